// BVH import: the HIERARCHY becomes a Body (joint names canonicalised through the alias table,
// End Sites kept as segment ends), the MOTION a Motion (root translation and per-joint
// rotations).
//
// Euler handling is exact: a joint's rotation channels, in the order listed, are intrinsic
// rotations, R = R_axis1(a1) R_axis2(a2) R_axis3(a3) (degrees), composed as quaternions, so any
// channel order works and gimbal-lock poses (middle angle +-90 deg) give the right rotation.
//
// Frames: BVH is Y up; imukit's world is Z up. Unless up == z, every vector v of the file maps
// to C v with C = R_x(+90 deg), (x, y, z) -> (x, -z, y), and every rotation R to C R C^T (the
// same rotation seen in the new axes). Lengths and root positions are multiplied by `scale`
// (1 for metres, 0.01 for centimetres, 0.056444 for CMU units).
//
// The frame rate is 1 / Frame Time, snapped to the whole number of Hz that reproduces the
// printed digits (CMU's "0.008333" is 120 Hz, not 120.0048 Hz).
//
// Errors name the file, line and column of the offending token.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "imukit/sim/body.hpp"
#include "imukit/sim/motion.hpp"

namespace imukit::sim {

enum class UpAxis { y, z };

// What a BVH file and its options may say: the scale (metres per file unit) and the frame rate
// are bounded like the CLI's options, and no length or root position may exceed
// max_length_m once scaled.
struct BvhLimits {
  static constexpr double min_scale = 1e-5, max_scale = 100.0;
  static constexpr double max_rate_hz = 1e6;
  static constexpr double max_frame_time_s = 3600.0;
  static constexpr double max_length_m = 1e4;
};

struct BvhOptions {
  double scale = 1.0;
  UpAxis up = UpAxis::y;
};

struct BvhData {
  Body body;
  Motion motion;
  std::vector<std::string> warnings;
  double frame_time_s = 0.0;  // as written in the file
};

BvhData parse_bvh(std::string_view text, const std::string& source_name,
                  const BvhOptions& options = {});
BvhData read_bvh(const std::string& path, const BvhOptions& options = {});

// A Body and Motion as BVH (bvh_write.cpp): lengths divided by options.scale, vectors and
// rotations mapped back to Y up unless options.up == z (the inverse of the reader's mapping),
// every joint with Zrotation Yrotation Xrotation channels (the root also Xposition Yposition
// Zposition), angles unwrapped frame to frame so they stay continuous, 10 significant digits
// (1e-8 degrees); leaves end in an End Site at Body::segment_end. Reading the file back with the
// same options gives the body's offsets and the motion's rotations to 1e-9.
std::string format_bvh(const Body& body, const Motion& motion, const BvhOptions& options = {});
void write_bvh(const std::string& path, const Body& body, const Motion& motion,
               const BvhOptions& options = {});

}  // namespace imukit::sim
