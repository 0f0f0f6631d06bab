// Physical constants imukit uses (SI inside, DESIGN.md): defined once here so that the unit "g"
// of a file, a device's full scale in g and the default gravity of every command are one number.
#pragma once

#include <Eigen/Core>
#include <numbers>

namespace imukit {

// Standard gravity g_n in m/s^2, exact by definition (3rd CGPM, 1901): the unit "g" of devices
// and files, and the default magnitude of gravity (a command's --gravity sets the local value).
inline constexpr double kStandardGravity = 9.80665;

// Degrees and radians (files and command lines speak degrees; the code radians).
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Gravity in the world frame by default: standard gravity along -Z (world Z points up).
inline const Eigen::Vector3d kStandardGravityWorld(0.0, 0.0, -kStandardGravity);

}  // namespace imukit
