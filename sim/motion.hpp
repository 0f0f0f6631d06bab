// Motion (the model's "Dynamics D", seed-summary section 1): at a constant frame rate, the root's
// world translation (m) and, per joint, the rotation of the joint relative to its parent (the
// root's rotation is its world orientation), as unit quaternions (Hamilton, active).
//
// Motion is read through MotionSource, which hands out any range of frames for any subset of
// joints, so the simulator can stream hours of motion in chunks with constant memory. Sources:
// an in-memory Motion (BVH, quaternion CSV), and ProceduralMotion, a deterministic smooth motion
// whose every frame is a function of its absolute index only (no accumulated time), for tests
// and hours-long scenes.
//
// Quaternion hygiene: validate_and_normalize() renormalises every rotation (so |q| never scales
// a vector, the reference's defect 3), records a warning when some norm was further than
// kQuaternionNormTolerance from 1, and throws imukit::Error naming the frame and joint of a
// non-finite or zero quaternion or translation. Any finite quaternion that is not all zeros is
// a rotation, from 1e-300 to 1e300: it is divided by its largest component before the norm is
// taken, so the norm neither overflows nor underflows.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/sampling.hpp"
#include "imukit/sim/body.hpp"

namespace imukit::sim {

inline constexpr double kQuaternionNormTolerance = 1e-6;

// Where a motion's frames were read from, for messages: the file and each frame's line.
struct FrameLines {
  std::string file;
  std::vector<int64_t> line;  // per frame
};

// q / |q| in place, and |q| (inf when it overflows; the unit quaternion is right regardless),
// or nullopt, q untouched, when q is all zeros. Precondition: q is finite.
std::optional<double> normalize_rotation(Eigen::Quaterniond& q);

// Frames [first_frame, first_frame + frames) for the joints asked for.
struct MotionChunk {
  int64_t first_frame = 0;
  int64_t frames = 0;
  Eigen::Matrix3Xd root_translation;          // 3 x frames, m
  std::vector<Eigen::Quaterniond> rotations;  // frames x joints, index frame * joints + k
  std::size_t joints = 0;                     // the number of joints asked for
  const Eigen::Quaterniond& rotation(int64_t frame_in_chunk, std::size_t k) const {
    return rotations[static_cast<std::size_t>(frame_in_chunk) * joints + k];
  }
};

class MotionSource {
 public:
  virtual ~MotionSource() = default;
  virtual double rate_hz() const = 0;
  virtual std::size_t joint_count() const = 0;
  // nullopt for an endless source.
  virtual std::optional<int64_t> frame_count() const = 0;
  // Fills `out` with frames [first, first + count) of the joints listed (indices into the body;
  // in that order). The range must lie inside the source (asserted).
  virtual void read(int64_t first, int64_t count, std::span<const int> joints,
                    MotionChunk& out) = 0;
};

// The first `frames` frames of a source (which it reads through, without a copy), so that a
// simulator sees the limit as the motion's end.
class LimitedMotion : public MotionSource {
 public:
  LimitedMotion(MotionSource& inner, int64_t frames) : inner_(inner), frames_(frames) {}
  double rate_hz() const override { return inner_.rate_hz(); }
  std::size_t joint_count() const override { return inner_.joint_count(); }
  std::optional<int64_t> frame_count() const override { return frames_; }
  void read(int64_t first, int64_t count, std::span<const int> joints, MotionChunk& out) override {
    inner_.read(first, count, joints, out);
  }

 private:
  MotionSource& inner_;
  int64_t frames_;
};

// Frames a run simulates: the source's count capped by `limit` (required for an endless source).
// Throws imukit::Error "<what>: an endless motion source needs a frame limit" or
// "<what>: at least 2 frames are needed, got N".
int64_t frames_to_simulate(const MotionSource& motion, std::optional<int64_t> limit,
                           std::string_view what);

class Motion : public MotionSource {
 public:
  Motion() = default;
  Motion(double rate_hz, std::size_t joints, int64_t frames);
  double rate_hz() const override { return rate_hz_; }
  std::size_t joint_count() const override { return joints_; }
  std::optional<int64_t> frame_count() const override { return frames_; }
  int64_t frames() const { return frames_; }
  void read(int64_t first, int64_t count, std::span<const int> joints, MotionChunk& out) override;

  // Stored joint by joint (all frames of joint 0, then joint 1, ...), so reading the few joints
  // a plan needs touches only their memory, however many joints the body has.
  Eigen::Quaterniond& rotation(int64_t frame, std::size_t joint) {
    return rotations_[joint * static_cast<std::size_t>(frames_) + static_cast<std::size_t>(frame)];
  }
  const Eigen::Quaterniond& rotation(int64_t frame, std::size_t joint) const {
    return rotations_[joint * static_cast<std::size_t>(frames_) + static_cast<std::size_t>(frame)];
  }
  // The samples in place (joint's rotations for frames 0.., translations x, y, z per frame), for
  // readers that need no copy (the simulator's grid methods).
  const Eigen::Quaterniond* rotation_data(std::size_t joint) const {
    return rotations_.data() + joint * static_cast<std::size_t>(frames_);
  }
  const double* translation_data() const { return translation_.data(); }
  Eigen::Ref<Eigen::Vector3d> root_translation(int64_t frame) { return translation_.col(frame); }
  Eigen::Vector3d root_translation(int64_t frame) const { return translation_.col(frame); }

