// Windowing, labels, the dataset writer and generate_dataset (augment/dataset.hpp).
#include "imukit/augment/dataset.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/npy.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/core/text_parse.hpp"

namespace imukit::augment {

using json = nlohmann::json;

std::vector<int64_t> labels_from_segments(std::span<const LabelSegment> segments,
                                          std::span<const double> time_s) {
  std::vector<int64_t> labels(time_s.size(), kNoLabel);
  // Sample n is inside [start, end) when start <= time_s[n] < end, to 1 ns (a time stamp that
  // prints as the boundary is on it).
  constexpr double kTolerance = 1e-9;
  const auto first_at = [&](double s) {
    return static_cast<std::size_t>(std::lower_bound(time_s.begin(), time_s.end(), s - kTolerance) -
                                    time_s.begin());
  };
  for (const LabelSegment& seg : segments) {
    if (!(std::isfinite(seg.start_s) && std::isfinite(seg.end_s) && seg.end_s >= seg.start_s))
      throw Error(fmt::format("labels: segment [{}, {}) is not a finite, ordered span", seg.start_s,
                              seg.end_s));
    for (std::size_t n = first_at(seg.start_s), hi = first_at(seg.end_s); n < hi; ++n)
      labels[n] = seg.label;
  }
  return labels;
}

std::vector<double> uniform_times_s(std::size_t samples, double rate_hz) {
  if (!(rate_hz > 0.0 && std::isfinite(rate_hz))) throw Error("labels: the rate must be positive");
  std::vector<double> t(samples);
  for (std::size_t n = 0; n < samples; ++n) t[n] = static_cast<double>(n) / rate_hz;
  return t;
}

std::vector<double> times_since_first_s(std::span<const TimeNs> t) {
  std::vector<double> s(t.size());
  for (std::size_t n = 0; n < t.size(); ++n) s[n] = to_seconds(t[n] - t.front());
  return s;
}

std::vector<int64_t> read_labels(const std::string& path, std::span<const double> time_s) {
  const std::size_t samples = time_s.size();
  LineReader reader(path);
  std::vector<Field> fields;
  const auto header = reader.next();
  if (!header) throw Error(InputLocation{path, 1, 1, std::nullopt}, "empty label file");
  split_fields(*header, fields);
  const bool per_sample = fields.size() == 1 && fields[0].text == "label";
  const bool segments = fields.size() == 3 && fields[0].text == "start_s" &&
                        fields[1].text == "end_s" && fields[2].text == "label";
  if (!per_sample && !segments) {
    throw Error(InputLocation{path, 1, 1, std::nullopt},
                "expected the header 'label' (one row per sample) or 'start_s,end_s,label'");
  }
  std::vector<int64_t> labels;
  std::vector<LabelSegment> segs;
  while (const auto line = reader.next()) {
    if (line->empty()) continue;
    split_fields(*line, fields);
    const std::size_t want = per_sample ? 1 : 3;
    if (fields.size() != want) {
      throw Error(InputLocation{path, reader.line_number(), 1, std::nullopt},
                  fmt::format("expected {} field(s), got {}", want, fields.size()));
    }
    const auto num = [&](const Field& f) {
      const std::optional<double> v = parse_double(f.text);
      if (!v || !std::isfinite(*v))
        throw Error(InputLocation{path, reader.line_number(), f.column, std::nullopt},
                    "expected a number, got " + quote_excerpt(f.text, 24));
      return *v;
    };
    const auto label = [&](const Field& f) {
      const double v = num(f);
      if (v != std::floor(v) || std::abs(v) > 9e15)
        throw Error(InputLocation{path, reader.line_number(), f.column, std::nullopt},
                    "a label must be an integer");
      if (v < static_cast<double>(kNoLabel))
        throw Error(
            InputLocation{path, reader.line_number(), f.column, std::nullopt},
            fmt::format("label {}: a label is a class index >= 0, or {} for none", v, kNoLabel));
      return static_cast<int64_t>(v);
    };
    if (per_sample) {
      labels.push_back(label(fields[0]));
    } else {
      segs.push_back({num(fields[0]), num(fields[1]), label(fields[2])});
      if (segs.back().end_s < segs.back().start_s)
        throw Error(InputLocation{path, reader.line_number(), fields[1].column, std::nullopt},
                    "end_s before start_s");
    }
  }
  if (per_sample) {
    if (labels.size() != samples) {
      throw Error(InputLocation{path, std::nullopt, std::nullopt, std::nullopt},
                  fmt::format("{} labels for {} samples", labels.size(), samples));
    }
    return labels;
  }
  return labels_from_segments(segs, time_s);
}

std::vector<int64_t> window_starts(std::size_t samples, std::size_t window, std::size_t stride) {
  if (window == 0 || stride == 0) throw Error("windowing: window and stride must be >= 1");
  if (samples > static_cast<std::size_t>(std::numeric_limits<int64_t>::max()))
    throw Error("windowing: more samples than a signed 64-bit index reaches");
  std::vector<int64_t> starts;
  if (window > samples) return starts;
  // Counted rather than stepped, so s + stride cannot wrap past the end (found in review).
  const std::size_t count = (samples - window) / stride + 1;
  starts.reserve(count);
  for (std::size_t k = 0; k < count; ++k) starts.push_back(static_cast<int64_t>(k * stride));
  return starts;
}

std::vector<int64_t> window_labels(std::span<const int64_t> labels, std::span<const int64_t> starts,
                                   std::size_t window) {
  if (window == 0) throw Error("windowing: the window must be >= 1 sample");
  std::vector<int64_t> out(starts.size(), kNoLabel);
  if (labels.empty()) return out;
  // Below kNoLabel is neither a class nor "none" (found in review: `augment --labels` wrote -3
  // into y.npy as a class).
  if (const auto low =
          std::find_if(labels.begin(), labels.end(), [](int64_t l) { return l < kNoLabel; });
      low != labels.end()) {
    throw Error(fmt::format("labels[{}] is {}; a label is a class index >= 0, or {} for none",
                            low - labels.begin(), *low, kNoLabel));
  }
  std::map<int64_t, std::size_t> counts;
  for (std::size_t w = 0; w < starts.size(); ++w) {
    // A negative start wrapped to a huge one whose end wrapped back inside: "unlabelled"
    // instead of an error (found in review).
    if (starts[w] < 0 || static_cast<std::size_t>(starts[w]) > labels.size() ||
        window > labels.size() - static_cast<std::size_t>(starts[w])) {
      throw Error(
          fmt::format("windowing: window {} (samples {} to {} + {}) is outside the {} labels", w,
                      starts[w], starts[w], window, labels.size()));
    }
    const auto s = static_cast<std::size_t>(starts[w]);
    counts.clear();
    for (std::size_t i = s; i < s + window; ++i) ++counts[labels[i]];
    // The plurality of the window's samples, unlabelled ones included: a window of 99
    // unlabelled samples and one of class 3 was class 3 (found in review, 2026-11-27). Map
    // order puts kNoLabel first, so it loses every tie, and ties between classes keep the
    // smaller label.
    std::size_t best = 0;
    for (const auto& [label, n] : counts) {
      if (n > best || (label != kNoLabel && n == best && out[w] == kNoLabel)) {
        best = n;
        out[w] = label;
      }
    }
  }
  return out;
}

std::vector<float> extract_windows(const std::vector<const ImuSeries*>& streams,
                                   std::span<const int64_t> starts, std::size_t window) {
  const std::size_t S = streams.size(), C = 6 * S;
  if (S == 0) throw Error("windowing: no streams");
  const std::size_t n = streams[0]->size();
  for (std::size_t s = 0; s < S; ++s) {
    if (!streams[s]->has_accel() || !streams[s]->has_gyro())
      throw Error(fmt::format("windowing: stream {} needs accelerometer and gyroscope", s));
    if (streams[s]->size() != n)
      throw Error(fmt::format("windowing: stream {} has {} samples, stream 0 has {}", s,
                              streams[s]->size(), n));
  }
  if (window == 0) throw Error("windowing: the window must be >= 1 sample");
  // Every window is checked before X is sized from them. Not s0 + window > n, which wraps for a
  // huge window (found in review, 2026-11-27: an out-of-range read).
  for (const int64_t start : starts) {
    if (start < 0 || window > n || static_cast<std::size_t>(start) > n - window)
      throw Error("windowing: a window lies outside the streams");
  }
  std::vector<float> X(starts.size() * window * C);
  for (std::size_t w = 0; w < starts.size(); ++w) {
    const auto s0 = static_cast<std::size_t>(starts[w]);
    for (std::size_t i = 0; i < window; ++i) {
      float* o = X.data() + (w * window + i) * C;
      for (std::size_t s = 0; s < S; ++s) {
        const auto c = static_cast<Eigen::Index>(s0 + i);
        for (int k = 0; k < 3; ++k) {
          o[6 * s + static_cast<std::size_t>(k)] = static_cast<float>(streams[s]->accel(k, c));
          o[6 * s + 3 + static_cast<std::size_t>(k)] = static_cast<float>(streams[s]->gyro(k, c));
        }
      }
    }
  }
  return X;
}

void write_dataset(const std::string& dir, std::span<const float> X, const BatchShape& shape,
                   std::span<const int64_t> y, std::span<const int64_t> sub_policy,
                   const DatasetInfo& info) {
  if (X.size() != shape.size() || y.size() != shape.windows || sub_policy.size() != shape.windows)
    throw Error("write_dataset: X, y and sub_policy do not match the shape");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(dir + ": cannot create the folder: " + ec.message());
  const std::filesystem::path d(dir);
  const std::size_t xs[3] = {shape.windows, shape.samples, shape.channels};
  const std::size_t ys[1] = {shape.windows};
  // dataset.json goes first and comes back last: a run that fails between the arrays (each
  // replaced whole) leaves no description of another run's shape beside them (found in review,
  // 2026-11-27: new X.npy and y.npy sat beside the old dataset.json).
  const std::filesystem::path description = d / "dataset.json";
  std::filesystem::remove(description, ec);
  if (ec)
    throw Error(description.string() + ": cannot remove the old description: " + ec.message());
  write_npy((d / "X.npy").string(), X, xs);
  write_npy((d / "y.npy").string(), y, ys);
  write_npy((d / "sub_policy.npy").string(), sub_policy, ys);
  json j;
  j["schema"] = std::string(kDatasetSchema);
  j["mode"] = info.mode;
  j["source"] = info.source;
  j["sensors"] = info.sensors;
  json channels = json::array();
  for (const std::string& s : info.sensors)
    for (const char* c : {"ax", "ay", "az", "gx", "gy", "gz"}) channels.push_back(s + "." + c);
  j["channels"] = channels;
  j["shape"] = {shape.windows, shape.samples, shape.channels};
  j["rate_hz"] = info.rate_hz;
  if (info.gravity_world) {
    const Eigen::Vector3d& g = *info.gravity_world;
    j["gravity_world_mps2"] = {g.x(), g.y(), g.z()};
  }
  j["window"] = info.window;
  j["stride"] = info.stride;
  j["units"] = info.normalized ? json{{"accelerometer", "z-score"}, {"gyroscope", "z-score"}}
                               : json{{"accelerometer", "m/s^2"}, {"gyroscope", "rad/s"}};
  if (info.normalized)
    j["normalization"] = {{"mean", info.channel_mean}, {"std", info.channel_std}};
  j["labels"] = {{"file", "y.npy"}, {"unlabelled", kNoLabel}};
  j["seeds"] = {{"seed", info.seed},
                {"batch_size", info.batch_size},
                {"identity_fraction", info.identity_fraction},
                {"streams",
                 "windows are dealt into batches in the order of a Fisher-Yates shuffle drawn "
                 "from Rng(seed, 1); batch b draws from Rng(seed).child(b): one uniform when "
                 "identity_fraction > 0 (below it the batch is not augmented), one uniform "
                 "choosing the sub-policy, then for PPDA one 64-bit draw s (the batch's k-th "
                 "window: Rng(s).child(k)), for STDA the methods' draws for the whole batch "
                 "(augment/stda.hpp)"}};
  if (info.mode == "ppda") {
    j["method"] = info.method;
    j["too_short_windows"] = info.too_short_windows;
  }
  j["policy"] = info.policy_json.empty() ? json() : json::parse(info.policy_json);
  j["sub_policy_file"] = "sub_policy.npy";
  write_text_file(description.string(), j.dump(2) + "\n");
}

namespace {

// Each channel's mean and standard deviation over X (rows of C values) into info (std 0 -> 1).
void channel_statistics(std::span<const float> X, std::size_t C, DatasetInfo& info) {
  std::vector<double> sum(C, 0.0), sq(C, 0.0);
  const std::size_t rows = C == 0 ? 0 : X.size() / C;
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < C; ++c) sum[c] += X[r * C + c];
  info.channel_mean.assign(C, 0.0);
  info.channel_std.assign(C, 1.0);
  for (std::size_t c = 0; c < C; ++c)
    info.channel_mean[c] = rows ? sum[c] / static_cast<double>(rows) : 0.0;
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < C; ++c) {
      const double d = X[r * C + c] - info.channel_mean[c];
      sq[c] += d * d;
    }
  for (std::size_t c = 0; c < C; ++c) {
    const double sd = rows > 1 ? std::sqrt(sq[c] / static_cast<double>(rows)) : 0.0;
    info.channel_std[c] = sd > 0.0 ? sd : 1.0;
  }
  info.normalized = true;
}

