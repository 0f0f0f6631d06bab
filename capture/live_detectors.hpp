// Detectors that run on samples as they are recorded:
// - TapDetector finds sync taps, the sharp jerk spikes of tapping the device, so a recording
//   can be aligned with video or motion capture that saw the same tap;
// - PoseGuide counts the distinct still poses held during a guided multi-position capture
//   (the protocol of Tedaldi, Pretto & Menegatti, ICRA 2014) and says when there are enough.
// Both are streaming (constant memory, one sample at a time) so the recorder can run them live.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <vector>

#include "imukit/core/time.hpp"

namespace imukit::capture {

struct TapDetectorOptions {
  // A tap is a jerk (|a_k - a_k-1| / dt) above both this floor and `factor` times the running
  // typical jerk. A firm tap with a finger gives thousands of m/s^3, walking a few hundred.
  double min_jerk = 1000.0;  // m/s^3
  double factor = 20.0;
  double refractory_s = 0.25;   // one tap, one event
  double baseline_tau_s = 2.0;  // time constant of the running typical jerk
};

class TapDetector {
 public:
  explicit TapDetector(TapDetectorOptions options = {}) : opt_(options) {}
  // Returns the time of a tap that starts at this sample.
  std::optional<TimeNs> feed(TimeNs t, const Eigen::Vector3d& accel);

 private:
  TapDetectorOptions opt_;
  bool have_previous_ = false;
  TimeNs previous_t_ = 0;
  Eigen::Vector3d previous_a_ = Eigen::Vector3d::Zero();
  double baseline_ = -1.0;  // running typical jerk; negative until the first estimate
  TimeNs last_tap_ = 0;
  bool tapped_ = false;
};

struct PoseGuideOptions {
  int poses_wanted = 6;         // distinct orientations to collect
  double still_s = 2.0;         // how long a pose must be held
  double window_s = 0.5;        // window of the stillness test
  double max_accel_var = 0.05;  // (m/s^2)^2, sum over axes, within the window
  double max_gyro_norm = 0.1;   // rad/s, mean |w| within the window (when a gyro is present)
  double min_separation_deg =
      30.0;  // a new pose's gravity direction differs this much from all others
  // The first pose counts only once the device has been still this long: the initial static
  // period whose variance sets a multi-position calibration's stillness threshold (Tedaldi et
  // al.; `imukit calibrate --init-static`). 0: the first pose is like any other.
  double initial_still_s = 0.0;
};

struct PoseEvent {
  enum class Kind { still, new_pose, repeated_pose, done };
  Kind kind;
  TimeNs t;
  int count;                    // distinct poses so far
  Eigen::Vector3d gravity_dir;  // unit vector, sensor frame (what the accelerometer saw)
  TimeNs still_since = 0;       // start of the stillness that made this pose
  bool initial = false;         // the first pose, held for the initial still period
};

class PoseGuide {
 public:
  explicit PoseGuide(PoseGuideOptions options = {}) : opt_(options) {}
  // One sample (gyro may be null). Returns what happened at it, if anything.
  std::optional<PoseEvent> feed(TimeNs t, const Eigen::Vector3d& accel,
                                const Eigen::Vector3d* gyro);
  int count() const { return static_cast<int>(poses_.size()); }
  bool done() const { return count() >= opt_.poses_wanted; }
  const std::vector<Eigen::Vector3d>& poses() const { return poses_; }

 private:
  PoseGuideOptions opt_;
  struct Entry {
    TimeNs t;
    Eigen::Vector3d a;
    double w;
  };
  std::deque<Entry> window_;
  Eigen::Vector3d sum_a_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_a2_ = Eigen::Vector3d::Zero();
  double sum_w_ = 0.0;
  bool still_ = false;
  TimeNs still_since_ = 0;
  bool pose_taken_ = false;  // this stillness already produced its pose
  Eigen::Vector3d still_sum_ = Eigen::Vector3d::Zero();
  std::size_t still_n_ = 0;
  std::vector<Eigen::Vector3d> poses_;
};

}  // namespace imukit::capture
