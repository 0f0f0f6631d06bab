// Constants several test files use, defined once: a unity build (the sanitizer pass of
// scripts/test.sh) compiles a module's test files as one translation unit, where two files'
// own definitions of kPi would collide.
#pragma once

#include <limits>
#include <numbers>

namespace imukit {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kEps = std::numeric_limits<double>::epsilon();  // 2.2e-16

}  // namespace imukit
