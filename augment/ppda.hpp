// PPDA: physically plausible augmentation (seed-summary section 2). A sub-policy changes the
// simulation's parameters -- the motion's joint rotation angles (amplitude), its timing (speed),
// the sensors' placement, their hardware errors -- and the window is simulated again, so the
// augmented signals obey the same physics as real ones (a faster motion has larger rates and
// accelerations; a rotated sensor sees gravity along other axes).
//
// How a batch is made fast: the augmenter compiles one simulator plan per scene (only the joints
// on the sensors' chains) and reuses it for every window; each window simulates only its own
// frames plus a stencil margin. Placement changes need no new plan: the simulator evaluates, per
// sensor-carrying joint, the specific force at the joint origin and at unit offsets along its
// axes, and since a rigid segment's acceleration field is affine in the position, any sensor
// position and orientation on that segment follows exactly by a linear combination and a rotation.
//
// Randomness: apply() takes one 64-bit draw from the caller's Rng as the batch's base seed and
// window k draws from Rng(base).child(k), so the output is the same for any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "imukit/augment/policy.hpp"
#include "imukit/augment/stda.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::augment {

struct PpdaOptions {
  std::size_t window = 100;  // samples per window, at the scene's sensor rate
  // Derivative method for the re-simulation. spline (default): analytic derivatives of the
  // re-timed motion, rate error O(h^3). The re-timed motion is resampled on the motion's own
  // frame grid, so when the sensor rate equals the motion rate every sample falls on a frame,
  // where the simulator's vectorised on-frame spline is about as fast as fd; fd is second
  // order (at 100 Hz about 6x the spline's acceleration error and 40x its rate error).
  sim::DerivativeMethod method = sim::DerivativeMethod::spline;
};

// What was drawn for one window (for logs and tests).
struct PpdaWindowLog {
  int64_t start = 0;              // first sample of the base window
  double speed_scale = 1.0;       // b (scaling)
  std::vector<double> speed_u;    // warping uniforms
  std::vector<double> amplitude;  // per chosen joint: a, or its K+2 knot values, joint after joint
  std::vector<sim::Placement> placements;              // per sensor, as simulated
  std::vector<Eigen::Vector3d> accel_bias, gyro_bias;  // per sensor (ranges hardware)
};

class PpdaAugmenter {
 public:
  // Takes the scene's body, motion, sensors (accelerometer and gyroscope are both output; of a
  // sensor's hardware model only its range and resolution are kept, bounding the readings unless
  // the sub-policy draws a whole device from a profile: its noise, biases and calibration are
  // the sub-policy's hardware group's to decide) and sample rate. Throws imukit::Error if the
  // motion has no frame count or is shorter than a window with its margins: the frames a window of
  // options.window samples spans, plus 10 (3 on each side for the derivative stencils, and 4), even
  // where every window would be identity.
  PpdaAugmenter(const sim::Scene& scene, PpdaOptions options = {});
  ~PpdaAugmenter();
  PpdaAugmenter(PpdaAugmenter&&) noexcept;
  PpdaAugmenter& operator=(PpdaAugmenter&&) noexcept;

  std::size_t window() const;
  std::size_t channels() const;  // 6 per sensor: ax ay az gx gy gz
  ChannelLayout layout() const;
  std::vector<std::string> sensor_names() const;
  double rate_hz() const;        // sensor sample rate
  int64_t sample_count() const;  // sensor samples in the whole motion

  // Base window starts (sample indices) every `stride` samples: 0, stride, ... while a window fits.
  std::vector<int64_t> window_starts(std::size_t stride) const;

  // Amplitude warping's curve is sampled on the window's frames and differentiated twice by the
  // simulator (the joint's angle times the curve), whose stencils span 3 frames: knots closer
  // than kMinAmplitudeKnotSpacing samples are not resolved, and the curve turns into noise that
  // the derivatives amplify (98 knots on 100 samples read 20,499 m/s^2, found in review,
  // 2026-11-26). At most max_amplitude_knots(window) interior knots, (T - 1) / 3 - 1: 32 on 100
  // samples, 5 on 20 (the grids' 2 and 4 fit); 0, a straight line, is always allowed.
  static constexpr std::size_t kMinAmplitudeKnotSpacing = 3;
  static int max_amplitude_knots(std::size_t window);
  // Throws imukit::Error naming the sub-policy when it cannot be applied to this augmenter's
  // windows (amplitude knots beyond max_amplitude_knots). apply() checks its sub-policy; a
  // caller with a whole policy checks them all up front.
  void check(const SubPolicy& sub) const;

  // Simulates window k starting at sample starts[k] under `sub` into out (starts.size() x
  // window x channels floats, C order). threads: 0 = hardware concurrency. A speed-scaled window
  // covers b times the base span around the base window's centre, moved inside the motion when
  // it would leave it. An identity-speed window never moves: it is the plain simulation's samples
  // starts[k] .. starts[k] + window - 1 (before amplitude, placement and hardware changes), the
  // first and last windows included. A window whose re-timed span needs more motion than the
  // scene has (a speed drawn too fast for a short motion) throws imukit::Error; with
  // `too_short` (starts.size() flags) it is flagged there instead and its rows of out are left
  // as they were, the other windows as without it (each window draws its own numbers).
  void apply(const SubPolicy& sub, std::span<const int64_t> starts, Rng& rng, std::span<float> out,
             unsigned threads = 1, std::vector<PpdaWindowLog>* log = nullptr,
             std::span<uint8_t> too_short = {});
  void apply(const Policy& policy, std::size_t sub_policy, std::span<const int64_t> starts,
             Rng& rng, std::span<float> out, unsigned threads = 1);
  // The same, double precision, single window, no threads (tests).
  void apply_window(const SubPolicy& sub, int64_t start, Rng& rng, std::span<double> out,
                    PpdaWindowLog* log = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace imukit::augment
