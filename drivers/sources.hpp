// Signal sources for mock devices that need no simulator: a device held still in one
// orientation (StaticSource) and one placed in a sequence of still poses with smooth rotations
// between them (PosesSource, the input a multi-position calibration expects).
//
// Frames: world Z up, gravity g_world = (0, 0, -g); a still sensor measures the specific force
// f = R_world_sensor^T (0, 0, +g). The Earth's rotation is not modelled (gyro reads 0 at rest).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "imukit/core/signal_source.hpp"
#include "imukit/core/units.hpp"

namespace imukit::drivers {

class StaticSource : public SignalSource {
 public:
  explicit StaticSource(const Eigen::Quaterniond& q_world_sensor = Eigen::Quaterniond::Identity(),
                        double gravity = kStandardGravity);
  void evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                Eigen::Matrix3Xd* angular_rate) override;

 private:
  Eigen::Vector3d f_sensor_;
};

// Holds poses[0] for hold_s, rotates to poses[1] in move_s, holds it, ... and stays in the last
// pose. Each rotation follows slerp with the smoothstep profile s(u) = 3u^2 - 2u^3, so the
// angular rate starts and ends at zero: w_world = log(q_{k+1} q_k^-1) * ds/dt, and the gyro
// measures R_world_sensor^T w_world.
class PosesSource : public SignalSource {
 public:
  // The first pose is held max(hold_s, first_hold_s): a guided capture starts with a longer
  // still period (PoseGuideOptions::initial_still_s).
  PosesSource(std::vector<Eigen::Quaterniond> q_world_sensor, double hold_s, double move_s,
              double gravity = kStandardGravity, double first_hold_s = 0.0);
  // The six faces up, in the order +z, +x, +y, -z, -x, -y (the axis named points up).
  static std::vector<Eigen::Quaterniond> six_faces();
  // `count` (1..26) poses of a tilt tour over the 26 directions of a cube's faces, edges and
  // corners: the sensor direction that points up goes from +z to the nearest direction not yet
  // visited (35 to 90 degrees away), and each pose is the previous one tilted by the smallest
  // rotation that brings the new direction up, about an axis perpendicular to gravity, as a
  // person turns a device on a table. A multi-position calibration wants many such poses
  // (Tedaldi et al. use 30-50); the tour's rotation axes cover all three sensor axes.
  static std::vector<Eigen::Quaterniond> tilt_tour(int count);

  void evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                Eigen::Matrix3Xd* angular_rate) override;
  // Orientation at time t (s) and the index of the pose being held (-1 while rotating).
  Eigen::Quaterniond orientation(double t_s, int* held_pose = nullptr) const;
  double duration_s() const;

 private:
  std::vector<Eigen::Quaterniond> poses_;
  double hold_s_;
  double move_s_;
  double gravity_;
  double extra_first_s_;  // how much longer the first pose is held
};

}  // namespace imukit::drivers
