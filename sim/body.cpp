#include "imukit/sim/body.hpp"

#include <fmt/core.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cassert>
#include <cctype>
#include <functional>
#include <set>

#include "imukit/core/error.hpp"

namespace imukit::sim {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

struct Alias {
  const char* source;  // compared case-insensitively
  const char* canonical;
};

// Names both CMU releases agree on, the canonical names themselves and common other spellings
// (the reference simulator's L_ELBOW style, "upper arm"/"lower arm" rigs).
constexpr std::array kCommonAliases = {
    Alias{"hips", "pelvis"},
    Alias{"pelvis", "pelvis"},
    Alias{"hip", "pelvis"},
    Alias{"root", "pelvis"},
    Alias{"neck", "neck"},
    Alias{"head", "head"},
    Alias{"spine", "spine"},
    Alias{"chest", "chest"},
    Alias{"l_clavicle", "left_clavicle"},
    Alias{"r_clavicle", "right_clavicle"},
    Alias{"l_shoulder", "left_shoulder"},
    Alias{"r_shoulder", "right_shoulder"},
    Alias{"l_elbow", "left_elbow"},
    Alias{"r_elbow", "right_elbow"},
    Alias{"l_wrist", "left_wrist"},
    Alias{"r_wrist", "right_wrist"},
    Alias{"l_hip", "left_hip"},
    Alias{"r_hip", "right_hip"},
    Alias{"l_knee", "left_knee"},
    Alias{"r_knee", "right_knee"},
    Alias{"l_ankle", "left_ankle"},
    Alias{"r_ankle", "right_ankle"},
    Alias{"leftupperarm", "left_shoulder"},
    Alias{"rightupperarm", "right_shoulder"},
    Alias{"leftlowerarm", "left_elbow"},
    Alias{"rightlowerarm", "right_elbow"},
    Alias{"leftupperleg", "left_hip"},
    Alias{"rightupperleg", "right_hip"},
    Alias{"leftlowerleg", "left_knee"},
    Alias{"rightlowerleg", "right_knee"},
};

// CMU "3dsMax-friendly" conversion (cmuconvert-max): joints named for the joint.
constexpr std::array kCmuMaxAliases = {
    Alias{"lowerback", "spine"},
    Alias{"chest", "chest"},
    Alias{"leftcollar", "left_clavicle"},
    Alias{"rightcollar", "right_clavicle"},
    Alias{"leftshoulder", "left_shoulder"},
    Alias{"rightshoulder", "right_shoulder"},
    Alias{"leftelbow", "left_elbow"},
    Alias{"rightelbow", "right_elbow"},
    Alias{"leftwrist", "left_wrist"},
    Alias{"rightwrist", "right_wrist"},
    Alias{"lefthip", "left_hip"},
    Alias{"righthip", "right_hip"},
    Alias{"leftknee", "left_knee"},
    Alias{"rightknee", "right_knee"},
    Alias{"leftankle", "left_ankle"},
    Alias{"rightankle", "right_ankle"},
    Alias{"lefttoe", "left_toe"},
    Alias{"righttoe", "right_toe"},
};

// CMU "MotionBuilder-friendly" conversion (cmuconvert-mb2): joints named for the segment they
// carry, and LeftShoulder is the clavicle.
constexpr std::array kCmuMotionBuilderAliases = {
    Alias{"lowerback", "spine"},
    Alias{"spine1", "chest"},
    Alias{"leftshoulder", "left_clavicle"},
    Alias{"rightshoulder", "right_clavicle"},
    Alias{"leftarm", "left_shoulder"},
    Alias{"rightarm", "right_shoulder"},
    Alias{"leftforearm", "left_elbow"},
    Alias{"rightforearm", "right_elbow"},
    Alias{"lefthand", "left_wrist"},
    Alias{"righthand", "right_wrist"},
    Alias{"leftupleg", "left_hip"},
    Alias{"rightupleg", "right_hip"},
    Alias{"leftleg", "left_knee"},
    Alias{"rightleg", "right_knee"},
    Alias{"leftfoot", "left_ankle"},
    Alias{"rightfoot", "right_ankle"},
    Alias{"lefttoebase", "left_toe"},
    Alias{"righttoebase", "right_toe"},
};

struct SegmentName {
  const char* joint;
  const char* segment;
};
constexpr std::array kSegments = {
    SegmentName{"pelvis", "pelvis"},
    SegmentName{"spine", "abdomen"},
    SegmentName{"chest", "thorax"},
    SegmentName{"neck", "neck"},
    SegmentName{"head", "head"},
    SegmentName{"left_clavicle", "left_clavicle"},
    SegmentName{"right_clavicle", "right_clavicle"},
    SegmentName{"left_shoulder", "left_upper_arm"},
    SegmentName{"right_shoulder", "right_upper_arm"},
    SegmentName{"left_elbow", "left_forearm"},
    SegmentName{"right_elbow", "right_forearm"},
    SegmentName{"left_wrist", "left_hand"},
    SegmentName{"right_wrist", "right_hand"},
    SegmentName{"left_hip", "left_thigh"},
    SegmentName{"right_hip", "right_thigh"},
    SegmentName{"left_knee", "left_shank"},
    SegmentName{"right_knee", "right_shank"},
    SegmentName{"left_ankle", "left_foot"},
    SegmentName{"right_ankle", "right_foot"},
    SegmentName{"left_toe", "left_toes"},
    SegmentName{"right_toe", "right_toes"},
};

template <std::size_t N>
const char* lookup(const std::array<Alias, N>& table, const std::string& lowered) {
  for (const Alias& a : table) {
    if (lowered == a.source) return a.canonical;
  }
  return nullptr;
}

}  // namespace