// z-scores X's channels with info's statistics.
void apply_normalization(std::span<float> X, std::size_t C, const DatasetInfo& info) {
  const std::size_t rows = C == 0 ? 0 : X.size() / C;
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < C; ++c)
      X[r * C + c] =
          static_cast<float>((X[r * C + c] - info.channel_mean[c]) / info.channel_std[c]);
}

// Per-channel z-scoring over every window and sample.
void normalize(std::vector<float>& X, std::size_t C, DatasetInfo& info) {
  channel_statistics(X, C, info);
  apply_normalization(X, C, info);
}

void check_options(const DatasetOptions& o, const Policy& policy) {
  if (o.window < 2) throw Error("augment: --window must be at least 2 samples");
  if (o.stride < 1) throw Error("augment: --stride must be at least 1 sample");
  if (o.batch_size < 1) throw Error("augment: the batch size must be at least 1");
  if (!(o.identity_fraction >= 0.0 && o.identity_fraction <= 1.0))
    throw Error("augment: the identity fraction must be in [0, 1]");
  policy.validate();
}

// N windows of T samples and C channels (float32, plus an int64 label and sub-policy index each)
// and `working` more windows' worth of float32 held beside them (a batch, the source's windows)
// must fit in the memory allowed before they are allocated.
void check_size(std::size_t N, std::size_t working, std::size_t T, std::size_t C,
                std::size_t max_bytes) {
  if (max_bytes == 0) {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    max_bytes = pages > 0 && page > 0
                    ? static_cast<std::size_t>(pages) / 2 * static_cast<std::size_t>(page)
                    : std::size_t{4} << 30;
  }
  // In long double: the product of three size_t can exceed 2^64.
  const long double window_bytes = static_cast<long double>(T) * static_cast<long double>(C) * 4;
  const long double bytes = static_cast<long double>(N) * (window_bytes + 16) +
                            static_cast<long double>(working) * window_bytes;
  if (bytes <= static_cast<long double>(max_bytes)) return;
  const auto gib = [](long double b) { return static_cast<double>(b / (1 << 30)); };
  throw Error(fmt::format(
      "augment: {} windows x {} samples x {} channels need {:.3g} GiB in memory (with the "
      "working copies), more than the "
      "{:.3g} GiB allowed (half this machine's memory); ask for fewer windows (--count)",
      N, T, C, gib(bytes), gib(static_cast<long double>(max_bytes))));
}

