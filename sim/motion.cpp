#include "imukit/sim/motion.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <sstream>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/core/text_parse.hpp"
#include "imukit/core/time.hpp"

namespace imukit::sim {

Motion::Motion(double rate_hz, std::size_t joints, int64_t frames)
    : rate_hz_(rate_hz),
      joints_(joints),
      frames_(frames),
      translation_(Eigen::Matrix3Xd::Zero(3, frames)),
      rotations_(static_cast<std::size_t>(frames) * joints, Eigen::Quaterniond::Identity()) {
  assert(frames >= 0);
}

void Motion::read(int64_t first, int64_t count, std::span<const int> joints, MotionChunk& out) {
  assert(first >= 0 && count >= 0 && first + count <= frames_);
  out.first_frame = first;
  out.frames = count;
  out.joints = joints.size();
  out.root_translation = translation_.middleCols(first, count);
  out.rotations.resize(static_cast<std::size_t>(count) * joints.size());
  for (std::size_t k = 0; k < joints.size(); ++k) {
    const Eigen::Quaterniond* src = &rotation(first, static_cast<std::size_t>(joints[k]));
    for (int64_t f = 0; f < count; ++f) {
      out.rotations[static_cast<std::size_t>(f) * joints.size() + k] = src[f];
    }
  }
}

std::optional<double> normalize_rotation(Eigen::Quaterniond& q) {
  assert(q.coeffs().allFinite());
  const double n = q.norm();
  // The plain norm where its squares can neither overflow nor lose bits to underflow (and the
  // same bits as ever); otherwise scaled by the largest component first: a component of 1e155
  // squared to inf and q / inf gave the zero quaternion, one of 1e-300 squared to 0.
  if (n > 1e-100 && n < 1e100) {
    q.coeffs() /= n;
    return n;
  }
  const double largest = q.coeffs().cwiseAbs().maxCoeff();
  if (largest == 0.0) return std::nullopt;
  const Eigen::Vector4d scaled = q.coeffs() / largest;  // components in [-1, 1], one of them +-1
  const double scaled_norm = scaled.norm();
  q.coeffs() = scaled / scaled_norm;
  return largest * scaled_norm;
}

std::vector<std::string> Motion::validate_and_normalize(const Body* body, const FrameLines* lines) {
  const auto joint_name = [&](std::size_t j) {
    if (body != nullptr && body->size() == joints_) return body->joint(j).name;
    std::string s = "#";  // appended, not operator+: gcc 12 -Wrestrict false positive
    s += std::to_string(j);
    return s;
  };
  // "file:line: " of frame f when the lines are known, "motion: " otherwise.
  const auto where = [&](int64_t f) -> std::string {
    if (lines == nullptr || static_cast<std::size_t>(f) >= lines->line.size()) return "motion: ";
    InputLocation at;
    at.file = lines->file;
    at.line = lines->line[static_cast<std::size_t>(f)];
    return at.to_string() + ": ";
  };
  std::vector<std::string> warnings;
  int64_t off = 0;
  double worst = 0.0;
  int64_t worst_frame = 0;
  std::size_t worst_joint = 0;
  for (int64_t f = 0; f < frames_; ++f) {
    if (!translation_.col(f).allFinite()) {
      throw Error(where(f) + "frame " + std::to_string(f) + ": root translation is not finite");
    }
    if (const auto p = translation_.col(f);
        p.cwiseAbs().maxCoeff() > PlausibilityLimits::max_root_translation_m) {
      throw Error(fmt::format(
          "{}frame {}: root translation ({:g} {:g} {:g}) m is beyond {:g} m (not metres?)",
          where(f), f, p.x(), p.y(), p.z(), PlausibilityLimits::max_root_translation_m));
    }
    for (std::size_t j = 0; j < joints_; ++j) {
      Eigen::Quaterniond& q = rotation(f, j);
      if (!q.coeffs().allFinite()) {
        throw Error(where(f) + "frame " + std::to_string(f) + ", joint " + joint_name(j) +
                    ": quaternion is not finite");
      }
      const std::optional<double> n = normalize_rotation(q);
      if (!n) {
        throw Error(where(f) + "frame " + std::to_string(f) + ", joint " + joint_name(j) +
                    ": quaternion is all zeros (no rotation to normalise)");
      }
      const double dev = std::abs(*n - 1.0);
      if (dev > kQuaternionNormTolerance) {
        ++off;
        if (dev > worst) {
          worst = dev;
          worst_frame = f;
          worst_joint = j;
        }
      }
    }
  }
  if (off > 0) {
    std::ostringstream s;
    s << where(worst_frame) << off << " quaternions had norms further than "
      << kQuaternionNormTolerance << " from 1 and were renormalised (worst |1 - |q|| = " << worst
      << " at frame " << worst_frame << ", joint " << joint_name(worst_joint) << ")";
    warnings.push_back(s.str());
  }
  return warnings;
}

void require_simulatable(const MotionSource& motion, const std::string& what) {
  check_rate(motion.rate_hz(), what + ": the motion's frame rate");
  if (const auto n = motion.frame_count(); n && *n < 2) {
    throw Error(what + ": the motion has " + std::to_string(*n) +
                " frame(s); simulation needs at least 2 (velocities and accelerations are "
                "derivatives over time)");
  }
}

// --- ProceduralMotion -------------------------------------------------------------------------

ProceduralMotion::ProceduralMotion(std::size_t joints, const ProceduralMotionOptions& options)
    : options_(options) {
  double whole = 0.0;
  if (!(std::modf(options.rate_hz, &whole) == 0.0 && whole >= 1.0 && whole <= 1e6)) {
    throw Error("procedural motion: the rate must be a whole number of Hz in [1, 1e6]");
  }
  if (options.period_s < 1 || options.harmonics < 0) {
    throw Error("procedural motion: period_s must be >= 1 and harmonics >= 0");
  }
  if (options.frames && *options.frames < 0) throw Error("procedural motion: negative frame count");
  // Checked here, not only by the scene reader, so that scene files and Python's
  // ProceduralMotion share one check: a NaN amplitude from Python reached an assertion and a NaN
  // translation gave NaN samples (found in review, 2026-11-27).
  if (!(options.amplitude_rad >= 0.0 && options.amplitude_rad <= 10.0)) {
    throw Error(fmt::format("procedural motion: amplitude_rad must be in [0, 10] rad, got {}",
                            options.amplitude_rad));
  }
  if (!(options.translation_amplitude_m >= 0.0 && std::isfinite(options.translation_amplitude_m))) {
    throw Error(
        fmt::format("procedural motion: translation_amplitude_m must be finite and >= 0 m, got {}",
                    options.translation_amplitude_m));
  }
  period_frames_ = static_cast<int64_t>(whole) * options.period_s;
  Rng rng(options.seed);
  for (std::size_t j = 0; j < joints; ++j) {
    Eigen::Vector3d axis(rng.normal(), rng.normal(), rng.normal());
    axes_.push_back(axis.normalized());
    std::vector<int64_t> ks;
    std::vector<double> offs;
    for (int h = 0; h < options.harmonics; ++h) {
      // k / period_s Hz: 0.2 .. 1.2 Hz, the band of everyday human movement.
      ks.push_back(static_cast<int64_t>(rng.uniform_index(
                       static_cast<uint64_t>(std::max<int64_t>(1, options.period_s)))) +
                   options.period_s / 5);
      offs.push_back(rng.uniform());
    }
    harmonic_.push_back(std::move(ks));
    offset_.push_back(std::move(offs));
  }
  for (auto& t : translation_harmonic_) {
    t.push_back(options.period_s / 5 + static_cast<int64_t>(rng.uniform_index(static_cast<uint64_t>(
                                           std::max<int64_t>(1, options.period_s)))));
  }
}

double ProceduralMotion::phase(int64_t absolute_frame, int64_t k) const {
  // (frame * k) mod P in integers: exact for any frame, so no drift over hours.
  const int64_t m = ((absolute_frame % period_frames_) * k) % period_frames_;
  return 2.0 * std::numbers::pi * static_cast<double>(m) / static_cast<double>(period_frames_);
}

void ProceduralMotion::read(int64_t first, int64_t count, std::span<const int> joints,
                            MotionChunk& out) {
  assert(first >= 0 && count >= 0);
  assert(!options_.frames || first + count <= *options_.frames);
  out.first_frame = first;
  out.frames = count;
  out.joints = joints.size();
  out.root_translation.resize(3, count);
  out.rotations.resize(static_cast<std::size_t>(count) * joints.size());
  for (int64_t f = 0; f < count; ++f) {
    const int64_t a = options_.start_frame + first + f;
    for (int axis = 0; axis < 3; ++axis) {
      const int64_t k = translation_harmonic_[static_cast<std::size_t>(axis)].front();
      out.root_translation(axis, f) =
          options_.translation_amplitude_m * std::sin(phase(a, k) + 0.7 * axis);
    }
    for (std::size_t i = 0; i < joints.size(); ++i) {
      const auto j = static_cast<std::size_t>(joints[i]);
      double angle = 0.0;
      for (std::size_t h = 0; h < harmonic_[j].size(); ++h) {
        angle += options_.amplitude_rad *
                 std::sin(phase(a, harmonic_[j][h]) + 2.0 * std::numbers::pi * offset_[j][h]);
      }
      out.rotations[static_cast<std::size_t>(f) * joints.size() + i] =
          Eigen::Quaterniond(Eigen::AngleAxisd(angle, axes_[j]));
    }
  }
}

Motion ProceduralMotion::materialize(int64_t frames) {
  Motion m(options_.rate_hz, axes_.size(), frames);
  std::vector<int> all(axes_.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = static_cast<int>(j);
  MotionChunk c;
  // In chunks: the copy never holds more than 4096 frames beside the motion.
  for (int64_t first = 0; first < frames; first += 4096) {
    const int64_t n = std::min<int64_t>(4096, frames - first);
    read(first, n, all, c);
    for (int64_t f = 0; f < n; ++f) {
      m.root_translation(first + f) = c.root_translation.col(f);
      for (std::size_t j = 0; j < all.size(); ++j) m.rotation(first + f, j) = c.rotation(f, j);
    }
  }
  return m;
}

// --- quaternion CSV ---------------------------------------------------------------------------

namespace {

// What each column of a joint-quaternion CSV holds: -1 nothing, 0 time, 1..3 root x..z,
// 10 + 4 j + c joint j's component c (w, x, y, z).
struct QuaternionColumns {
  std::vector<int> role;
  bool have_t = false;
};

QuaternionColumns quaternion_columns(const std::vector<Field>& fields, const Body& body,
                                     const std::function<InputLocation(int64_t)>& at) {
  QuaternionColumns cols;
  cols.role.assign(fields.size(), -1);
  std::vector<std::array<bool, 4>> have(body.size(), {false, false, false, false});
  std::array<bool, 4> have_t_root{false, false, false, false};  // t, root_x, root_y, root_z
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::string name(fields[i].text);
    const bool is_t = name == "t" || name == "time" || name == "t_s";
    const bool is_root = name == "root_x" || name == "root_y" || name == "root_z";
    if (is_t || is_root) {
      // A second one was taken, the last winning (a second time column gave "not uniform";
      // found in review, 2026-11-27).
      const int role = is_t ? 0 : 1 + (name.back() - 'x');
      if (have_t_root[static_cast<std::size_t>(role)])
        throw Error(at(fields[i].column),
                    fmt::format("a second {} column", is_t ? "time" : quote_excerpt(name)));
      have_t_root[static_cast<std::size_t>(role)] = true;
      cols.role[i] = role;
      cols.have_t = cols.have_t || is_t;
    } else if (name.size() > 3 && name[name.size() - 3] == '_' && name[name.size() - 2] == 'q') {
      const char c = name.back();
      const int comp = c == 'w' ? 0 : c == 'x' ? 1 : c == 'y' ? 2 : c == 'z' ? 3 : -1;
      const auto j = body.find(name.substr(0, name.size() - 3));
      if (comp < 0 || !j) {
        throw Error(at(fields[i].column),
                    "column " + quote_excerpt(name) + " names no joint of the body");
      }
      if (have[static_cast<std::size_t>(*j)][static_cast<std::size_t>(comp)]) {
        throw Error(at(fields[i].column),
                    "column " + quote_excerpt(name) + " repeats a joint component");
      }
      have[static_cast<std::size_t>(*j)][static_cast<std::size_t>(comp)] = true;
      cols.role[i] = 10 + 4 * *j + comp;
    } else {
      throw Error(at(fields[i].column), "unknown column " + quote_excerpt(name) +
                                            " (expected t, root_x..z or <joint>_qw..qz)");
    }
  }
  for (std::size_t j = 0; j < body.size(); ++j) {
    const auto& h = have[j];
    if ((h[0] || h[1] || h[2] || h[3]) && !(h[0] && h[1] && h[2] && h[3])) {
      throw Error(at(1), "joint " + body.joint(j).name + " needs all four columns _qw,_qx,_qy,_qz");
    }
  }
  return cols;
}

// The frame rate from the t column: a uniform step within the rates a BVH may state.
double rate_from_times(const std::vector<double>& times, int64_t frames, const FrameLines& lines) {
  const std::string& source_name = lines.file;
  if (frames < 2) {
    throw Error(InputLocation{source_name, std::nullopt, std::nullopt, std::nullopt},
                "motion has " + std::to_string(frames) +
                    " frame(s): the rate cannot be taken from t (simulation needs >= 2)");
  }
  const double dt = (times.back() - times.front()) / static_cast<double>(frames - 1);
  if (!(dt > 0.0)) throw Error(source_name + ": t does not increase");
  // A step of 1e20 s made the simulator's sample times overflow int64 ns (found by fuzzing),
  // one of 1e-12 s puts every frame at the same ns.
  if (!(dt >= 1e-6 && dt <= 3600.0)) {
    std::ostringstream what;
    what << "t steps by " << dt
         << " s per frame: motions are read at 1 frame per hour to 1e6 frames per second";
    throw Error(InputLocation{source_name, std::nullopt, std::nullopt, std::nullopt}, what.str());
  }
  // Each step within 1 % of the median step: times printed to the microsecond at 30 Hz, epoch
  // seconds (a double's spacing there is 2.4e-7 s) and imukit's own ns-rounded CSV at 7 kHz were
  // refused by a test of each step against the mean to 1e-6 (review, 2026-11-27); a missing
  // frame is a step of two. The rate is the mean's, over the whole span.
  const double median = median_step_s(times);
  for (int64_t f = 1; f < frames; ++f) {
    const double step = times[static_cast<std::size_t>(f)] - times[static_cast<std::size_t>(f - 1)];
    if (std::abs(step - median) > 0.01 * median) {
      // The frame's own line (f + 2 was off by the blank lines skipped before it).
      std::ostringstream what;
      what.precision(9);
      what << "t is not uniform: frame " << f << " comes " << step << " s after the one before, "
           << step / median << " times the median step of " << median
           << " s (1 % allowed: resample the motion first)";
      throw Error(
          InputLocation{source_name, lines.line[static_cast<std::size_t>(f)], 1, std::nullopt},
          what.str());
    }
  }
  // Steps that each pass but drift add up: every frame within 1 % of a period of the grid too.
  for (int64_t f = 1; f < frames; ++f) {
    const double off =
        times[static_cast<std::size_t>(f)] - (times.front() + static_cast<double>(f) * dt);
    if (std::abs(off) > 0.01 * dt) {
      std::ostringstream what;
      what.precision(9);
      what << "t is not uniform: frame " << f << " is " << off / dt
           << " periods off the uniform grid of step " << dt
           << " s (1 % allowed: the step drifts; resample the motion first)";
      throw Error(
          InputLocation{source_name, lines.line[static_cast<std::size_t>(f)], 1, std::nullopt},
          what.str());
    }
  }
  return 1.0 / dt;
}

// The rows' values (row-major, one per column) into a Motion of the body's joints.
Motion quaternion_motion(const std::vector<double>& values, const std::vector<int>& role,
                         double rate, const Body& body) {
  const std::size_t width = role.size();
  const auto frames = static_cast<int64_t>(values.size() / std::max<std::size_t>(width, 1));
  Motion m(rate, body.size(), frames);
  for (int64_t f = 0; f < frames; ++f) {
    for (std::size_t i = 0; i < width; ++i) {
      const double v = values[static_cast<std::size_t>(f) * width + i];
      if (role[i] >= 1 && role[i] <= 3) {
        m.root_translation(f)(role[i] - 1) = v;
      } else if (role[i] >= 10) {
        const auto j = static_cast<std::size_t>((role[i] - 10) / 4);
        const int c = (role[i] - 10) % 4;
        Eigen::Quaterniond& q = m.rotation(f, j);
        if (c == 0)
          q.w() = v;
        else if (c == 1)
          q.x() = v;
        else if (c == 2)
          q.y() = v;
        else
          q.z() = v;
      }
    }
  }
  return m;
}

}  // namespace

Motion parse_quaternion_csv(std::string_view text, const std::string& source_name, const Body& body,
                            std::optional<double> rate_hz, std::vector<std::string>* warnings) {
  LineReader reader(text, source_name);
  std::vector<Field> fields;
  const auto at = [&](int64_t column) {
    return InputLocation{source_name, reader.line_number(), column, std::nullopt};
  };
  std::optional<std::string_view> line = reader.next();
  if (!line)
    throw Error(InputLocation{source_name, 1, 1, std::nullopt},
                "empty file: expected a header row");
  split_fields(*line, fields);
  // A given rate is checked as a measured one (NaN, 0 or -5 came back as the motion's rate;
  // found in review, 2026-11-27).
  if (rate_hz) check_rate(*rate_hz, source_name + ": rate_hz");
  const QuaternionColumns cols = quaternion_columns(fields, body, at);
  if (!cols.have_t && !rate_hz) throw Error(at(1), "no t column: give the frame rate");
  std::vector<double> times;
  std::vector<double> values;  // row-major, fields.size() per row
  const std::size_t width = fields.size();
  // Per joint in the file, the fields of its w, x, y, z.
  std::vector<std::array<std::size_t, 4>> joint_fields(body.size(), {width, width, width, width});
  for (std::size_t i = 0; i < width; ++i) {
    if (cols.role[i] >= 10) {
      const auto j = static_cast<std::size_t>((cols.role[i] - 10) / 4);
      joint_fields[j][static_cast<std::size_t>((cols.role[i] - 10) % 4)] = i;
    }
  }
  FrameLines frame_lines{source_name, {}};
  while ((line = reader.next())) {
    if (line->empty()) continue;
    // This row's frame: the rows before it (counted before its t is stored, so every message
    // about the row names the same frame).
    const auto frame = static_cast<int64_t>(frame_lines.line.size());
    split_fields(*line, fields);
    if (fields.size() != width) {
      throw Error(at(1), "expected " + std::to_string(width) + " fields, got " +
                             std::to_string(fields.size()));
    }
    const std::size_t row = values.size();
    for (std::size_t i = 0; i < width; ++i) {
      const auto v = parse_double(fields[i].text);
      if (!v)
        throw Error(at(fields[i].column), "not a number: " + quote_excerpt(fields[i].text, 24));
      if (!std::isfinite(*v)) {
        throw Error(at(fields[i].column),
                    "frame " + std::to_string(frame) + ": value is not finite");
      }
      // Validated again with the Motion; here where the column is known.
      if (cols.role[i] >= 1 && cols.role[i] <= 3 &&
          std::abs(*v) > PlausibilityLimits::max_root_translation_m) {
        throw Error(at(fields[i].column),
                    fmt::format("frame {}: root translation {:g} m is beyond {:g} m (not metres?)",
                                frame, *v, PlausibilityLimits::max_root_translation_m));
      }
      values.push_back(*v);
      if (cols.role[i] == 0) times.push_back(*v);
    }
    if (!cols.have_t) times.push_back(0.0);
    // A quaternion of four zeros has no direction to normalise to; any other finite one does.
    for (std::size_t j = 0; j < body.size(); ++j) {
      const std::array<std::size_t, 4>& jf = joint_fields[j];
      if (jf[0] == width) continue;  // joint not in the file: identity
      if (values[row + jf[0]] == 0.0 && values[row + jf[1]] == 0.0 && values[row + jf[2]] == 0.0 &&
          values[row + jf[3]] == 0.0) {
        throw Error(at(fields[jf[0]].column),
                    "frame " + std::to_string(frame) + ", joint " + body.joint(j).name +
                        ": quaternion is all zeros (no rotation to normalise)");
      }
    }
    frame_lines.line.push_back(reader.line_number());
  }
  const auto frames = static_cast<int64_t>(values.size() / std::max<std::size_t>(width, 1));
  const double rate = rate_hz ? *rate_hz : rate_from_times(times, frames, frame_lines);
  // A t column beside a given rate must agree with it (found in review: it was ignored, so a
  // file with gaps or another rate was read at the given one without a word).
  if (rate_hz && cols.have_t && frames >= 2) {
    const double from_t = rate_from_times(times, frames, frame_lines);
    // The last frame within 1 % of a period of where the given rate puts it.
    if (std::abs(from_t - rate) > 0.01 * rate / static_cast<double>(frames - 1)) {
      std::ostringstream what;
      what << "the t column steps at " << from_t << " Hz, the given rate is " << rate
           << " Hz (give one of them, or the same)";
      throw Error(InputLocation{source_name, std::nullopt, std::nullopt, std::nullopt}, what.str());
    }
  }
  Motion m = quaternion_motion(values, cols.role, rate, body);
  std::vector<std::string> w = m.validate_and_normalize(&body, &frame_lines);
  if (warnings != nullptr) warnings->insert(warnings->end(), w.begin(), w.end());
  return m;
}

Motion read_quaternion_csv(const std::string& path, const Body& body, std::optional<double> rate_hz,
                           std::vector<std::string>* warnings) {
  const std::string text = read_regular_file(path, kMaxMotionBytes, "joint-quaternion CSV");
  return parse_quaternion_csv(text, path, body, rate_hz, warnings);
}

std::string format_quaternion_csv(const Body& body, const Motion& motion) {
  if (motion.joint_count() != body.size())
    throw Error("quaternion CSV: the motion has " + std::to_string(motion.joint_count()) +
                " joints, the body " + std::to_string(body.size()));
  std::string out = "t,root_x,root_y,root_z";
  for (const Joint& j : body.joints()) {
    for (const char* c : {"_qw", "_qx", "_qy", "_qz"}) out.append(",").append(j.name).append(c);
  }
  out += "\n";
  char buf[32];
  const auto put = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.17g", v);
    out += buf;
  };
  for (int64_t f = 0; f < motion.frames(); ++f) {
    std::snprintf(buf, sizeof buf, "%.17g", to_seconds(sample_time(0, f, motion.rate_hz())));
    out += buf;
    for (int k = 0; k < 3; ++k) put(motion.root_translation(f)(k));
    for (std::size_t j = 0; j < body.size(); ++j) {
      const Eigen::Quaterniond& q = motion.rotation(f, j);
      put(q.w()), put(q.x()), put(q.y()), put(q.z());
    }
    out += "\n";
  }
  return out;
}

void write_quaternion_csv(const std::string& path, const Body& body, const Motion& motion) {
  const std::string text = format_quaternion_csv(body, motion);
  write_text_file(path, text);
}

int64_t frames_to_simulate(const MotionSource& motion, std::optional<int64_t> limit,
                           std::string_view what) {
  const std::optional<int64_t> count = motion.frame_count();
  if (!count && !limit)
    throw Error(std::string(what) + ": an endless motion source needs a frame limit");
  int64_t frames = count.value_or(*limit);
  if (limit) frames = std::min(frames, *limit);
  if (frames < 2)
    throw Error(std::string(what) + ": at least 2 frames are needed, got " +
                std::to_string(frames));
  return frames;
}

}  // namespace imukit::sim
