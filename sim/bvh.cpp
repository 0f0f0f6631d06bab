#include "imukit/sim/bvh.hpp"

#include <fmt/core.h>

#include <array>
#include <cmath>
#include <numbers>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/text_parse.hpp"
#include "imukit/core/units.hpp"

namespace imukit::sim {
namespace {

struct Token {
  std::string_view text;
  int64_t line = 0;
  int64_t column = 0;
};

// Whitespace tokenizer that remembers where each token starts. Braces and ':' are tokens of
// their own only where BVH needs them ("{", "}", "Frames:", "Time:").
class Tokenizer {
 public:
  Tokenizer(std::string_view text, const std::string& name) : text_(text), name_(name) {}

  bool next(Token& t) {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++line_;
        col_ = 1;
        ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++col_;
        ++pos_;
      } else {
        break;
      }
    }
    if (pos_ >= text_.size()) return false;
    const std::size_t start = pos_;
    t.line = line_;
    t.column = col_;
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n' || c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') break;
      ++pos_;
      ++col_;
    }
    t.text = text_.substr(start, pos_ - start);
    return true;
  }

  Token expect_any(const char* what) {
    Token t;
    if (!next(t))
      throw Error(InputLocation{name_, line_, col_, std::nullopt},
                  std::string("unexpected end of file: expected ") + what);
    last_ = t;
    return t;
  }
  void expect(std::string_view word) {
    const Token t = expect_any(std::string(word).c_str());
    if (t.text != word)
      fail(t, "expected '" + std::string(word) + "', got " + quote_excerpt(t.text, 24));
  }
  double number(const char* what) {
    const Token t = expect_any(what);
    const auto v = parse_double(t.text);
    if (!v) fail(t, std::string("expected ") + what + ", got " + quote_excerpt(t.text, 24));
    if (!std::isfinite(*v)) fail(t, std::string(what) + " is not finite");
    return *v;
  }
  [[noreturn]] void fail(const Token& t, const std::string& what) const {
    throw Error(InputLocation{name_, t.line, t.column, std::nullopt}, what);
  }
  int64_t line() const { return line_; }
  // The token read last (a number's, for messages about its value).
  const Token& last() const { return last_; }
  std::size_t remaining() const { return text_.size() - pos_; }

 private:
  std::string_view text_;
  const std::string& name_;
  std::size_t pos_ = 0;
  int64_t line_ = 1;
  int64_t col_ = 1;
  Token last_;
};

enum class Channel { xpos, ypos, zpos, xrot, yrot, zrot };

struct RawJoint {
  std::string name;
  int parent = -1;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> end;
  std::array<Token, 3> offset_at, end_at;  // where each value is, for messages
  std::vector<Channel> channels;
};

void parse_joint(Tokenizer& tz, std::vector<RawJoint>& joints, int parent, int depth) {
  if (depth > 1000) {
    Token t;
    t.line = tz.line();
    tz.fail(t, "hierarchy nested deeper than 1000 joints");
  }
  const Token name = tz.expect_any("a joint name");
  if (name.text == "{") tz.fail(name, "joint has no name");
  RawJoint j;
  j.name = std::string(name.text);
  j.parent = parent;
  for (const RawJoint& other : joints) {
    if (other.name == j.name) tz.fail(name, "duplicate joint name " + quote_excerpt(j.name));
  }
  tz.expect("{");
  tz.expect("OFFSET");
  for (int i = 0; i < 3; ++i) {
    j.offset(i) = tz.number("an OFFSET value");
    j.offset_at[static_cast<std::size_t>(i)] = tz.last();
  }
  const Token ch = tz.expect_any("CHANNELS");
  if (ch.text != "CHANNELS") tz.fail(ch, "expected 'CHANNELS', got " + quote_excerpt(ch.text, 24));
  const Token nt = tz.expect_any("a channel count");
  const auto n = parse_double(nt.text);
  if (!n || *n != std::floor(*n) || *n < 0 || *n > 6) tz.fail(nt, "channel count must be 0..6");
  for (int i = 0; i < static_cast<int>(*n); ++i) {
    const Token c = tz.expect_any("a channel name");
    std::string l(c.text);
    for (char& x : l) x = static_cast<char>(std::tolower(static_cast<unsigned char>(x)));
    Channel k;
    if (l == "xposition")
      k = Channel::xpos;
    else if (l == "yposition")
      k = Channel::ypos;
    else if (l == "zposition")
      k = Channel::zpos;
    else if (l == "xrotation")
      k = Channel::xrot;
    else if (l == "yrotation")
      k = Channel::yrot;
    else if (l == "zrotation")
      k = Channel::zrot;
    else
      tz.fail(c, "unknown channel " + quote_excerpt(c.text, 24));
    for (Channel e : j.channels) {
      if (e == k) tz.fail(c, "channel " + quote_excerpt(c.text, 24) + " listed twice");
    }
    j.channels.push_back(k);
  }
  const int self = static_cast<int>(joints.size());
  joints.push_back(std::move(j));
  for (;;) {
    const Token t = tz.expect_any("JOINT, End Site or '}'");
    if (t.text == "}") return;
    if (t.text == "JOINT") {
      parse_joint(tz, joints, self, depth + 1);
    } else if (t.text == "End") {
      tz.expect("Site");
      tz.expect("{");
      tz.expect("OFFSET");
      RawJoint& parent_joint = joints[static_cast<std::size_t>(self)];
      Eigen::Vector3d e;
      for (int i = 0; i < 3; ++i) {
        e(i) = tz.number("an OFFSET value");
        parent_joint.end_at[static_cast<std::size_t>(i)] = tz.last();
      }
      tz.expect("}");
      parent_joint.end = e;
    } else {
      tz.fail(t, "expected JOINT, End Site or '}', got " + quote_excerpt(t.text, 24));
    }
  }
}