// The output windows in batch order (batch b holds positions b * batch_size onwards): a
// seeded shuffle of 0 .. N-1 drawn from stream 1 of the seed (the batches draw from stream 0's
// children), so that a batch, which shares one sub-policy, holds windows from all over the
// source, as a training mini-batch does. Batches of consecutive windows were runs of one
// activity under one or two sub-policies, augmentation tied to the label (found in review,
// 2026-11-27).
std::vector<std::size_t> batch_order(std::size_t N, uint64_t seed) {
  std::vector<std::size_t> order(N);
  std::iota(order.begin(), order.end(), std::size_t{0});
  Rng rng(seed, 1);
  for (std::size_t i = N; i > 1; --i) std::swap(order[i - 1], order[rng.uniform_index(i)]);
  return order;
}

// Sub-policy of batch b (-1: identity), drawn from the batch's stream.
int64_t batch_sub_policy(const Policy& policy, double identity_fraction, Rng& batch_rng) {
  if (identity_fraction > 0.0 && batch_rng.uniform() < identity_fraction) return -1;
  return static_cast<int64_t>(sample_sub_policy(policy, batch_rng));
}

DatasetInfo base_info(const Policy& policy, const DatasetOptions& o) {
  DatasetInfo info;
  info.window = o.window;
  info.stride = o.stride;
  info.policy_name = policy.name;
  info.policy_json = format_policy(policy);
  info.seed = o.seed;
  info.batch_size = o.batch_size;
  info.identity_fraction = o.identity_fraction;
  info.method = std::string(sim::to_string(o.method));
  return info;
}

