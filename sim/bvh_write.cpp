// BVH writer (sim/bvh.hpp): the inverse of parse_bvh's mappings.
#include <cmath>
#include <cstdio>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/bvh.hpp"

namespace imukit::sim {
namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v == 0.0 ? 0.0 : v);  // no "-0"
  return buf;
}

// BVH names are single tokens.
std::string token(const std::string& name) {
  std::string s = name;
  for (char& c : s) {
    if (c == ' ' || c == '\t' || c == '{' || c == '}') c = '_';
  }
  return s;
}

// Intrinsic Z-Y-X angles (deg) of R = Rz(a) Ry(b) Rx(c) nearest the previous frame's: every
// rotation has two, (a, b, c) with b in [-90, 90] and (a + 180, 180 - b, c + 180), each
// unwrapped by whole turns. Taking the first always made a and c jump by 180 degrees wherever b
// passed +-90 (a body turning about the file's vertical Y axis, the middle one; review,
// 2026-11-27): the rotations read back right, but the channels were not continuous.
Eigen::Vector3d zyx_degrees(const Eigen::Matrix3d& R, const Eigen::Vector3d& previous) {
  const double s = std::clamp(-R(2, 0), -1.0, 1.0);
  const double b = std::asin(s);
  double a = 0.0, c = 0.0;
  if (std::abs(s) < 1.0 - 1e-12) {
    a = std::atan2(R(1, 0), R(0, 0));
    c = std::atan2(R(2, 1), R(2, 2));
  } else {
    // Gimbal lock: only a -+ c is determined; keep c at its previous value.
    c = previous.z() / kDegPerRad;
    const double d = std::atan2(-R(0, 1), R(1, 1));  // a - c (b = +90) or a + c (b = -90)
    a = s > 0 ? d + c : d - c;
  }
  const auto unwrapped = [&](Eigen::Vector3d e) {
    for (int k = 0; k < 3; ++k) e(k) += 360.0 * std::round((previous(k) - e(k)) / 360.0);
    return e;
  };
  const Eigen::Vector3d first = unwrapped({a * kDegPerRad, b * kDegPerRad, c * kDegPerRad});
  if (std::abs(s) >= 1.0 - 1e-12) return first;  // gimbal lock: one solution, kept above
  const Eigen::Vector3d second =
      unwrapped({a * kDegPerRad + 180.0, 180.0 - b * kDegPerRad, c * kDegPerRad + 180.0});
  return (second - previous).squaredNorm() < (first - previous).squaredNorm() ? second : first;
}

}  // namespace

std::string format_bvh(const Body& body, const Motion& motion, const BvhOptions& options) {
  if (motion.joint_count() != body.size())
    throw Error("BVH: the motion has " + std::to_string(motion.joint_count()) +
                " joints, the body " + std::to_string(body.size()));
  if (!(options.scale > 0.0)) throw Error("BVH: the scale must be positive");
  if (body.size() == 0) throw Error("BVH: the body has no joints");
  const bool y_up = options.up == UpAxis::y;
  // C^T: world (x, y, z) -> file (x, z, -y).
  const auto to_file = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d {
    const Eigen::Vector3d s = v / options.scale;
    return y_up ? Eigen::Vector3d(s.x(), s.z(), -s.y()) : s;
  };
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  if (y_up) C << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  std::string out = "HIERARCHY\n";
  const auto vec = [&](const Eigen::Vector3d& v) {
    std::string t = number(v.x());
    t.append(" ").append(number(v.y())).append(" ").append(number(v.z()));
    return t;
  };
  // Depth-first, children in index order; the motion's columns follow this order.
  std::vector<std::size_t> order;
  // Appends one line indented by `depth` tabs (append, not operator+: gcc 12 -Wrestrict).
  const auto line = [&](int depth, const std::string& a, const std::string& b = {}) {
    out.append(static_cast<std::size_t>(depth), '\t').append(a).append(b).append("\n");
  };
  const auto emit = [&](auto&& self, std::size_t j, int depth) -> void {
    const Joint& joint = body.joint(j);
    line(depth, joint.parent < 0 ? "ROOT " : "JOINT ", token(joint.name));
    line(depth, "{");
    line(depth + 1, "OFFSET ",
         vec(joint.parent < 0 ? Eigen::Vector3d::Zero() : to_file(joint.offset_parent_joint)));
    line(depth + 1, joint.parent < 0 ? "CHANNELS 6 Xposition Yposition Zposition "
                                       "Zrotation Yrotation Xrotation"
                                     : "CHANNELS 3 Zrotation Yrotation Xrotation");
    order.push_back(j);
    const std::vector<int> kids = body.children(static_cast<int>(j));
    for (const int k : kids) self(self, static_cast<std::size_t>(k), depth + 1);
    if (kids.empty()) {
      line(depth + 1, "End Site");
      line(depth + 1, "{");
      line(depth + 2, "OFFSET ", vec(to_file(body.segment_end(static_cast<int>(j)))));
      line(depth + 1, "}");
    }
    line(depth, "}");
  };
  emit(emit, 0, 0);
  if (order.size() != body.size()) throw Error("BVH: the body has more than one root");
  out.append("MOTION\nFrames: ").append(std::to_string(motion.frames())).append("\n");
  char buf[48];
  std::snprintf(buf, sizeof buf, "Frame Time: %.10g\n", 1.0 / motion.rate_hz());
  out += buf;
  std::vector<Eigen::Vector3d> previous(body.size(), Eigen::Vector3d::Zero());
  for (int64_t f = 0; f < motion.frames(); ++f) {
    out.append(vec(to_file(motion.root_translation(f))));
    for (const std::size_t j : order) {
      const Eigen::Matrix3d R =
          C.transpose() * motion.rotation(f, j).normalized().toRotationMatrix() * C;
      previous[j] = zyx_degrees(R, previous[j]);
      out.append(" ").append(vec(previous[j]));
    }
    out.append("\n");
  }
  return out;
}

void write_bvh(const std::string& path, const Body& body, const Motion& motion,
               const BvhOptions& options) {
  const std::string text = format_bvh(body, motion, options);
  write_text_file(path, text);
}

}  // namespace imukit::sim