const std::vector<std::string>& canonical_joint_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const SegmentName& s : kSegments) n.emplace_back(s.joint);
    return n;
  }();
  return names;
}

std::string segment_name(std::string_view canonical_joint) {
  for (const SegmentName& s : kSegments) {
    if (canonical_joint == s.joint) return s.segment;
  }
  return {};
}

std::vector<std::string> canonicalize_joint_names(const std::vector<std::string>& source_names) {
  // The MotionBuilder scheme is the one with LeftArm/LeftForeArm/LeftUpLeg; without them
  // "LeftShoulder" is the 3dsMax release's shoulder joint.
  bool motion_builder = false;
  for (const std::string& n : source_names) {
    const std::string l = lower(n);
    if (l == "leftarm" || l == "rightarm" || l == "leftforearm" || l == "rightforearm" ||
        l == "leftupleg" || l == "rightupleg") {
      motion_builder = true;
    }
  }
  std::vector<std::string> out;
  std::set<std::string> taken;
  for (const std::string& n : source_names) {
    const std::string l = lower(n);
    const char* c =
        motion_builder ? lookup(kCmuMotionBuilderAliases, l) : lookup(kCmuMaxAliases, l);
    if (c == nullptr) c = lookup(kCommonAliases, l);
    if (c == nullptr) {
      for (const SegmentName& s : kSegments) {
        if (l == s.joint) c = s.joint;
      }
    }
    if (c != nullptr && taken.insert(c).second) {
      out.emplace_back(c);
    } else {
      out.push_back(n);
    }
  }
  // A source name that equals a canonical name claimed by another joint would now be a
  // duplicate: suffix it so names stay unique.
  std::set<std::string> seen;
  for (std::string& n : out) {
    while (!seen.insert(n).second) n += "_";
  }
  return out;
}

int Body::add_joint(std::string name, int parent, const Eigen::Vector3d& offset_parent_joint,
                    std::string source_name) {
  assert(parent >= -1 && parent < static_cast<int>(joints_.size()));
  assert(parent >= 0 || joints_.empty());  // one root, first
  for (const Joint& j : joints_) {
    if (j.name == name) throw Error("body: duplicate joint name '" + name + "'");
  }
  if (!offset_parent_joint.allFinite()) {
    throw Error("body: joint '" + name + "' has a non-finite offset");
  }
  Joint j;
  j.source_name = source_name.empty() ? name : std::move(source_name);
  j.name = std::move(name);
  j.parent = parent;
  j.offset_parent_joint = offset_parent_joint;
  joints_.push_back(std::move(j));
  return static_cast<int>(joints_.size()) - 1;
}

