#include "imukit/drivers/sources.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "imukit/core/so3.hpp"

namespace imukit::drivers {

StaticSource::StaticSource(const Eigen::Quaterniond& q_world_sensor, double gravity) {
  f_sensor_ = q_world_sensor.normalized().conjugate() * Eigen::Vector3d(0, 0, gravity);
}

void StaticSource::evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                            Eigen::Matrix3Xd* angular_rate) {
  const auto n = static_cast<Eigen::Index>(times.size());
  if (specific_force) *specific_force = f_sensor_.replicate(1, n);
  if (angular_rate) angular_rate->setZero(3, n);
}

PosesSource::PosesSource(std::vector<Eigen::Quaterniond> q_world_sensor, double hold_s,
                         double move_s, double gravity, double first_hold_s)
    : poses_(std::move(q_world_sensor)),
      hold_s_(hold_s),
      move_s_(move_s),
      gravity_(gravity),
      extra_first_s_(std::max(0.0, first_hold_s - hold_s)) {
  assert(!poses_.empty() && hold_s_ >= 0 && move_s_ > 0);
  for (auto& q : poses_) q.normalize();
}

std::vector<Eigen::Quaterniond> PosesSource::six_faces() {
  using Eigen::AngleAxisd;
  using Eigen::Vector3d;
  const double pi = 3.14159265358979323846;
  // R_world_sensor maps the named sensor axis onto world +z.
  // Ordered so that consecutive poses are never opposite (a half turn has no unique shortest
  // path): +z, +x, +y, -z, -x, -y.
  return {Eigen::Quaterniond::Identity(),
          Eigen::Quaterniond(AngleAxisd(-pi / 2, Vector3d::UnitY())),
          Eigen::Quaterniond(AngleAxisd(pi / 2, Vector3d::UnitX())),
          Eigen::Quaterniond(AngleAxisd(pi, Vector3d::UnitX())),
          Eigen::Quaterniond(AngleAxisd(pi / 2, Vector3d::UnitY())),
          Eigen::Quaterniond(AngleAxisd(-pi / 2, Vector3d::UnitX()))};
}

std::vector<Eigen::Quaterniond> PosesSource::tilt_tour(int count) {
  assert(count >= 1 && count <= 26);
  // The candidate up directions (sensor frame): faces, then edges, then corners; ties in the
  // nearest-neighbour search go to the earlier one, so the tour is fixed.
  std::vector<Eigen::Vector3d> dirs;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        if (x != 0 || y != 0 || z != 0) dirs.emplace_back(Eigen::Vector3d(x, y, z).normalized());
      }
    }
  }
  std::stable_sort(
      dirs.begin(), dirs.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
        return a.cwiseAbs().maxCoeff() > b.cwiseAbs().maxCoeff() + 1e-9;  // faces, edges, corners
      });
  std::vector<bool> used(dirs.size(), false);
  std::size_t at = 0;
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    if (dirs[i].z() > 0.999) at = i;  // start with +z up
  }
  used[at] = true;
  std::vector<Eigen::Quaterniond> poses{Eigen::Quaterniond::Identity()};  // R_world_sensor
  while (static_cast<int>(poses.size()) < count) {
    std::size_t next = dirs.size();
    for (std::size_t i = 0; i < dirs.size(); ++i) {
      if (!used[i] &&
          (next == dirs.size() || dirs[i].dot(dirs[at]) > dirs[next].dot(dirs[at]) + 1e-12))
        next = i;
    }
    // R_next = R_at Q with Q dirs[next] = dirs[at]: then R_next dirs[next] = R_at dirs[at] = z.
    const Eigen::Quaterniond Q = Eigen::Quaterniond::FromTwoVectors(dirs[next], dirs[at]);
    poses.push_back((poses.back() * Q).normalized());
    used[next] = true;
    at = next;
  }
  return poses;
}

double PosesSource::duration_s() const {
  return extra_first_s_ + static_cast<double>(poses_.size()) * hold_s_ +
         static_cast<double>(poses_.size() - 1) * move_s_;
}

Eigen::Quaterniond PosesSource::orientation(double t, int* held) const {
  t = std::max(0.0, t - extra_first_s_);  // the first pose's longer hold
  const double cycle = hold_s_ + move_s_;
  const auto last = static_cast<int>(poses_.size()) - 1;
  int k = t <= 0 ? 0 : static_cast<int>(std::floor(t / cycle));
  if (k >= last) {
    if (held) *held = last;
    return poses_.back();
  }
  const double in = t - k * cycle;
  if (in < hold_s_) {
    if (held) *held = k;
    return poses_[k];
  }
  if (held) *held = -1;
  const double u = (in - hold_s_) / move_s_;
  return slerp(poses_[k], poses_[k + 1], u * u * (3 - 2 * u));
}

void PosesSource::evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                           Eigen::Matrix3Xd* angular_rate) {
  const auto n = static_cast<Eigen::Index>(times.size());
  if (specific_force) specific_force->resize(3, n);
  if (angular_rate) angular_rate->resize(3, n);
  const double cycle = hold_s_ + move_s_;
  const auto last = static_cast<int>(poses_.size()) - 1;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t_s = to_seconds(times[static_cast<std::size_t>(i)]);
    const Eigen::Quaterniond q = orientation(t_s);
    const double t = std::max(0.0, t_s - extra_first_s_);
    const Eigen::Matrix3d R_sensor_world = q.toRotationMatrix().transpose();
    if (specific_force) specific_force->col(i) = R_sensor_world * Eigen::Vector3d(0, 0, gravity_);
    if (angular_rate) {
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      const int k = t <= 0 ? 0 : static_cast<int>(std::floor(t / cycle));
      const double in = t - k * cycle;
      if (k < last && in >= hold_s_) {
        const double u = (in - hold_s_) / move_s_;
        const double ds_dt = 6 * u * (1 - u) / move_s_;
        // slerp(q0, q1, s) = q0 exp(s log(q0^-1 q1)): body-frame rate log(q0^-1 q1) ds/dt of
        // the intermediate frame, which in world coordinates is q0 * that.
        const Eigen::Vector3d phi_body = so3_log(poses_[k].conjugate() * poses_[k + 1]);
        const Eigen::Vector3d w_world = poses_[k] * (phi_body * ds_dt);
        w = R_sensor_world * w_world;
      }
      angular_rate->col(i) = w;
    }
  }
}

}  // namespace imukit::drivers
