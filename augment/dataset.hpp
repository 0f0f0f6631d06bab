// Windowing, labels and the dataset writer (DESIGN.md "Datasets from augment"): X.npy float32
// (N windows, T samples, C channels, per sensor ax ay az gx gy gz), y.npy int64 (N), and
// dataset.json ("schema": "imukit.dataset/1": sensors, channels, rate, window, stride, units,
// policy, seeds, source). generate_dataset() is the one entry point the CLI (`imukit augment`),
// the demo and the Python bindings share: from a simulated scene (PPDA) or a recording (the STDA
// counterparts of the same policy), count windows, one sub-policy per batch, bit-identical for
// the same seed whatever the thread count.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "imukit/augment/policy.hpp"
#include "imukit/augment/ppda.hpp"
#include "imukit/augment/stda.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::augment {

inline constexpr std::string_view kDatasetSchema = "imukit.dataset/1";
inline constexpr int64_t kNoLabel = -1;

// A labelled time span [start_s, end_s) in seconds from the first sample.
struct LabelSegment {
  double start_s = 0.0;
  double end_s = 0.0;
  int64_t label = 0;
};

// Per-sample labels (kNoLabel where no segment covers a sample; later segments win overlaps).
// Sample n is at time_s[n] seconds from the first sample (non-decreasing): a recording's own time
// stamps, so a gap in it does not shift the labels after it.
std::vector<int64_t> labels_from_segments(std::span<const LabelSegment> segments,
                                          std::span<const double> time_s);
// The times of `samples` samples at rate_hz from 0 (a simulated scene's).
std::vector<double> uniform_times_s(std::size_t samples, double rate_hz);
// Seconds from the first time stamp, per sample.
std::vector<double> times_since_first_s(std::span<const TimeNs> t);
// Reads labels: a CSV with a header row and either one column `label` (one row per sample) or
// three columns `start_s,end_s,label` (segments, placed at the samples' times). Errors name
// file:line.
std::vector<int64_t> read_labels(const std::string& path, std::span<const double> time_s);

// Window starts 0, stride, 2 stride, ... while start + window <= samples.
std::vector<int64_t> window_starts(std::size_t samples, std::size_t window, std::size_t stride);
// The majority label of each window: the most frequent of its samples' labels, kNoLabel
// included (a window mostly unlabelled is unlabelled), kNoLabel losing every tie and ties
// between classes going to the smaller label. Empty labels: every window kNoLabel. Throws
// imukit::Error for a label below kNoLabel.
std::vector<int64_t> window_labels(std::span<const int64_t> labels, std::span<const int64_t> starts,
                                   std::size_t window);

// Recorded streams as an (N, T, C) batch: streams in order, ax ay az gx gy gz each, windows at
// `starts`. All streams must have accelerometer and gyroscope and the same sample count.
std::vector<float> extract_windows(const std::vector<const ImuSeries*>& streams,
                                   std::span<const int64_t> starts, std::size_t window);

struct DatasetInfo {
  std::vector<std::string> sensors;
  double rate_hz = 0.0;
  std::size_t window = 0;
  std::size_t stride = 0;
  std::string mode;    // "ppda" or "stda"
  std::string source;  // the scene or recording path
  std::string policy_name;
  std::string policy_json;  // format_policy() text, embedded verbatim
  uint64_t seed = 0;
  std::size_t batch_size = 0;
  double identity_fraction = 0.0;
  std::string method;  // PPDA: "spline", "fd" or "reference" (DatasetOptions::method)
  // PPDA: windows written unaugmented (sub_policy -1) because their drawn speed needed more
  // motion than the scene has around them.
  std::size_t too_short_windows = 0;
  bool normalized = false;
  std::vector<double> channel_mean, channel_std;  // when normalized
  std::optional<Eigen::Vector3d> gravity_world;   // PPDA: the scene's, as simulated (m/s^2)
};

// Writes X.npy, y.npy, sub_policy.npy (int64, the sub-policy index per window, -1 = none) and
// dataset.json into dir (created). Throws imukit::Error on I/O failure.
void write_dataset(const std::string& dir, std::span<const float> X, const BatchShape& shape,
                   std::span<const int64_t> y, std::span<const int64_t> sub_policy,
                   const DatasetInfo& info);

struct DatasetOptions {
  std::size_t window = 100;
  std::size_t stride = 25;
  std::size_t count = 0;         // windows to write; 0 = one pass over the base windows
  std::size_t batch_size = 256;  // one sub-policy per batch
  uint64_t seed = 0;
  unsigned threads = 1;    // 0 = hardware concurrency; the output does not depend on it
  bool normalize = false;  // z-score every channel (statistics stored in dataset.json)
  // Fraction of batches left unaugmented (the paper's one-at-a-time comparison uses 0.5).
  double identity_fraction = 0.0;
  sim::DerivativeMethod method = sim::DerivativeMethod::spline;  // see PpdaOptions
  // The dataset is built in memory: one needing more bytes than this is refused before anything
  // is allocated. 0: half the machine's physical memory.
  std::size_t max_bytes = 0;
};

struct Dataset {
  std::vector<float> X;
  BatchShape shape;
  std::vector<int64_t> y;
  std::vector<int64_t> sub_policy;
  DatasetInfo info;
};

// Base windows every `stride` samples; output window i uses base window i mod (base count) (so a
// count above the base count repeats the windows under fresh draws). The output windows are
// dealt into batches of `batch_size` in a shuffled order (a Fisher-Yates shuffle drawn from
// Rng(seed, 1)), so a batch holds windows from all over the source; batch b uses sub-policy
// sample_sub_policy(policy, Rng(seed).child(b)) (or identity for the identity_fraction of
// batches decided by the same stream) and draws its windows, in shuffled order, from
// Rng(seed).child(b) as PpdaAugmenter::apply does. X stays in window order. A window whose
// drawn speed needs more motion than the scene has around it is written unaugmented
// (sub_policy -1, from Rng(seed).child(b).child(0)) and counted in info.too_short_windows.
// labels: per sample (at the sensor rate), may be empty.
Dataset generate_dataset(const sim::Scene& scene, const Policy& policy,
                         std::span<const int64_t> labels, const DatasetOptions& options);
// The STDA counterparts of the policy applied to recorded windows. Time scaling runs first and
// reads the recording around each window (a faster window shows more of it), instead of holding
// the window's edge values as apply_stda does on bare windows; the recording must hold a window
// at the policy's fastest speed, and every sample must be finite (both checked before any work).
Dataset generate_dataset(const std::vector<std::string>& stream_names,
                         const std::vector<const ImuSeries*>& streams, const Policy& policy,
                         std::span<const int64_t> labels, const DatasetOptions& options);

}  // namespace imukit::augment