std::optional<int> Body::find(std::string_view name) const {
  const std::string l = lower(name);
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    if (lower(joints_[i].name) == l || lower(joints_[i].source_name) == l)
      return static_cast<int>(i);
  }
  // A segment's name stands for the joint at its start. Some segments share their joint's name
  // (pelvis, neck, head, clavicles): that name was just looked up, so asking again would recurse
  // without end on a body without the joint.
  for (const SegmentName& s : kSegments) {
    if (l == s.segment && l != s.joint) return find(s.joint);
  }
  // An alias spelling of a canonical name this body uses.
  const std::vector<std::string> c = canonicalize_joint_names({std::string(name)});
  if (c.front() != name) {
    for (std::size_t i = 0; i < joints_.size(); ++i) {
      if (joints_[i].name == c.front()) return static_cast<int>(i);
    }
  }
  return std::nullopt;
}

int Body::index_of(std::string_view name) const {
  if (const auto i = find(name)) return *i;
  std::string known;
  for (const Joint& j : joints_) known += (known.empty() ? "" : ", ") + j.name;
  throw Error("body has no joint or segment '" + std::string(name) + "' (joints: " + known + ")");
}

std::vector<int> Body::chain(int j) const {
  std::vector<int> c;
  for (int k = j; k >= 0; k = joints_[static_cast<std::size_t>(k)].parent) c.push_back(k);
  std::reverse(c.begin(), c.end());
  return c;
}

std::vector<int> Body::children(int j) const {
  std::vector<int> c;
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    if (joints_[i].parent == j) c.push_back(static_cast<int>(i));
  }
  return c;
}

int Body::segment_child(int j) const {
  const std::vector<int> kids = children(j);
  if (kids.empty()) return -1;
  // Subtree depth picks the limb's continuation (the elbow, not a twist helper or the thumb).
  std::function<int(int)> depth = [&](int k) {
    int d = 0;
    for (int c : children(k)) d = std::max(d, 1 + depth(c));
    return d;
  };
  int best = kids.front();
  int best_depth = -1;
  double best_len = -1.0;
  for (int k : kids) {
    const int d = depth(k);
    const double len = joints_[static_cast<std::size_t>(k)].offset_parent_joint.norm();
    if (d > best_depth || (d == best_depth && len > best_len)) {
      best = k;
      best_depth = d;
      best_len = len;
    }
  }
  return best;
}

Eigen::Vector3d Body::segment_end(int j) const {
  if (const int child = segment_child(j); child >= 0) {
    const Eigen::Vector3d o = joints_[static_cast<std::size_t>(child)].offset_parent_joint;
    if (o.norm() > 0.0) return o;
  }
  const Joint& jj = joints_[static_cast<std::size_t>(j)];
  if (jj.end_offset && jj.end_offset->norm() > 0.0) return *jj.end_offset;
  return jj.offset_parent_joint;
}

std::vector<Eigen::Vector3d> Body::neutral_positions() const {
  std::vector<Eigen::Vector3d> p(joints_.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    if (joints_[i].parent >= 0) {
      p[i] = p[static_cast<std::size_t>(joints_[i].parent)] + joints_[i].offset_parent_joint;
    }
  }
  return p;
}

Eigen::Vector3d Body::forward_direction() const {
  const std::vector<Eigen::Vector3d> p = neutral_positions();
  const Eigen::Vector3d up(0, 0, 1);
  for (const auto& [l, r] :
       {std::pair{"left_hip", "right_hip"}, std::pair{"left_shoulder", "right_shoulder"}}) {
    const auto il = find(l);
    const auto ir = find(r);
    if (!il || !ir) continue;
    Eigen::Vector3d right = p[static_cast<std::size_t>(*ir)] - p[static_cast<std::size_t>(*il)];
    right -= right.dot(up) * up;
    if (right.norm() < 1e-9) continue;
    return up.cross(right).normalized();
  }
  return Eigen::Vector3d::UnitY();
}

