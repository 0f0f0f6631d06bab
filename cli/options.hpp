// Numeric options are checked once, when the command line is parsed, by the validators here
// (every command uses them, so every option reads its value the same way): the value must be a
// finite number (a whole number where the option counts something) inside the option's range,
// and the message names the option, the range with its unit and the value given, e.g.
//   imukit: error: --init-static: must be a number in (0, 3600] s, got 'nan'
// Ranges that several commands share are named here once.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace imukit::cli {

enum class LowEnd { closed, open };

// A finite number in [lo, hi], or (lo, hi] with LowEnd::open; `unit` follows the range.
CLI::Validator real_in(double lo, double hi, const std::string& unit, LowEnd low = LowEnd::closed);
// A whole number (decimal digits, optional sign) in [lo, hi].
CLI::Validator whole_in(int64_t lo, int64_t hi, const std::string& unit = "");

// Shared ranges.
CLI::Validator gravity_range();      // local gravity magnitude: [0.1, 100] m/s^2
CLI::Validator seed_range();         // [0, kMaxSeed = 2^63 - 1], a scene's too
CLI::Validator bvh_scale_range();    // metres per BVH length unit: sim::BvhLimits
CLI::Validator sample_rate_range();  // (0, 1e6] Hz

}  // namespace imukit::cli
