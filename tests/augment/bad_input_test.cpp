// Policies are bounded when they are read, and a dataset too large for memory is refused before
// it is allocated (issue 16).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <limits>
#include <string>

#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/core/npy.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "support/expect_error.hpp"
#include "support/procedural_scene.hpp"

namespace imukit::augment {
namespace {

using imukit::testing::expect_error;

std::string policy_with(const std::string& sub_policy) {
  return R"({"schema": "imukit.policy/1", "sub_policies": [)" + sub_policy + "]}";
}

TEST(BadInput, PolicyParametersAreBoundedWhenRead) {
  // sigma 1e300 used to pass the reader and abort in so3_log when a window was drawn.
  expect_error(
      [] {
        parse_policy(policy_with(R"({"amplitude": {"method": "scaling", "sigma": 1e300}})"),
                     "p.json", "");
      },
      {"p.json: sub_policies[0].amplitude.sigma: expected a number in [0, 2], got 1e+300"});
  expect_error(
      [] {
        parse_policy(policy_with(R"({"speed": {"method": "scaling", "range": [1e-300, 1]}})"),
                     "p.json", "");
      },
      {"sub_policies[0].speed.range", "0.01 <= lo <= hi <= 100"});
  expect_error(
      [] { parse_policy(policy_with(R"({"hardware": {"accel_noise": 1e30}})"), "p.json", ""); },
      {"sub_policies[0].hardware.accel_noise: expected a number in [0, 1000] m/s^2"});
  expect_error(
      [] { parse_policy(policy_with(R"({"hardware": {"gyro_bias": 101}})"), "p.json", ""); },
      {"sub_policies[0].hardware.gyro_bias", "[0, 100] rad/s"});
  expect_error(
      [] {
        parse_policy(R"({"schema": "imukit.policy/1", "sub_policies": [{}, {}],
                         "probabilities": [1e308, 1e308]})",
                     "p.json", "");
      },
      {"probabilities", "finite"});
  // The largest plausible values pass.
  EXPECT_NO_THROW(
      parse_policy(policy_with(R"({"amplitude": {"method": "warping", "sigma": 2, "knots": 4},
                      "hardware": {"accel_noise": 1000, "gyro_noise": 100}})"),
                   "p.json", ""));
}

TEST(BadInput, PolicyValidateAppliesTheSameLimitsToPoliciesBuiltInCode) {
  Policy p = builtin_policy("imukit");
  EXPECT_NO_THROW(p.validate());
  p.sub_policies[3].amplitude.sigma = 1e300;
  expect_error([&] { p.validate(); }, {"sub-policy 3: amplitude sigma outside [0, 2]"});
  p = builtin_policy("imukit");
  p.sub_policies[0].placement.rotation_range_rad.x() = 10.0;
  expect_error([&] { p.validate(); }, {"placement half-widths"});
}

sim::Scene short_watch_scene() {
  sim::Scene scene = testing::preset_scene({"left_wrist_watch"}, {.rate_hz = 50, .frames = 200});
  scene.sensors[0].spec.name = "watch";
  return scene;
}

TEST(BadInput, DatasetTooLargeForMemoryIsRefusedBeforeAllocating) {
  // --count 1e8 used to end in std::bad_alloc (or vector::_M_default_append for -1).
  const sim::Scene scene = short_watch_scene();
  DatasetOptions o;
  o.window = 50;
  o.count = 1'000'000'000'000;
  expect_error([&] { generate_dataset(scene, builtin_policy("imukit"), {}, o); },
               {"augment: 1000000000000 windows x 50 samples x 6 channels need", "GiB", "--count"});
  // The limit is the caller's to set: 100 windows of 50 x 6 float32 (+16 bytes) need 121600,
  // and the batch they are made in (all 100 here, the batch size being 256) 120000 more.
  o.count = 100;
  o.max_bytes = 241'599;
  expect_error([&] { generate_dataset(scene, builtin_policy("imukit"), {}, o); },
               {"100 windows x 50 samples x 6 channels"});
  o.max_bytes = 241'600;
  EXPECT_EQ(generate_dataset(scene, builtin_policy("imukit"), {}, o).y.size(), 100u);
}

// A recording of n samples at 50 Hz, one stream "watch", every sample the same at rest.
ImuSeries still_recording(std::size_t n) {
  ImuSeries s;
  s.t.resize(n);
  for (std::size_t i = 0; i < n; ++i) s.t[i] = static_cast<TimeNs>(i) * 20'000'000;
  s.accel = Eigen::Matrix3Xd::Zero(3, static_cast<Eigen::Index>(n));
  s.accel.row(2).setConstant(9.81);
  s.gyro = Eigen::Matrix3Xd::Zero(3, static_cast<Eigen::Index>(n));
  return s;
}

