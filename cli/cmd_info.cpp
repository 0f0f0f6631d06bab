// imukit info: what a recording holds: streams, samples, duration, measured rate and jitter,
// gaps, per-axis statistics of each channel, and events.
#include <fmt/core.h>

#include <cmath>
#include <limits>

#include "command.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/sampling.hpp"
#include "inputs.hpp"

namespace imukit::cli {
namespace {

// Statistics of the samples present: gaps (NaN, from --gaps columns) are counted and left out
// (found in review: they made every figure NaN).
void print_triad(const char* name, const char* unit, const Eigen::Matrix3Xd& m) {
  if (m.cols() == 0) return;
  Eigen::Vector3d mean, std_dev, lo, hi;
  Eigen::Index gaps = 0;
  for (int k = 0; k < 3; ++k) {
    double sum = 0.0, n = 0.0;
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -lo[k];
    for (Eigen::Index i = 0; i < m.cols(); ++i) {
      const double v = m(k, i);
      if (std::isnan(v)) continue;
      sum += v;
      n += 1.0;
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
    gaps = std::max<Eigen::Index>(gaps, m.cols() - static_cast<Eigen::Index>(n));
    mean[k] = n > 0.0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
    double ss = 0.0;
    for (Eigen::Index i = 0; i < m.cols(); ++i)
      if (!std::isnan(m(k, i))) ss += (m(k, i) - mean[k]) * (m(k, i) - mean[k]);
    std_dev[k] = n > 1.0 ? std::sqrt(ss / (n - 1.0)) : 0.0;
  }
  fmt::print(
      "  {:<6}{:<8} mean {:>12.6g} {:>12.6g} {:>12.6g}   std {:>10.4g} {:>10.4g} {:>10.4g}\n", name,
      unit, mean.x(), mean.y(), mean.z(), std_dev.x(), std_dev.y(), std_dev.z());
  fmt::print("  {:<14} min  {:>12.6g} {:>12.6g} {:>12.6g}   max {:>10.4g} {:>10.4g} {:>10.4g}\n",
             "", lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z());
  if (gaps > 0)
    fmt::print("  {:<14} {} of {} samples are gaps (NaN), left out of these figures\n", "", gaps,
               m.cols());
}

// `rate_note`: what the recorder said of the stream's rate when its times cannot give one (a
// replay of a device without a sample clock); then no rate is measured from them.
void print_stream(const std::string& title, const ImuSeries& s, const std::string& rate_note) {
  const SamplingStats st = analyze_sampling(s.t);
  fmt::print("{}: {} samples over {:.3f} s ({:.6f} .. {:.6f} s)\n", title, st.samples,
             to_seconds(st.duration), s.empty() ? 0.0 : to_seconds(s.t.front()),
             s.empty() ? 0.0 : to_seconds(s.t.back()));
  if (!rate_note.empty()) {
    fmt::print("  rate   {}\n", rate_note);
  } else if (st.samples >= 2) {
    fmt::print("  rate   {:.4f} Hz measured from the time stamps (mean period {:.6f} ms)\n",
               st.mean_rate_hz, st.mean_period_s * 1e3);
    fmt::print("  period median {:.6f} ms, min {:.6f} ms, max {:.6f} ms, jitter (std) {:.3f} us\n",
               st.median_period_s * 1e3, st.min_period_s * 1e3, st.max_period_s * 1e3,
               st.period_std_s * 1e6);
    fmt::print("  {}: {} gaps (> 1.5 median periods), {} repeated time stamps\n",
               st.is_uniform() ? "uniformly sampled" : "NOT uniformly sampled", st.gaps,
               st.repeated);
  }
  print_triad("accel", "[m/s^2]", s.accel);
  print_triad("gyro", "[rad/s]", s.gyro);
  print_triad("mag", "[T]", s.mag);
  if (s.has_temperature()) {
    fmt::print("  temp   [degC]  mean {:.3f}  min {:.3f}  max {:.3f}\n", s.temperature_c.mean(),
               s.temperature_c.minCoeff(), s.temperature_c.maxCoeff());
  }
}

int run_info(const std::vector<std::string>& tokens) {
  const std::vector<InputArg> inputs = parse_input_args(tokens);
  if (inputs.empty()) throw UsageError("info: name at least one input file");
  for (const InputArg& input : inputs) {
    const Recording r = load_recording(input);
    for (const auto& [name, series] : r.streams) {
      const auto note = r.metadata.find("imukit.session." + name + ".rate");
      print_stream(
          r.streams.size() == 1 && r.metadata.empty() ? input.path : input.path + " " + name,
          series, note == r.metadata.end() ? std::string() : note->second);
    }
    for (const auto& [key, value] : r.metadata) fmt::print("  metadata {} = {}\n", key, value);
    for (const Event& e : r.events) {
      fmt::print("  event {:.6f} s {} {}\n", to_seconds(e.t), e.kind, e.label);
    }
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    info,
    CommandSpec{
        "info", "Describe recordings: streams, measured rate, jitter, gaps, channel statistics", 30,
        [](CLI::App& sub) -> std::function<int()> {
          sub.allow_extras();
          sub.footer(input_options_help() +
                     "\n\nExamples:\n"
                     "  imukit info session.mcap\n"
                     "  imukit info imu0.csv\n"
                     "  imukit info imu_data.txt --columns t,gx,gy,gz,ax,ay,az --accel-unit g\n");
          return [&sub] { return run_info(sub.remaining()); };
        }});

}  // namespace imukit::cli
