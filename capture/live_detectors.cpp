#include "imukit/capture/live_detectors.hpp"

#include <algorithm>
#include <cmath>

#include "imukit/core/units.hpp"

namespace imukit::capture {

std::optional<TimeNs> TapDetector::feed(TimeNs t, const Eigen::Vector3d& accel) {
  std::optional<TimeNs> tap;
  if (have_previous_ && t > previous_t_) {
    const double dt = to_seconds(t - previous_t_);
    const double jerk = (accel - previous_a_).norm() / dt;
    if (baseline_ < 0) {
      baseline_ = jerk;
    } else {
      const bool spike = jerk > opt_.min_jerk && jerk > opt_.factor * baseline_;
      if (spike && (!tapped_ || to_seconds(t - last_tap_) >= opt_.refractory_s)) {
        tap = previous_t_;  // the jump started after the previous sample
        last_tap_ = t;
        tapped_ = true;
      }
      // Winsorised running mean: a spike may raise the typical jerk only a little, so a tap
      // does not blind the detector to the next one.
      const double alpha = std::min(1.0, dt / opt_.baseline_tau_s);
      baseline_ += alpha * (std::min(jerk, 3.0 * baseline_ + 1e-9) - baseline_);
    }
  }
  have_previous_ = true;
  previous_t_ = t;
  previous_a_ = accel;
  return tap;
}

std::optional<PoseEvent> PoseGuide::feed(TimeNs t, const Eigen::Vector3d& accel,
                                         const Eigen::Vector3d* gyro) {
  const double w = gyro ? gyro->norm() : 0.0;
  window_.push_back({t, accel, w});
  sum_a_ += accel;
  sum_a2_ += accel.cwiseProduct(accel);
  sum_w_ += w;
  while (!window_.empty() && to_seconds(t - window_.front().t) > opt_.window_s) {
    sum_a_ -= window_.front().a;
    sum_a2_ -= window_.front().a.cwiseProduct(window_.front().a);
    sum_w_ -= window_.front().w;
    window_.pop_front();
  }
  const double n = static_cast<double>(window_.size());
  const bool full = to_seconds(t - window_.front().t) >= 0.9 * opt_.window_s && n >= 3;
  // Variance from running sums (accelerations are O(10) and the window short, so the
  // cancellation costs at most ~1e-12 relative; the threshold is 1e-2).
  const Eigen::Vector3d mean = sum_a_ / n;
  const double var = std::max(0.0, (sum_a2_ / n - mean.cwiseProduct(mean)).sum());
  const bool still = full && var < opt_.max_accel_var && (!gyro || sum_w_ / n < opt_.max_gyro_norm);

  if (!still) {
    still_ = false;
    return std::nullopt;
  }
  if (!still_) {
    still_ = true;
    still_since_ = window_.front().t;
    pose_taken_ = false;
    still_sum_.setZero();
    still_n_ = 0;
  }
  still_sum_ += accel;
  ++still_n_;
  const bool initial = poses_.empty() && opt_.initial_still_s > 0;
  const double hold = initial ? std::max(opt_.still_s, opt_.initial_still_s) : opt_.still_s;
  if (pose_taken_ || to_seconds(t - still_since_) < hold) return std::nullopt;
  pose_taken_ = true;
  const Eigen::Vector3d dir = still_sum_.normalized();
  const double cos_min = std::cos(opt_.min_separation_deg * kRadPerDeg);
  for (const Eigen::Vector3d& p : poses_) {
    if (p.dot(dir) > cos_min)
      return PoseEvent{PoseEvent::Kind::repeated_pose, t, count(), dir, still_since_, false};
  }
  poses_.push_back(dir);
  return PoseEvent{done() ? PoseEvent::Kind::done : PoseEvent::Kind::new_pose,
                   t,
                   count(),
                   dir,
                   still_since_,
                   initial};
}

}  // namespace imukit::capture
