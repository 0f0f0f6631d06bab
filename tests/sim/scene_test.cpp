#include "sim/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"

namespace imukit::sim {
namespace {

const char* kScene = R"({
  "schema": "imukit.scene/1",
  "body": {"default_humanoid": {"height_m": 1.8}},
  "motion": {"procedural": {"rate_hz": 100, "duration_s": 20, "seed": 3}},
  "simulation": {"method": "spline", "rate_hz": 200, "seed": 42, "chunk_frames": 64},
  "outputs": {"ground_truth": true},
  "sensors": [
    {"name": "watch", "preset": "left_wrist_watch",
     "hardware": {"schema": "imukit.profile/1",
                  "accelerometer": {"noise": {"noise_density": [0.001, 0.001, 0.001]}},
                  "gyroscope": {"noise": {"noise_density": [0.0002, 0.0002, 0.0002]}}}},
    {"name": "custom", "segment": "right_forearm", "position_m": [0.2, 0, 0.03],
     "rotation": {"euler": [0, 0, 90], "order": "XYZ", "intrinsic": true, "unit": "deg"},
     "outputs": ["gyroscope", "accelerometer", "orientation"]}
  ]
})";

TEST(Scene, ParsesBodyMotionSensorsAndSettings) {
  const Scene s = parse_scene(kScene, "scene.json", "");
  EXPECT_EQ(s.body.size(), 21u);
  EXPECT_EQ(s.frames, 2001);
  EXPECT_EQ(s.options.method, DerivativeMethod::spline);
  EXPECT_EQ(s.options.rate_hz, 200.0);
  EXPECT_EQ(s.seed, 42u);
  ASSERT_EQ(s.sensors.size(), 2u);
  EXPECT_TRUE(s.sensors[0].hardware.has_value());
  EXPECT_EQ(s.sensors[1].spec.placement.joint, s.body.index_of("right_elbow"));
  EXPECT_NEAR(s.sensors[1].spec.placement.q_joint_sensor.z(), std::sqrt(0.5), 1e-15);
  EXPECT_TRUE(s.sensors[1].spec.outputs.orientation);
}

TEST(Scene, ErrorsNameThePathOrLine) {
  const auto message = [](const std::string& text) {
    try {
      parse_scene(text, "s.json", "");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("{\n  \"schema\": ,\n}").find("s.json:2:13"), std::string::npos)
      << message("{\n  \"schema\": ,\n}");
  std::string bad = kScene;
  bad.replace(bad.find("left_wrist_watch"), 16, "left_sock");
  EXPECT_NE(message(bad).find("sensors[0].preset"), std::string::npos) << message(bad);
  bad = kScene;
  bad.replace(bad.find("\"spline\""), 8, "\"euler\"");
  EXPECT_NE(message(bad).find("simulation.method"), std::string::npos);
  bad = kScene;
  bad.replace(bad.find("\"order\": \"XYZ\", "), 16, "");
  EXPECT_NE(message(bad).find("sensors[1].rotation"), std::string::npos) << message(bad);
  bad = kScene;
  bad.replace(bad.find("\"right_forearm\""), 15, "\"tail\"");
  EXPECT_NE(message(bad).find("sensors[1].segment"), std::string::npos);
  EXPECT_NE(message(R"({"schema": "imukit.scene/2"})").find("schema"), std::string::npos);
  // A number beyond double's range is the JSON library's out_of_range, reported as an Error
  // (found by fuzz_scene_json).
  EXPECT_NE(message("[6E666]").find("s.json"), std::string::npos);
}

TEST(Scene, RunIsDeterministicAndHardwareAddsTheStatedNoise) {
  Scene a = parse_scene(kScene, "scene.json", "");
  Scene b = parse_scene(kScene, "scene.json", "");
  std::vector<double> da, db;
  double sum_sq = 0;
  int64_t n = 0;
  const auto collect = [&](std::vector<double>& out, bool stats) {
    return
        [&out, stats, &sum_sq, &n](std::size_t s, const SensorBlock& m, const SensorBlock* truth) {
          ASSERT_NE(truth, nullptr);
          if (s != 0) {
            EXPECT_EQ(m.q_world_sensor.size(), m.t.size());
            return;
          }
          for (Eigen::Index i = 0; i < m.specific_force.cols(); ++i) {
            out.push_back(m.specific_force(0, i));
            if (stats) {
              sum_sq += (m.specific_force.col(i) - truth->specific_force.col(i)).squaredNorm();
              n += 3;
            }
          }
        };
  };
  run_scene(a, collect(da, true));
  run_scene(b, collect(db, false));
  EXPECT_EQ(da, db);
  EXPECT_EQ(static_cast<int64_t>(da.size()), 4001);
  // White noise sigma = density sqrt(rate) = 0.001 sqrt(200); 12003 draws: +-3 % at 2.3 sigma.
  EXPECT_NEAR(std::sqrt(sum_sq / static_cast<double>(n)), 0.001 * std::sqrt(200.0),
              0.03 * 0.001 * std::sqrt(200.0));
}

TEST(Scene, BatchIsTheSameForAnyThreadCount) {
  const Body body = Body::default_humanoid();
  ProceduralMotionOptions po;
  po.frames = 300;
  ProceduralMotion proc(body.size(), po);
  auto motion = std::make_shared<Motion>(proc.materialize(300));
  HardwareModel hw;
  hw.accelerometer.noise_density = Eigen::Vector3d::Constant(0.002);
  hw.gyroscope.turn_on_bias_spread = Eigen::Vector3d::Constant(0.01);
  std::vector<BatchJob> jobs;
  for (int i = 0; i < 9; ++i) {
    BatchJob j;
    j.motion = motion;
    SceneSensor s;
    s.spec.name = "w";
    s.spec.placement =
        resolve_preset(placement_preset(i % 2 ? "left_wrist_watch" : "chest_strap"), body);
    s.hardware = hw;
    j.sensors = {s};
    j.options.method = i % 3 == 0 ? DerivativeMethod::spline : DerivativeMethod::fd;
    jobs.push_back(j);
  }
  const auto one = simulate_batch(body, jobs, 7, 1);
  const auto four = simulate_batch(body, jobs, 7, 4);
  ASSERT_EQ(one.size(), 9u);
  for (std::size_t i = 0; i < 9; ++i) {
    EXPECT_EQ(one[i][0].accel, four[i][0].accel) << i;
    EXPECT_EQ(one[i][0].gyro, four[i][0].gyro) << i;
  }
  // Different jobs draw different noise (child streams), even with the same motion and placement.
  EXPECT_NE(one[1][0].accel, one[3][0].accel);
}

}  // namespace
}  // namespace imukit::sim
