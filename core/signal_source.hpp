// SignalSource: anything that can say what an ideal IMU would measure at given times: the true
// specific force and angular rate in the sensor frame. A simulated scene is one, a still device
// in a fixed orientation is another; mock devices and the hardware model consume them, so the
// left end of the data flow (drivers) never needs to know about the right end (sim).
#pragma once

#include <Eigen/Core>
#include <span>

#include "imukit/core/time.hpp"

namespace imukit {

class SignalSource {
 public:
  virtual ~SignalSource() = default;

  // Fills column i of specific_force (m/s^2, sensor frame, +g upward at rest) and angular_rate
  // (rad/s, sensor frame) with the true values at times[i]. Times are in the source's own
  // timeline (ns) and increase. Either output may be null when the caller does not need it;
  // a non-null output has times.size() columns.
  virtual void evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                        Eigen::Matrix3Xd* angular_rate) = 0;
};

}  // namespace imukit