Eigen::Quaterniond axis_rotation(Channel c, double degrees) {
  const double a = degrees * kRadPerDeg;
  const Eigen::Vector3d axis = c == Channel::xrot   ? Eigen::Vector3d::UnitX()
                               : c == Channel::yrot ? Eigen::Vector3d::UnitY()
                                                    : Eigen::Vector3d::UnitZ();
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, axis));
}

// The MOTION section's header: the frame count, the frame time and the rate they give.
struct MotionHeader {
  Token frame_count;  // where messages about the frames point
  int64_t frames = 0;
  double frame_time_s = 0.0;
  double rate_hz = 0.0;
};

MotionHeader parse_motion_header(Tokenizer& tz) {
  {
    const Token t = tz.expect_any("MOTION");
    if (t.text == "ROOT") tz.fail(t, "more than one ROOT is not supported");
    if (t.text != "MOTION") tz.fail(t, "expected 'MOTION', got " + quote_excerpt(t.text, 24));
  }
  MotionHeader h;
  tz.expect("Frames:");
  h.frame_count = tz.expect_any("the frame count");
  const auto frames_d = parse_double(h.frame_count.text);
  if (!frames_d || *frames_d != std::floor(*frames_d) || *frames_d < 0 || *frames_d > 1e9) {
    tz.fail(h.frame_count, "frame count must be a whole number in [0, 1e9]");
  }
  h.frames = static_cast<int64_t>(*frames_d);
  tz.expect("Frame");
  tz.expect("Time:");
  const Token dtt = tz.expect_any("the frame time");
  const auto dt = parse_double(dtt.text);
  if (!dt || !std::isfinite(*dt) || !(*dt > 0.0))
    tz.fail(dtt, "frame time must be a positive number");
  // The same bound as a sensor rate: beyond it the frame times collapse onto each other.
  if (!(*dt >= 1.0 / BvhLimits::max_rate_hz && *dt <= BvhLimits::max_frame_time_s)) {
    tz.fail(dtt, fmt::format("frame time {:g} s is outside [{:g}, {:g}] s (rates up to {:g} Hz)",
                             *dt, 1.0 / BvhLimits::max_rate_hz, BvhLimits::max_frame_time_s,
                             BvhLimits::max_rate_hz));
  }
  h.frame_time_s = *dt;
  // Frame times are printed rounded (CMU: "0.008333" for 120 Hz). When a whole-number rate
  // reproduces the printed digits, use it: frame positions are then exact integers. Only when
  // the digits pin the time down to kSnapTolerance: "0.06" is 1/17 s rounded as well as 0.06 s
  // exactly, and taking 17 Hz would scale every derivative by 2 % (found in review).
  constexpr double kSnapTolerance = 0.005;
  h.rate_hz = 1.0 / *dt;
  const std::string_view txt = dtt.text;
  const std::size_t dot = txt.find('.');
  const bool plain = txt.find_first_of("eE") == std::string_view::npos;
  if (dot != std::string_view::npos && plain) {
    const double half_ulp = 0.5 * std::pow(10.0, -static_cast<double>(txt.size() - dot - 1));
    const double whole = std::round(h.rate_hz);
    if (whole >= 1.0 && half_ulp <= kSnapTolerance * *dt && std::abs(1.0 / whole - *dt) <= half_ulp)
      h.rate_hz = whole;
  }
  return h;
}

