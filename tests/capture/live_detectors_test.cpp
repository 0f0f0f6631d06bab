#include "imukit/capture/live_detectors.hpp"

#include <gtest/gtest.h>
#include <cmath>

#include "imukit/core/rng.hpp"

namespace imukit::capture {
namespace {

constexpr double kRate = 200.0;

// Noise of a consumer IMU at rest: 0.02 m/s^2 per sample.
Eigen::Vector3d still(Rng& rng) {
  return Eigen::Vector3d(0.02 * rng.normal(), 0.02 * rng.normal(), 9.80665 + 0.02 * rng.normal());
}

TEST(TapDetector, FindsEveryTapAtItsSampleAndNothingElse) {
  Rng rng(1);
  TapDetector detector;
  const std::vector<int64_t> taps = {2000, 2100, 9000, 30000, 60000};  // sample indices
  std::vector<TimeNs> found;
  for (int64_t i = 0; i < 120'000; ++i) {  // 10 minutes
    Eigen::Vector3d a = still(rng);
    for (int64_t k : taps) {
      // A 15 ms half-sine of 3 g along x: the tap.
      const double u = static_cast<double>(i - k) / kRate / 0.015;
      if (u >= 0 && u <= 1) a.x() += 3 * 9.80665 * std::sin(M_PI * u);
    }
    if (auto t = detector.feed(sample_time(0, i, kRate), a)) found.push_back(*t);
  }
  ASSERT_EQ(found.size(), taps.size());
  for (std::size_t k = 0; k < taps.size(); ++k) {
    EXPECT_EQ(found[k], sample_time(0, taps[k], kRate)) << k;
  }
}

TEST(TapDetector, IgnoresWalkingArmSwing) {
  Rng rng(2);
  TapDetector detector;
  int found = 0;
  for (int64_t i = 0; i < 60'000; ++i) {  // 5 minutes of 1 Hz arm swing, 12 m/s^2 peaks
    const double t = static_cast<double>(i) / kRate;
    Eigen::Vector3d a = still(rng);
    a.x() += 12.0 * std::sin(2 * M_PI * 1.0 * t) + 4.0 * std::sin(2 * M_PI * 2.0 * t);
    a.y() += 6.0 * std::cos(2 * M_PI * 1.0 * t);
    if (detector.feed(sample_time(0, i, kRate), a)) ++found;
  }
  EXPECT_EQ(found, 0);
}

// Held still in `dirs` in turn (3 s each) with 1 s rotations between them.
struct PoseRun {
  std::vector<PoseEvent> events;
};

PoseRun run_poses(const std::vector<Eigen::Vector3d>& dirs, PoseGuideOptions options = {}) {
  Rng rng(3);
  PoseGuide guide(options);
  PoseRun run;
  int64_t i = 0;
  for (std::size_t p = 0; p < dirs.size(); ++p) {
    for (int k = 0; k < 600; ++k, ++i) {  // 3 s still
      const Eigen::Vector3d a =
          9.80665 * dirs[p] +
          Eigen::Vector3d(0.02 * rng.normal(), 0.02 * rng.normal(), 0.02 * rng.normal());
      const Eigen::Vector3d w(0.002 * rng.normal(), 0.002 * rng.normal(), 0.002 * rng.normal());
      if (auto e = guide.feed(sample_time(0, i, kRate), a, &w)) run.events.push_back(*e);
    }
    if (p + 1 == dirs.size()) break;
    for (int k = 0; k < 200; ++k, ++i) {  // 1 s of rotation towards the next pose
      const double u = k / 200.0;
      const Eigen::Vector3d a = 9.80665 * ((1 - u) * dirs[p] + u * dirs[p + 1]).normalized() +
                                Eigen::Vector3d(3.0 * std::sin(M_PI * u), 0, 0);
      const Eigen::Vector3d w(1.5, 0.5 * std::sin(M_PI * u), 0);
      if (auto e = guide.feed(sample_time(0, i, kRate), a, &w)) run.events.push_back(*e);
    }
  }
  return run;
}

TEST(PoseGuide, CountsDistinctPosesAndSaysWhenThereAreEnough) {
  const std::vector<Eigen::Vector3d> dirs = {{0, 0, 1},  {1, 0, 0},  {0, 0, 1},       {0, 1, 0},
                                             {0, 0, -1}, {-1, 0, 0}, {0.1, -0.995, 0}};
  const PoseRun run = run_poses(dirs);
  ASSERT_EQ(run.events.size(), 7u);  // one event per still pose
  EXPECT_EQ(run.events[0].kind, PoseEvent::Kind::new_pose);
  EXPECT_EQ(run.events[2].kind, PoseEvent::Kind::repeated_pose);  // +z again
  EXPECT_EQ(run.events[5].count, 5);
  EXPECT_EQ(run.events[6].kind, PoseEvent::Kind::done);
  EXPECT_EQ(run.events[6].count, 6);
  for (std::size_t k = 0; k < run.events.size(); ++k) {
    EXPECT_GT(run.events[k].gravity_dir.dot(dirs[k].normalized()), std::cos(1.0 * M_PI / 180)) << k;
  }
  // Each pose is reported once it has been held for 2 s, counted from the start of the first
  // still window.
  EXPECT_NEAR(to_seconds(run.events[0].t), 2.0, 0.01);
  EXPECT_NEAR(to_seconds(run.events[1].t), 4.0 + 2.0,
              0.6);  // stillness begins once the window is clear of the rotation
}

TEST(PoseGuide, NearbyOrientationsAreNotNewPoses) {
  const PoseRun run = run_poses({{0, 0, 1}, {0.2, 0, 0.98}, {0, 0.3, 0.95}});  // within 20 degrees
  ASSERT_EQ(run.events.size(), 3u);
  EXPECT_EQ(run.events[1].kind, PoseEvent::Kind::repeated_pose);
  EXPECT_EQ(run.events[2].kind, PoseEvent::Kind::repeated_pose);
}

}  // namespace
}  // namespace imukit::capture
