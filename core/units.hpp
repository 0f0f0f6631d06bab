// Physical constants imukit uses (SI inside, DESIGN.md): defined once here so that the unit "g"
// of a file, a device's full scale in g and the default gravity of every command are one number.
#pragma once

#include <Eigen/Core>
#include <numbers>
#include <optional>
#include <string_view>

namespace imukit {

// Standard gravity g_n in m/s^2, exact by definition (3rd CGPM, 1901): the unit "g" of devices
// and files, and the default magnitude of gravity (a command's --gravity sets the local value).
inline constexpr double kStandardGravity = 9.80665;

// Degrees and radians (files and command lines speak degrees; the code radians).
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Gravity in the world frame by default: standard gravity along -Z (world Z points up).
inline const Eigen::Vector3d kStandardGravityWorld(0.0, 0.0, -kStandardGravity);

// The factor to SI of a unit named on a command line or in a device URI, one spelling list for
// both (the URI's text codec knew only mps2 and dps until review, 2026-11-27): accelerations
// m/s^2 (mps2), g, mg; angular rates rad/s (radps, rads), deg/s (dps). nullopt: not a unit.
inline std::optional<double> acceleration_unit_factor(std::string_view unit) {
  if (unit == "m/s^2" || unit == "mps2") return 1.0;
  if (unit == "g") return kStandardGravity;
  if (unit == "mg") return kStandardGravity * 1e-3;
  return std::nullopt;
}
inline std::optional<double> angular_rate_unit_factor(std::string_view unit) {
  if (unit == "rad/s" || unit == "radps" || unit == "rads") return 1.0;
  if (unit == "deg/s" || unit == "dps") return kRadPerDeg;
  return std::nullopt;
}

}  // namespace imukit