// The file's lengths in metres and imukit's z-up world, refusing values no body has.
class Lengths {
 public:
  Lengths(const BvhOptions& options, const std::string& source_name)
      : options_(options),
        source_name_(source_name),
        max_value_(BvhLimits::max_length_m / options.scale) {}

  // Exact for the y-up case: the change of basis maps (x, y, z) to (x, -z, y) with no rounding.
  Eigen::Vector3d to_world(const Eigen::Vector3d& v) const {
    const Eigen::Vector3d s = v * options_.scale;
    return options_.up == UpAxis::y ? Eigen::Vector3d(s.x(), -s.z(), s.y()) : s;
  }

  // Lengths and positions beyond BvhLimits::max_length_m are not a body on the Earth's surface
  // but a wrong scale or a corrupt file; refused where they are read. what() names the vector,
  // at[k] is where its component k was read (line 0 for a channel the file lacks, whose value is
  // 0), and the error points at the first value beyond the limit in the file (found in review: it
  // pointed at the line's first value, `t1.bvh:21:1` for the 99999 in column 5).
  template <class What>
  void check(const Eigen::Vector3d& v, const What& what, const std::array<Token, 3>& at) const {
    if (v.cwiseAbs().maxCoeff() <= max_value_) return;
    const Token* first = nullptr;
    for (std::size_t k = 0; k < 3; ++k) {
      const Token& t = at[k];
      if (!(std::abs(v(static_cast<Eigen::Index>(k))) > max_value_) || t.line == 0) continue;
      if (first == nullptr || t.line < first->line ||
          (t.line == first->line && t.column < first->column))
        first = &t;
    }
    if (first == nullptr) first = &at[0];  // not reached: the values beyond were read (finite)
    throw Error(InputLocation{source_name_, first->line, first->column, std::nullopt},
                fmt::format("{} ({:g} {:g} {:g}) is beyond {:g} m at scale {:g}: a wrong "
                            "scale or a corrupt file",
                            what(), v.x(), v.y(), v.z(), BvhLimits::max_length_m, options_.scale));
  }

 private:
  const BvhOptions& options_;
  const std::string& source_name_;
  double max_value_;
};

// The hierarchy's joints into out.body (canonical names, offsets in metres), with a warning
// when non-root joints have position channels.
void add_joints(const std::vector<RawJoint>& raw, const Lengths& lengths,
                const std::string& source_name, BvhData& out) {
  std::vector<std::string> names;
  for (const RawJoint& j : raw) names.push_back(j.name);
  const std::vector<std::string> canon = canonicalize_joint_names(names);
  bool ignored_positions = false;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    lengths.check(
        raw[i].offset, [&] { return "the OFFSET of " + quote_excerpt(raw[i].name); },
        raw[i].offset_at);
    if (raw[i].end) {
      lengths.check(
          *raw[i].end, [&] { return "the End Site of " + quote_excerpt(raw[i].name); },
          raw[i].end_at);
    }
    out.body.add_joint(
        canon[i], raw[i].parent,
        raw[i].parent < 0 ? Eigen::Vector3d::Zero() : lengths.to_world(raw[i].offset), raw[i].name);
    if (raw[i].end) out.body.joint(i).end_offset = lengths.to_world(*raw[i].end);
    if (raw[i].parent >= 0) {
      for (Channel c : raw[i].channels) {
        if (c == Channel::xpos || c == Channel::ypos || c == Channel::zpos)
          ignored_positions = true;
      }
    }
  }
  if (ignored_positions) {
    out.warnings.push_back(source_name +
                           ": position channels of non-root joints are ignored "
                           "(segment lengths are fixed by the OFFSETs)");
  }
}

