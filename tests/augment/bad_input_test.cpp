// Policies are bounded when they are read, and a dataset too large for memory is refused before
// it is allocated (issue 16).
#include <gtest/gtest.h>

#include <string>

#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/core/error.hpp"
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
  // The limit is the caller's to set: 100 windows of 50 x 6 float32 (+16 bytes) need 121600.
  o.count = 100;
  o.max_bytes = 121'599;
  expect_error([&] { generate_dataset(scene, builtin_policy("imukit"), {}, o); },
               {"100 windows x 50 samples x 6 channels"});
  o.max_bytes = 121'600;
  EXPECT_EQ(generate_dataset(scene, builtin_policy("imukit"), {}, o).y.size(), 100u);
}

}  // namespace
}  // namespace imukit::augment