  // See the header comment. Joint names (for messages) come from body when it matches; frame
  // lines, when given, put the file and line of the frame in front of each message.
  // Returns the warnings (empty when every norm was within tolerance).
  std::vector<std::string> validate_and_normalize(const Body* body = nullptr,
                                                  const FrameLines* lines = nullptr);
  // Bytes held by the samples.
  std::size_t memory_bytes() const {
    return rotations_.size() * sizeof(Eigen::Quaterniond) +
           static_cast<std::size_t>(translation_.size()) * sizeof(double);
  }

 private:
  double rate_hz_ = 0.0;
  std::size_t joints_ = 0;
  int64_t frames_ = 0;
  Eigen::Matrix3Xd translation_;
  std::vector<Eigen::Quaterniond> rotations_;
};

// The rates a simulation takes (core/sampling.hpp), here under the names sim has always used.
using imukit::check_rate;
using imukit::rate_within_limits;
using imukit::RateLimits;

// Throws imukit::Error unless the motion can be differentiated: at least 2 frames (a 0- or
// 1-frame motion has no velocity) and a rate within RateLimits.
void require_simulatable(const MotionSource& motion, const std::string& what);

// A smooth motion for tests and long scenes: every joint rotates about a fixed random axis by a
// sum of sinusoids, and the root translates along sinusoids. Frequencies are integer multiples of
// 1/period_s and phases are computed from (frame * k) mod (period frames) in integers, so frame
// 8.64e6 of a 24 h scene is computed exactly as frame 0 of a scene starting there
// (start_frame): no drift from accumulated time. The rate must be an integer number of Hz.
struct ProceduralMotionOptions {
  double rate_hz = 100.0;
  std::optional<int64_t> frames;  // nullopt: endless
  int64_t start_frame = 0;        // frame 0 of this source is absolute frame start_frame
  uint64_t seed = 1;
  int harmonics = 3;           // sinusoids per joint
  int64_t period_s = 60;       // fundamental period; frequencies k / period_s, k in [12, 72)
  double amplitude_rad = 0.1;  // per sinusoid (human-like accelerations at the wrist); [0, 10]
  double translation_amplitude_m = 0.05;  // finite, >= 0
};

class ProceduralMotion : public MotionSource {
 public:
  ProceduralMotion(std::size_t joints, const ProceduralMotionOptions& options);
  double rate_hz() const override { return options_.rate_hz; }
  std::size_t joint_count() const override { return axes_.size(); }
  std::optional<int64_t> frame_count() const override { return options_.frames; }
  void read(int64_t first, int64_t count, std::span<const int> joints, MotionChunk& out) override;
  // The whole range as a Motion (for tests).
  Motion materialize(int64_t frames);

 private:
  double phase(int64_t absolute_frame, int64_t k) const;
  ProceduralMotionOptions options_;
  int64_t period_frames_ = 0;
  std::vector<Eigen::Vector3d> axes_;
  std::vector<std::vector<int64_t>> harmonic_;  // per joint, the k of each sinusoid
  std::vector<std::vector<double>> offset_;     // per joint, phase offset of each (cycles)
  std::array<std::vector<int64_t>, 3> translation_harmonic_;
};

// Quaternion CSV: one header row; a time column `t` (s, uniform), optional root translation
// columns `root_x,root_y,root_z` (m), and per joint `<NAME>_qw,<NAME>_qx,<NAME>_qy,<NAME>_qz`
// (w first, as everywhere in imukit files). Joint names are matched to the body (aliases
// allowed); body joints without columns stay at identity. The rate is taken from the t column
// (each step within 1 % of the median), or is rate_hz (a valid rate; a t column then must
// agree with it to 1 % of a period). A second time or root column is an error. Errors name
// file, line and column.
Motion parse_quaternion_csv(std::string_view text, const std::string& source_name, const Body& body,
                            std::optional<double> rate_hz = std::nullopt,
                            std::vector<std::string>* warnings = nullptr);
Motion read_quaternion_csv(const std::string& path, const Body& body,
                           std::optional<double> rate_hz = std::nullopt,
                           std::vector<std::string>* warnings = nullptr);

// The same layout written out (t = frame / rate in s, root_x..z, then every joint's
// <name>_qw.._qz with the body's canonical names), 17 significant digits so reading it back
// gives the same doubles.
std::string format_quaternion_csv(const Body& body, const Motion& motion);
void write_quaternion_csv(const std::string& path, const Body& body, const Motion& motion);

}  // namespace imukit::sim
