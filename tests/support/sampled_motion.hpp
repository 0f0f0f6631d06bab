// A two-joint motion (root + one child) sampled from functions of time, shared by the simulator
// and identification tests and the identification benchmark so all of them build it one way.
// Header-only: the benchmarks use it without linking the test support library (GoogleTest).
#pragma once

#include <cstdint>

#include "imukit/sim/motion.hpp"

namespace imukit::testing {

// Frames f = 0 .. frames-1 at time f / rate: root(t) and child(t) give the two joints' rotations
// (Eigen::Quaterniond), trans(t) the root translation (Eigen::Vector3d, m).
template <class Root, class Child, class Trans>
sim::Motion sampled_motion(double rate, int64_t frames, Root root, Child child, Trans trans) {
  sim::Motion m(rate, 2, frames);
  for (int64_t f = 0; f < frames; ++f) {
    const double t = static_cast<double>(f) / rate;
    m.rotation(f, 0) = root(t);
    m.rotation(f, 1) = child(t);
    m.root_translation(f) = trans(t);
  }
  return m;
}

}  // namespace imukit::testing