// With normalize and a hardware-ranges sub-policy, the jitter is in standard deviations and
// must wait for the z-scoring: taken out of specs (where it is last) and returned.
std::vector<StdaSpec> jitter_in_standard_deviations(std::vector<StdaSpec>& specs,
                                                    const SubPolicy& sub,
                                                    const DatasetOptions& options) {
  std::vector<StdaSpec> after_normalizing;
  if (!options.normalize || sub.hardware.kind != HardwareOp::Kind::ranges) return after_normalizing;
  for (auto it = specs.begin(); it != specs.end();) {
    if (it->method == StdaMethod::jittering) {
      after_normalizing.push_back(*it);
      it = specs.erase(it);
    } else {
      ++it;
    }
  }
  return after_normalizing;
}

// Time scaling of a batch from the recording itself (whole: n rows of C channels): window k,
// base window members[k] mod the base count, becomes the recording at start + c + b (i - c),
// c = (T-1)/2, b ~ U[lo, hi] (moved inside the recording where it would leave it), linearly
// interpolated -- a faster window shows b T recorded samples instead of holding its edge values
// as apply_stda does on bare windows. check_time_scaling_fits made sure every b fits.
void scale_time_from_recording(const StdaSpec& spec, std::span<const float> whole, std::size_t n,
                               std::size_t C, std::span<const int64_t> base,
                               std::span<const std::size_t> members, Rng& rng,
                               std::span<float> batch_x, std::size_t T) {
  const double c = 0.5 * static_cast<double>(T - 1), last = static_cast<double>(n - 1);
  for (std::size_t k = 0; k < members.size(); ++k) {
    const double b = rng.uniform_in(spec.lo, spec.hi);
    const auto s0 = static_cast<double>(base[members[k] % base.size()]);
    const double first = s0 + c - b * c, end = s0 + c + b * c;
    const double shift = first < 0.0 ? -first : end > last ? last - end : 0.0;
    float* o = batch_x.data() + k * T * C;
    for (std::size_t i = 0; i < T; ++i) {
      const double pos = std::clamp(s0 + c + b * (static_cast<double>(i) - c) + shift, 0.0, last);
      const auto j = std::min(static_cast<std::size_t>(pos), n - 2);
      const double f = pos - static_cast<double>(j);
      for (std::size_t ch = 0; ch < C; ++ch) {
        const double a0 = whole[j * C + ch], a1 = whole[(j + 1) * C + ch];
        o[i * C + ch] = static_cast<float>(a0 + f * (a1 - a0));
      }
    }
  }
}