// The frames' channel values into a Motion: joint rotations in the world's axes, the root's
// position channels (from its OFFSET) as the root translation.
Motion read_frames(Tokenizer& tz, const std::vector<RawJoint>& raw, const MotionHeader& h,
                   const Lengths& lengths, UpAxis up) {
  // Never allocate for frames the file cannot hold: each value takes at least 2 bytes.
  std::size_t channels = 0;
  for (const RawJoint& j : raw) channels += j.channels.size();
  if (h.frames > 0 && channels == 0)
    tz.fail(h.frame_count, "frames given but no joint has channels");
  if (h.frames > 0 && static_cast<double>(h.frames) * static_cast<double>(channels) >
                          static_cast<double>(tz.remaining()) / 2.0 + 1.0) {
    tz.fail(h.frame_count, "the file declares " + std::to_string(h.frames) + " frames of " +
                               std::to_string(channels) +
                               " channels but is too short to hold them");
  }
  // Up-axis change of basis C as a quaternion.
  const Eigen::Quaterniond qC =
      up == UpAxis::y
          ? Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()))
          : Eigen::Quaterniond::Identity();
  // The root's OFFSET is where the root sits when its position channels read 0.
  const Eigen::Vector3d root_offset = lengths.to_world(raw.front().offset);
  Motion motion(h.rate_hz, raw.size(), h.frames);
  for (int64_t f = 0; f < h.frames; ++f) {
    for (std::size_t i = 0; i < raw.size(); ++i) {
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      Eigen::Vector3d pos = Eigen::Vector3d::Zero();
      std::array<Token, 3> pos_at;  // where x, y and z were read
      for (Channel c : raw[i].channels) {
        const double v = tz.number("a channel value");
        const bool rotation = c == Channel::xrot || c == Channel::yrot || c == Channel::zrot;
        if (rotation && std::abs(v) > PlausibilityLimits::max_euler_deg) {
          tz.fail(tz.last(),
                  fmt::format("frame {}, joint {}: rotation {:g} deg is beyond {:g} deg: no "
                              "motion turns that far, and there rounding swamps its derivatives "
                              "(a corrupt file?)",
                              f, quote_excerpt(raw[i].name), v, PlausibilityLimits::max_euler_deg));
        }
        switch (c) {
          case Channel::xpos:
            pos.x() = v;
            pos_at[0] = tz.last();
            break;
          case Channel::ypos:
            pos.y() = v;
            pos_at[1] = tz.last();
            break;
          case Channel::zpos:
            pos.z() = v;
            pos_at[2] = tz.last();
            break;
          default:
            q = q * axis_rotation(c, v);
            break;  // intrinsic: right-multiply in order
        }
      }
      motion.rotation(f, i) = qC * q * qC.conjugate();
      if (i == 0) {
        lengths.check(
            pos, [&] { return fmt::format("the root position of frame {}", f); }, pos_at);
        motion.root_translation(f) = root_offset + lengths.to_world(pos);
      }
    }
  }
  Token extra;
  if (tz.next(extra)) {
    tz.fail(extra, "more values than " + std::to_string(h.frames) + " frames of channels");
  }
  return motion;
}

}  // namespace

BvhData parse_bvh(std::string_view text, const std::string& source_name,
                  const BvhOptions& options) {
  if (!(options.scale >= BvhLimits::min_scale && options.scale <= BvhLimits::max_scale)) {
    throw Error(fmt::format("{}: the BVH scale must be in [{:g}, {:g}] m per unit, got {:g}",
                            source_name, BvhLimits::min_scale, BvhLimits::max_scale,
                            options.scale));
  }
  Tokenizer tz(text, source_name);
  tz.expect("HIERARCHY");
  tz.expect("ROOT");
  std::vector<RawJoint> raw;
  parse_joint(tz, raw, -1, 0);
  const MotionHeader header = parse_motion_header(tz);
  const Lengths lengths(options, source_name);
  BvhData out;
  out.frame_time_s = header.frame_time_s;
  add_joints(raw, lengths, source_name, out);
  out.motion = read_frames(tz, raw, header, lengths, options.up);
  std::vector<std::string> w = out.motion.validate_and_normalize(&out.body);
  out.warnings.insert(out.warnings.end(), w.begin(), w.end());
  return out;
}

BvhData read_bvh(const std::string& path, const BvhOptions& options) {
  const std::string text = read_regular_file(path, kMaxMotionBytes, "BVH motion");
  return parse_bvh(text, path, options);
}

}  // namespace imukit::sim