// Found in review (2026-11-27): a NaN sample went into the windows (with --normalize into a
// whole channel and its statistics), exit 0.
TEST(BadInput, ANonFiniteSampleOfARecordingIsNamed) {
  ImuSeries s = still_recording(300);
  s.accel(0, 150) = std::numeric_limits<double>::quiet_NaN();
  DatasetOptions o;
  o.window = 100;
  o.stride = 50;
  expect_error([&] { generate_dataset({"watch"}, {&s}, builtin_policy("paper"), {}, o); },
               {"stream 'watch': the accelerometer of sample 150 (t = 3.000000000 s) is not "
                "finite"});
  s.accel(0, 150) = 0.0;
  s.gyro(2, 7) = -std::numeric_limits<double>::infinity();
  expect_error([&] { generate_dataset({"watch"}, {&s}, builtin_policy("paper"), {}, o); },
               {"the gyroscope of sample 7 (t = 0.140000000 s) is not finite"});
}

// Found in review (2026-11-27): STDA failed at the first batch that drew a speed whose window
// did not fit in the recording (hours in, for a long run); it is refused before any work.
TEST(BadInput, ATimeScalingThatCannotFitTheRecordingIsRefusedBeforeAnyWork) {
  const ImuSeries s = still_recording(300);
  const Policy fast = parse_policy(
      policy_with(R"({"speed": {"method": "scaling", "range": [1.6, 2.0]}})"), "fast.json", "");
  DatasetOptions o;
  o.window = 200;
  o.stride = 50;
  expect_error([&] { generate_dataset({"watch"}, {&s}, fast, {}, o); },
               {"sub-policy 0 scales time up to 2x: a window of 200 samples then spans 399 "
                "samples, and the recording has 300"});
  o.window = 150;  // 2 x 149 + 1 = 299 samples fit
  EXPECT_EQ(generate_dataset({"watch"}, {&s}, fast, {}, o).y.size(), 4u);
}

// Found in review (2026-11-27): when every window's drawn speed needed more motion than the
// scene has, every window was written unaugmented, and the run reported success.
TEST(BadInput, APpdaRunThatAugmentsNoWindowIsAnError) {
  const sim::Scene scene = short_watch_scene();  // 200 frames at 50 Hz
  const Policy fast = parse_policy(
      policy_with(R"({"speed": {"method": "scaling", "range": [1.6, 2.0]}})"), "fast.json", "");
  DatasetOptions o;
  o.window = 150;
  o.stride = 25;
  expect_error([&] { generate_dataset(scene, fast, {}, o); },
               {"each of the 3 windows to augment drew a speed that needs more motion than the "
                "scene has around it",
                "nothing would be augmented"});
}

// Found in review (2026-11-27): a failed write left new X.npy and y.npy beside the dataset.json
// of an earlier run of another shape. dataset.json is now removed first and written last.
TEST(BadInput, AFailedDatasetWriteLeavesNoDescriptionOfAnotherRun) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("imukit_dataset_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const sim::Scene scene = short_watch_scene();
  DatasetOptions o;
  o.window = 50;
  o.stride = 50;
  o.count = 7;
  Dataset d = generate_dataset(scene, builtin_policy("imukit"), {}, o);
  write_dataset(dir.string(), d.X, d.shape, d.y, d.sub_policy, d.info);
  ASSERT_TRUE(std::filesystem::exists(dir / "dataset.json"));
  EXPECT_EQ(d.info.method, "spline");
  // The third file cannot be written: a folder stands where it goes.
  std::filesystem::remove(dir / "sub_policy.npy");
  std::filesystem::create_directory(dir / "sub_policy.npy");
  o.count = 3;
  o.method = sim::DerivativeMethod::reference;
  d = generate_dataset(scene, builtin_policy("imukit"), {}, o);
  EXPECT_EQ(d.info.method, "reference");  // it said "spline" (found in review, 2026-11-27)
  EXPECT_THROW(write_dataset(dir.string(), d.X, d.shape, d.y, d.sub_policy, d.info), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "dataset.json"));
  // No temporary is left behind either, and the arrays written are whole.
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().extension() == ".tmp", false) << entry.path();
  EXPECT_EQ(read_npy((dir / "X.npy").string()).shape, (std::vector<std::size_t>{3, 50, 6}));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace imukit::augment