// Before any work: every sub-policy's fastest time scaling must fit a window in the recording
// (a window of T samples at b times the speed spans b (T-1) + 1 samples). It failed at the first
// batch that drew such a speed, possibly hours in.
void check_time_scaling_fits(const Policy& policy, bool normalize, double rate, std::size_t T,
                             std::size_t n) {
  for (std::size_t p = 0; p < policy.sub_policies.size(); ++p) {
    for (const StdaSpec& spec :
         stda_counterparts(policy.sub_policies[p], policy, normalize, rate)) {
      if (spec.method != StdaMethod::time_scaling) continue;
      const double span = spec.hi * static_cast<double>(T - 1) + 1.0;
      if (span > static_cast<double>(n)) {
        throw Error(fmt::format(
            "augment: sub-policy {} scales time up to {:g}x: a window of {} samples then spans "
            "{:.0f} samples, and the recording has {}; use a shorter window or a slower policy",
            p, spec.hi, T, std::ceil(span), n));
      }
    }
  }
}

// Every accelerometer and gyroscope value of the streams is finite: a NaN or an infinity went
// into the windows, and with normalize into a whole channel's statistics (found in review,
// 2026-11-27).
void check_finite(const std::vector<std::string>& names,
                  const std::vector<const ImuSeries*>& streams) {
  for (std::size_t s = 0; s < streams.size(); ++s) {
    for (const auto* m : {&streams[s]->accel, &streams[s]->gyro}) {
      if (const auto i = first_non_finite_sample(*m)) {
        throw Error(fmt::format(
            "augment: stream {}: the {} of sample {} (t = {:.9f} s) is not finite; STDA needs "
            "every sample (cut the recording or fill its gaps first)",
            quote_excerpt(names[s]), m == &streams[s]->accel ? "accelerometer" : "gyroscope", *i,
            static_cast<double>(streams[s]->t[static_cast<std::size_t>(*i)] -
                                streams[s]->t.front()) *
                1e-9));
      }
    }
  }
}

}  // namespace

