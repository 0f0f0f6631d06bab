// Fuzzes the BVH reader. Only imukit::Error may escape. What parses must be a valid body and a
// unit-quaternion motion, and (for short motions) simulate a sensor on its deepest joint with
// finite output or a clean imukit::Error.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "imukit/core/error.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/simulator.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  imukit::sim::BvhData d;
  try {
    d = imukit::sim::parse_bvh(text, "fuzz.bvh", {.scale = 0.01, .up = imukit::sim::UpAxis::y});
  } catch (const imukit::Error&) {
    return 0;
  }
  if (d.body.size() == 0 || d.motion.joint_count() != d.body.size()) std::abort();
  for (int64_t f = 0; f < d.motion.frames(); ++f) {
    for (std::size_t j = 0; j < d.body.size(); ++j) {
      if (std::abs(d.motion.rotation(f, j).norm() - 1.0) > 1e-12) std::abort();
    }
  }
  if (d.motion.frames() < 2 || d.motion.frames() > 64 || d.body.size() > 64) return 0;
  imukit::sim::SensorSpec s;
  s.name = "fuzz";
  s.placement.joint = static_cast<int>(d.body.size()) - 1;
  s.placement.p_joint_sensor = Eigen::Vector3d(0.01, 0.02, 0.03);
  for (const auto method :
       {imukit::sim::DerivativeMethod::fd, imukit::sim::DerivativeMethod::spline}) {
    try {
      imukit::sim::SimulationOptions o;
      o.method = method;
      imukit::sim::Simulator sim(d.body, {s}, o);
      sim.run(d.motion, [](std::size_t, const imukit::sim::SensorBlock&) {});
    } catch (const imukit::Error&) {
    }
  }
  return 0;
}
