// A silent device ends a recording with a reason instead of never ending, and a guided capture
// asks for the initial still period a calibration needs (issue 16).
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "imukit/capture/live_detectors.hpp"
#include "imukit/capture/recording_mcap.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/time.hpp"
#include "imukit/drivers/uri.hpp"
#include "support/test_data.hpp"

namespace imukit::capture {
namespace {

TEST(BadInput, ASilentDeviceIsStoppedByTheNoDataTimeout) {
  // drop=1 loses every frame: the data-time --duration was never reached and the session ran
  // until Ctrl-C.
  testing::TempDir dir;
  std::vector<SessionDevice> devices;
  devices.push_back({"silent", "mock:static?drop=1&clock=virtual",
                     drivers::open_device("mock:static?drop=1&clock=virtual"), std::nullopt});
  SessionOptions o;
  o.path = (dir / "silent.mcap").string();
  o.duration_s = 5;
  o.no_data_timeout_s = 0.3;
  const auto start = std::chrono::steady_clock::now();
  const SessionReport r = record_session(std::move(devices), o);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.stop_reason, "no data from any device for 0.3 s");
  ASSERT_EQ(r.devices.size(), 1u);
  EXPECT_EQ(r.devices[0].samples, 0u);
  EXPECT_NE(r.devices[0].end_reason.find("no data for 0.3 s since the start"), std::string::npos)
      << r.devices[0].end_reason;
  EXPECT_LT(wall, 5.0);
}

// 200 Hz of a device lying still (0.02 m/s^2 of noise) except between the times in `moves`.
std::vector<PoseEvent> feed(PoseGuide& guide, double seconds,
                            const std::vector<std::pair<double, double>>& moves) {
  Rng rng(5);
  std::vector<PoseEvent> events;
  for (int64_t i = 0; i < int64_t(seconds * 200); ++i) {
    const double t = double(i) / 200;
    bool moving = false;
    for (const auto& [a, b] : moves) moving = moving || (t >= a && t < b);
    const Eigen::Vector3d a(0.02 * rng.normal() + (moving ? 3 * std::sin(20 * t) : 0),
                            0.02 * rng.normal(), 9.80665 + 0.02 * rng.normal());
    const Eigen::Vector3d w(moving ? 1.0 : 0.0, 0, 0);
    if (auto e = guide.feed(sample_time(0, i, 200.0), a, &w)) events.push_back(*e);
  }
  return events;
}

TEST(BadInput, GuidedCaptureCountsItsFirstPoseOnlyAfterTheInitialStillPeriod) {
  PoseGuideOptions o;
  o.initial_still_s = 10;
  {
    PoseGuide guide(o);
    const auto events = feed(guide, 9.0, {});
    EXPECT_TRUE(events.empty()) << "a pose after " << to_seconds(events.front().t) << " s";
  }
  {
    PoseGuide guide(o);
    const auto events = feed(guide, 12.0, {});
    ASSERT_EQ(events.size(), 1u);
    EXPECT_TRUE(events[0].initial);
    EXPECT_EQ(events[0].count, 1);
    EXPECT_NEAR(to_seconds(events[0].still_since), 0.0, 0.01);
    EXPECT_NEAR(to_seconds(events[0].t), 10.0, 0.01);
  }
  {
    // Moved at 4 s: the period starts again once the device is still.
    PoseGuide guide(o);
    const auto events = feed(guide, 16.0, {{4.0, 5.0}});
    ASSERT_EQ(events.size(), 1u);
    EXPECT_NEAR(to_seconds(events[0].still_since), 5.0, 0.6);
    EXPECT_NEAR(to_seconds(events[0].t - events[0].still_since), 10.0, 0.01);
  }
}

TEST(BadInput, GuidedCaptureRecordsWhereTheInitialStillPeriodStarts) {
  testing::TempDir dir;
  std::vector<SessionDevice> devices;
  const std::string uri = "mock:poses?clock=virtual&rate=100&poses=3";
  devices.push_back({"watch", uri, drivers::open_device(uri), std::nullopt});
  SessionOptions o;
  o.path = (dir / "poses.mcap").string();
  o.duration_s = 60;
  PoseGuideOptions guide;
  guide.poses_wanted = 3;
  guide.initial_still_s = 10;
  o.guide = guide;
  const SessionReport r = record_session(std::move(devices), o);
  EXPECT_EQ(r.stop_reason, "3 distinct poses held");
  const RecordingRead read = read_recording_mcap(o.path);
  EXPECT_EQ(read.recording.metadata.at("imukit.guide.initial_still_s"), "10");
  int initial = 0;
  for (const Event& e : read.recording.events) {
    if (e.kind != "initial_still") continue;
    ++initial;
    // mock:poses holds its first pose 12 s (init_s): still from the first sample.
    EXPECT_NEAR(to_seconds(e.t - read.recording.streams.at("watch").t.front()), 0.0, 0.6);
  }
  EXPECT_EQ(initial, 1);
}

}  // namespace
}  // namespace imukit::capture