Dataset generate_dataset(const sim::Scene& scene, const Policy& policy,
                         std::span<const int64_t> labels, const DatasetOptions& options) {
  check_options(options, policy);
  PpdaOptions po;
  po.window = options.window;
  po.method = options.method;
  PpdaAugmenter aug(scene, po);
  // Every sub-policy up front: a bad one drawn late would fail hours into the run.
  for (const SubPolicy& sub : policy.sub_policies) aug.check(sub);
  const std::vector<int64_t> base = aug.window_starts(options.stride);
  if (!labels.empty() && labels.size() != static_cast<std::size_t>(aug.sample_count()))
    throw Error(
        fmt::format("augment: {} labels for {} samples", labels.size(), aug.sample_count()));
  const std::vector<int64_t> base_labels = window_labels(labels, base, options.window);
  const std::size_t N = options.count > 0 ? options.count : base.size();
  const std::size_t T = options.window, C = aug.channels();
  check_size(N, std::min(options.batch_size, N), T, C, options.max_bytes);  // X and a batch
  Dataset d;
  d.shape = {N, T, C};
  d.X.resize(d.shape.size());
  d.y.resize(N);
  d.sub_policy.resize(N);
  const Rng root(options.seed);
  const std::vector<std::size_t> order = batch_order(N, options.seed);
  const SubPolicy identity;
  std::size_t too_short_windows = 0;
  std::vector<float> rows;  // the batch's windows, then scattered to their places in X
  for (std::size_t b0 = 0, batch = 0; b0 < N; b0 += options.batch_size, ++batch) {
    const std::size_t n = std::min(options.batch_size, N - b0);
    const std::span<const std::size_t> members(order.data() + b0, n);
    Rng br = root.child(batch);
    const int64_t idx = batch_sub_policy(policy, options.identity_fraction, br);
    std::vector<int64_t> starts(n);
    for (std::size_t k = 0; k < n; ++k) {
      starts[k] = base[members[k] % base.size()];
      d.y[members[k]] = base_labels[members[k] % base.size()];
      d.sub_policy[members[k]] = idx;
    }
    const SubPolicy& sub = idx < 0 ? identity : policy.sub_policies[static_cast<std::size_t>(idx)];
    rows.resize(n * T * C);
    std::vector<uint8_t> too_short(n, 0);
    aug.apply(sub, starts, br, rows, options.threads, nullptr, too_short);
    // A speed drawn too fast for the motion around a window needs frames the scene does not
    // have: that window is written unaugmented (sub_policy -1) and counted. It ended the whole
    // run until review, 2026-11-27; whether a sub-policy can need too much depends on its draw.
    std::vector<int64_t> plain_starts;
    for (std::size_t k = 0; k < n; ++k)
      if (too_short[k] != 0) plain_starts.push_back(starts[k]);
    if (!plain_starts.empty()) {
      std::vector<float> plain(plain_starts.size() * T * C);
      Rng plain_rng = br.child(0);  // the identity sub-policy draws nothing; a stream all the same
      aug.apply(identity, plain_starts, plain_rng, plain, options.threads);
      for (std::size_t k = 0, j = 0; k < n; ++k) {
        if (too_short[k] == 0) continue;
        std::copy_n(plain.data() + j++ * T * C, T * C, rows.data() + k * T * C);
        d.sub_policy[members[k]] = -1;
      }
      too_short_windows += plain_starts.size();
    }
    for (std::size_t k = 0; k < n; ++k)
      std::copy_n(rows.data() + k * T * C, T * C, d.X.data() + members[k] * T * C);
  }
  // Not one window augmented (every speed drawn too fast for the scene) is no augmentation at
  // all; it was written as one, with only too_short_windows in dataset.json to say so (found in
  // review, 2026-11-27).
  if (too_short_windows > 0 &&
      std::none_of(d.sub_policy.begin(), d.sub_policy.end(), [](int64_t k) { return k >= 0; })) {
    throw Error(fmt::format(
        "augment: each of the {} windows to augment drew a speed that needs more motion than the "
        "scene has around it ({:.6g} s of motion, windows of {} samples): nothing would be "
        "augmented; use a longer scene, a shorter window or a slower speed range",
        too_short_windows, static_cast<double>(aug.sample_count()) / aug.rate_hz(), T));
  }
  d.info = base_info(policy, options);
  d.info.too_short_windows = too_short_windows;
  d.info.mode = "ppda";
  d.info.gravity_world = scene.options.gravity_world;
  d.info.sensors = aug.sensor_names();
  d.info.rate_hz = aug.rate_hz();
  if (options.normalize) normalize(d.X, C, d.info);
  return d;
}

