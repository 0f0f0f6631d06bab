// Fuzzes the joint-quaternion motion CSV reader (`identify --motion`, scenes' "csv" motions) on
// the default humanoid, and what follows: what parses must be a unit-quaternion motion over the
// body's joints, and a short one is simulated with the left-wrist watch preset (finite output or
// a clean imukit::Error). Only imukit::Error may escape.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "imukit/core/error.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/simulator.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const imukit::sim::Body body = imukit::sim::Body::default_humanoid();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  imukit::sim::Motion motion;
  try {
    motion = imukit::sim::parse_quaternion_csv(text, "fuzz.csv", body);
  } catch (const imukit::Error&) {
    return 0;
  }
  if (motion.joint_count() != body.size() || !(motion.rate_hz() > 0)) std::abort();
  for (int64_t f = 0; f < motion.frames(); ++f) {
    if (!motion.root_translation(f).allFinite()) std::abort();
    for (std::size_t j = 0; j < body.size(); ++j) {
      if (std::abs(motion.rotation(f, j).norm() - 1.0) > 1e-12) std::abort();
    }
  }
  if (motion.frames() < 2 || motion.frames() > 64) return 0;
  imukit::sim::SensorSpec s;
  s.name = "watch";
  s.placement = imukit::sim::preset_placement("left_wrist_watch", body);
  for (const auto method :
       {imukit::sim::DerivativeMethod::fd, imukit::sim::DerivativeMethod::spline}) {
    try {
      imukit::sim::SimulationOptions o;
      o.method = method;
      imukit::sim::Simulator sim(body, {s}, o);
      sim.run(motion, [](std::size_t, const imukit::sim::SensorBlock& b) {
        if (!b.specific_force.allFinite() || !b.angular_rate.allFinite()) std::abort();
      });
    } catch (const imukit::Error&) {
    }
  }
  return 0;
}