Body body_from_joints(const std::vector<std::string>& names, const std::vector<int>& parents,
                      const Eigen::Ref<const Eigen::Matrix3Xd>& offsets, const std::string& what) {
  const std::size_t n = names.size();
  if (n == 0) throw Error(what + ": a body needs at least one joint");
  if (parents.size() != n || static_cast<std::size_t>(offsets.cols()) != n) {
    throw Error(what + ": " + std::to_string(n) + " names, " + std::to_string(parents.size()) +
                " parents and " + std::to_string(offsets.cols()) + " offsets (expected as many)");
  }
  const std::vector<std::string> canonical = canonicalize_joint_names(names);
  Body b;
  for (std::size_t i = 0; i < n; ++i) {
    const std::string at = what + ": joint " + std::to_string(i) + " ('" + names[i] + "')";
    if (names[i].empty()) throw Error(what + ": joint " + std::to_string(i) + " has no name");
    if (i == 0 && parents[i] != -1)
      throw Error(at + ": the first joint is the root and has parent -1");
    if (i > 0 && !(parents[i] >= 0 && static_cast<std::size_t>(parents[i]) < i)) {
      throw Error(at + ": parent " + std::to_string(parents[i]) +
                  " must be an earlier joint (parents come before children; one root)");
    }
    if (!offsets.col(static_cast<Eigen::Index>(i)).allFinite())
      throw Error(at + ": the offset is not finite");
    if (const Eigen::Vector3d o = offsets.col(static_cast<Eigen::Index>(i));
        o.cwiseAbs().maxCoeff() > PlausibilityLimits::max_position_m) {
      throw Error(fmt::format("{}: the offset ({:g} {:g} {:g}) m is beyond {:g} m (not metres?)",
                              at, o.x(), o.y(), o.z(), PlausibilityLimits::max_position_m));
    }
    for (std::size_t k = 0; k < i; ++k) {
      if (names[k] == names[i]) throw Error(at + ": duplicate joint name");
    }
    b.add_joint(canonical[i], parents[i], offsets.col(static_cast<Eigen::Index>(i)), names[i]);
  }
  return b;
}

Body Body::default_humanoid(double height_m) {
  if (!(height_m > 0.3 && height_m < 3.0)) {
    throw Error("default humanoid: height must be in (0.3, 3) m, got " + std::to_string(height_m));
  }
  const double H = height_m;
  Body b;
  using V = Eigen::Vector3d;
  // Stature ratios after Winter fig. 4.1: shoulder at 0.818 H, hip joint 0.530 H (the pelvis
  // root sits 0.03 H above it), knee 0.285 H, ankle 0.039 H, upper arm 0.186 H, forearm 0.146 H,
  // hand 0.108 H, foot 0.152 H.
  const int pelvis = b.add_joint("pelvis", -1, V::Zero());
  const int spine = b.add_joint("spine", pelvis, V(0, 0, 0.05 * H));
  const int chest = b.add_joint("chest", spine, V(0, 0, 0.11 * H));
  const int neck = b.add_joint("neck", chest, V(0, 0, 0.098 * H));
  const int head = b.add_joint("head", neck, V(0, 0, 0.052 * H));
  b.joint(static_cast<std::size_t>(head)).end_offset = V(0, 0, 0.13 * H);
  for (const double side : {-1.0, 1.0}) {
    const std::string s = side < 0 ? "left_" : "right_";
    const int clav = b.add_joint(s + "clavicle", chest, V(side * 0.015 * H, 0, 0.08 * H));
    const int sh = b.add_joint(s + "shoulder", clav, V(side * 0.1145 * H, 0, 0.018 * H));
    const int el = b.add_joint(s + "elbow", sh, V(side * 0.186 * H, 0, 0));
    const int wr = b.add_joint(s + "wrist", el, V(side * 0.146 * H, 0, 0));
    b.joint(static_cast<std::size_t>(wr)).end_offset = V(side * 0.108 * H, 0, 0);
  }
  for (const double side : {-1.0, 1.0}) {
    const std::string s = side < 0 ? "left_" : "right_";
    const int hip = b.add_joint(s + "hip", pelvis, V(side * 0.05 * H, 0, -0.03 * H));
    const int knee = b.add_joint(s + "knee", hip, V(0, 0, -0.245 * H));
    const int ankle = b.add_joint(s + "ankle", knee, V(0, 0, -0.246 * H));
    const int toe = b.add_joint(s + "toe", ankle, V(0, 0.11 * H, -0.03 * H));
    b.joint(static_cast<std::size_t>(toe)).end_offset = V(0, 0.042 * H, 0);
  }
  return b;
}

}  // namespace imukit::sim