Dataset generate_dataset(const std::vector<std::string>& stream_names,
                         const std::vector<const ImuSeries*>& streams, const Policy& policy,
                         std::span<const int64_t> labels, const DatasetOptions& options) {
  check_options(options, policy);
  if (streams.empty() || stream_names.size() != streams.size())
    throw Error("augment: give one name per stream");
  const std::size_t n = streams[0]->size();
  const double rate = measured_rate_hz(streams[0]->t, "augment: the recording");
  // A window stacks the streams' samples side by side, so they must be the same instants: every
  // stream's sample i within half a period of stream 0's (two devices' clocks differ by less;
  // streams at other rates, or one started later, differ by more).
  for (std::size_t s = 1; s < streams.size(); ++s) {
    const std::vector<TimeNs>& t0 = streams[0]->t;
    const std::vector<TimeNs>& ts = streams[s]->t;
    if (ts.size() != n) {
      throw Error(fmt::format(
          "augment: stream {} has {} samples, stream {} has {}: the streams "
          "of a recording must share one time base (resample them first)",
          quote_excerpt(stream_names[s]), ts.size(), quote_excerpt(stream_names[0]), n));
    }
    const double half_period_ns = 0.5e9 / rate;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::abs(static_cast<double>(ts[i] - t0[i])) > half_period_ns) {
        throw Error(fmt::format(
            "augment: sample {} of stream {} is {:+.6f} s off sample {} of stream {} (more than "
            "half a sample period at {:.6g} Hz): the streams of a recording must share one time "
            "base "
            "(resample them first)",
            i, quote_excerpt(stream_names[s]), static_cast<double>(ts[i] - t0[i]) * 1e-9, i,
            quote_excerpt(stream_names[0]), rate));
      }
    }
  }
  check_finite(stream_names, streams);
  const std::vector<int64_t> base = window_starts(n, options.window, options.stride);
  if (base.empty())
    throw Error(fmt::format("augment: the recording ({} samples) is shorter than a window of {}", n,
                            options.window));
  if (!labels.empty() && labels.size() != n)
    throw Error(fmt::format("augment: {} labels for {} samples", labels.size(), n));
  const std::vector<int64_t> base_labels = window_labels(labels, base, options.window);
  const std::size_t N = options.count > 0 ? options.count : base.size();
  const std::size_t T = options.window, C = 6 * streams.size();
  check_time_scaling_fits(policy, options.normalize, rate, T, n);
  // X, the base windows, a batch and (for time scaling) the whole recording are held at once.
  check_size(N, base.size() + std::min(options.batch_size, N) + n / T + 1, T, C, options.max_bytes);
  std::vector<float> windows = extract_windows(streams, base, options.window);
  Dataset d;
  d.info = base_info(policy, options);
  d.info.mode = "stda";
  d.info.sensors = stream_names;
  d.info.rate_hz = rate;
  // The statistics of the recording's windows. They are z-scored after the transforms that act
  // on physical units (a rotation or scaling of z-scored channels is neither), before the
  // jitter of the hardware ranges, whose sigmas are then standard deviations (the paper's
  // setting; stda_counterparts).
  if (options.normalize) channel_statistics(windows, C, d.info);
  const ChannelLayout layout = ChannelLayout::imu(stream_names);
  d.shape = {N, T, C};
  d.X.resize(d.shape.size());
  d.y.resize(N);
  d.sub_policy.resize(N);
  const Rng root(options.seed);
  const std::vector<std::size_t> order = batch_order(N, options.seed);
  std::vector<float> whole;    // the recording itself, for time scaling
  std::vector<float> batch_x;  // the batch's windows, then scattered to their places in X
  for (std::size_t b0 = 0, batch = 0; b0 < N; b0 += options.batch_size, ++batch) {
    const std::size_t nb = std::min(options.batch_size, N - b0);
    const std::span<const std::size_t> members(order.data() + b0, nb);
    Rng br = root.child(batch);
    const int64_t idx = batch_sub_policy(policy, options.identity_fraction, br);
    batch_x.resize(nb * T * C);
    for (std::size_t k = 0; k < nb; ++k) {
      const std::size_t src = members[k] % base.size();
      std::copy_n(windows.data() + src * T * C, T * C, batch_x.data() + k * T * C);
      d.y[members[k]] = base_labels[src];
      d.sub_policy[members[k]] = idx;
    }
    if (idx >= 0) {
      const SubPolicy& sub = policy.sub_policies[static_cast<std::size_t>(idx)];
      std::vector<StdaSpec> specs = stda_counterparts(sub, policy, options.normalize, rate);
      std::vector<StdaSpec> after_normalizing = jitter_in_standard_deviations(specs, sub, options);
      const auto scaling = std::find_if(specs.begin(), specs.end(), [](const StdaSpec& spec) {
        return spec.method == StdaMethod::time_scaling;
      });
      if (scaling != specs.end()) {
        if (whole.empty()) whole = extract_windows(streams, std::vector<int64_t>{0}, n);
        scale_time_from_recording(*scaling, whole, n, C, base, members, br, batch_x, T);
        specs.erase(scaling);
      }
      for (const StdaSpec& spec : specs) apply_stda(spec, layout, batch_x, {nb, T, C}, br);
      if (options.normalize) apply_normalization(batch_x, C, d.info);
      for (const StdaSpec& spec : after_normalizing)
        apply_stda(spec, layout, batch_x, {nb, T, C}, br);
    } else if (options.normalize) {
      apply_normalization(batch_x, C, d.info);
    }
    for (std::size_t k = 0; k < nb; ++k)
      std::copy_n(batch_x.data() + k * T * C, T * C, d.X.data() + members[k] * T * C);
  }
  return d;
}

}  // namespace imukit::augment
