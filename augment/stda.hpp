// STDA: the classic signal-level augmentations of activity-recognition windows (seed-summary
// section 2, paper Table I), applied in place to a batch of windows stored as one contiguous
// C-order (N windows, T samples, C channels) array of float or double -- the layout of X.npy and
// of a NumPy/PyTorch batch. Methods: magnitude scaling, magnitude warping (not-a-knot cubic
// spline through K+2 knots), time scaling (t' = t / b around the window centre), time warping
// (tsaug semantics: PCHIP warp, linear resampling, one warp for all channels, realised speed
// ratio exactly r), rotation (one rotation per window, applied to every sensor's 3-axis blocks) and
// jittering (sigma per channel kind in SI units, or in standard deviations of z-scored data).
//
// Randomness: every method draws from a caller-owned Rng, window after window, in the order
// documented at StdaDraws; passing a StdaDraws* records exactly the drawn parameters, and
// replay_stda() applies a recorded set again without an Rng (bit-identical result).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/interpolation.hpp"
#include "imukit/core/rng.hpp"

namespace imukit::augment {

// Shape of a C-order (windows, samples, channels) batch.
struct BatchShape {
  std::size_t windows = 0;
  std::size_t samples = 0;
  std::size_t channels = 0;
  std::size_t size() const { return windows * samples * channels; }
  bool operator==(const BatchShape&) const = default;
};

// What a channel measures: selects the jitter sigma (in that quantity's SI unit).
enum class ChannelKind { accelerometer, gyroscope, magnetometer, other };

// Which channels form a sensor's 3-axis blocks. A sensor's blocks share one rotation (its
// accelerometer and gyroscope turn together when the device turns).
struct SensorChannels {
  std::string name;
  std::vector<std::size_t> triads;  // first channel of each x, y, z block
};

struct ChannelLayout {
  std::vector<ChannelKind> kinds;  // one per channel
  std::vector<SensorChannels> sensors;

  // The imukit dataset layout: per sensor "ax ay az gx gy gz" (DESIGN.md), sensors in order.
  static ChannelLayout imu(const std::vector<std::string>& sensor_names);
  // Throws imukit::Error unless every triad lies inside `channels` and kinds has that size.
  void validate(std::size_t channels) const;
};

enum class StdaMethod {
  identity,
  magnitude_scaling,  // X' = a X, a ~ N(1, sigma^2) (one a per window, or per channel)
  magnitude_warping,  // X' = a(t) X, a(t) the not-a-knot spline through K+2 knots ~ N(1, sigma^2)
  time_scaling,       // X'(i) = X(c + b (i - c)), c = (T-1)/2, b ~ U[lo, hi]; ends held
  time_warping,       // tsaug TimeWarp(n_speed_change = K, max_speed_ratio = r)
  rotation,           // R = Rx(ax) Ry(ay) Rz(az), angles ~ U[-max, max] per axis, every sensor
  jittering,          // X' = X + N(0, sigma_kind^2) per sample and channel
};
std::string_view to_string(StdaMethod method);
// "magnitude_scaling", ...; throws imukit::Error listing the names.
StdaMethod parse_stda_method(std::string_view name);

struct StdaSpec {
  StdaMethod method = StdaMethod::identity;
  double sigma = 0.0;         // magnitude scaling / warping: 1-sigma of the factor
  int knots = 2;              // magnitude / time warping: K interior knots (speed changes)
  bool per_channel = false;   // magnitude scaling / warping: an independent draw per channel
  double lo = 1.0, hi = 1.0;  // time scaling: b ~ U[lo, hi], b > 1 is faster
  double ratio = 1.0;         // time warping: max speed / min speed, >= 1
  double max_angle_rad[3] = {3.141592653589793, 3.141592653589793, 3.141592653589793};
  // jittering: sigma per ChannelKind (m/s^2, rad/s, T, other); with z-scored data set all four
  // to the same number of standard deviations.
  double jitter_sigma[4] = {0.0, 0.0, 0.0, 0.0};

  // Throws imukit::Error naming the field for out-of-range parameters.
  void validate() const;
  std::string describe() const;  // e.g. "time_warping(K=2, r=1.5)"
};

// The parameters drawn, per window, `per_window` values each, in this order:
//  magnitude_scaling  a (1, or one per channel)
//  magnitude_warping  the K+2 knot values (per channel: channel after channel)
//  time_scaling       b
//  time_warping       the K+1 uniforms u (the speeds follow from them exactly)
//  rotation           ax, ay, az (rad), one rotation for all sensors
//  jittering          the T x C standard normal draws, sample after sample (scaled afterwards)
struct StdaDraws {
  StdaMethod method = StdaMethod::identity;
  std::size_t per_window = 0;
  std::vector<double> values;  // windows x per_window
};

// Applies `spec` to every window of `batch` (shape.size() values, C order) in place.
void apply_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<float> batch,
                const BatchShape& shape, Rng& rng, StdaDraws* log = nullptr);
void apply_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<double> batch,
                const BatchShape& shape, Rng& rng, StdaDraws* log = nullptr);
// The same with the draws taken from `draws` (as logged) instead of an Rng. Throws
// imukit::Error if the draws do not fit the spec and shape.
void replay_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<float> batch,
                 const BatchShape& shape, const StdaDraws& draws);
void replay_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<double> batch,
                 const BatchShape& shape, const StdaDraws& draws);

// Building blocks, exposed for PPDA and tests.
// tsaug's warp for K speed changes and ratio r from the K+1 uniforms u: the source position
// (in samples, 0 .. T-1) of each of the T output samples.
std::vector<double> time_warp_positions(std::span<const double> u, double ratio,
                                        std::size_t samples);
// The K+1 segment speeds v (max v / min v = ratio exactly when the u are not all equal).
std::vector<double> time_warp_speeds(std::span<const double> u, double ratio);
// The same warp as an interpolant over output positions (PCHIP, extrapolating beyond [0, T-1]).
Interpolant time_warp_interpolant(std::span<const double> u, double ratio, std::size_t samples);
// The smooth factor curve through K+2 equally spaced knot values over [0, T-1], evaluated at
// 0 .. T-1 (not-a-knot cubic spline).
std::vector<double> warp_curve(std::span<const double> knot_values, std::size_t samples);
// The same curve as an interpolant (for evaluation between samples).
Interpolant warp_curve_interpolant(std::span<const double> knot_values, std::size_t samples);

}  // namespace imukit::augment
