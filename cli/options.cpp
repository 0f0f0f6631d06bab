#include "options.hpp"

#include <fmt/core.h>

#include <charconv>
#include <cmath>
#include <limits>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/simulator.hpp"

namespace imukit::cli {
namespace {

// 1e7 rather than 1e+07.
std::string number_text(double v) {
  std::string s = fmt::format("{:g}", v);
  for (const char* from : {"e+0", "e+", "e-0"}) {
    const auto at = s.find(from);
    if (at != std::string::npos) {
      s.replace(at, std::string_view(from).size(), from[1] == '-' ? "e-" : "e");
      break;
    }
  }
  return s;
}

std::string range_text(double lo, double hi, const std::string& unit, LowEnd low) {
  return fmt::format("{}{}, {}]{}", low == LowEnd::open ? "(" : "[", number_text(lo),
                     number_text(hi), unit.empty() ? "" : " " + unit);
}

}  // namespace

CLI::Validator real_in(double lo, double hi, const std::string& unit, LowEnd low) {
  const std::string range = range_text(lo, hi, unit, low);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0.0;
        const char* end = text.data() + text.size();
        // from_chars: no locale, no leading blanks, the whole text must be the number.
        const char* begin = text.data() + (!text.empty() && text[0] == '+' ? 1 : 0);
        const auto [ptr, ec] = std::from_chars(begin, end, v);
        const bool number = ec == std::errc() && ptr == end && std::isfinite(v);
        if (number && (low == LowEnd::open ? v > lo : v >= lo) && v <= hi) return {};
        return fmt::format("must be a {}number in {}, got {}", number ? "" : "finite ", range,
                           quote_excerpt(text, 24));
      },
      "in " + range, "real_in");
}

CLI::Validator whole_in(int64_t lo, int64_t hi, const std::string& unit) {
  const std::string range = fmt::format("[{}, {}]{}", lo, hi, unit.empty() ? "" : " " + unit);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        int64_t v = 0;
        const char* end = text.data() + text.size();
        const char* begin = text.data() + (!text.empty() && text[0] == '+' ? 1 : 0);
        // CLI11 converts the text again with base detection, so "010" would be checked as 10
        // and run as 8 (found in review): a leading zero is refused, as JSON refuses it.
        if (end - begin > 1 && begin[0] == '0') {
          return fmt::format("must be a whole number in {} written without leading zeros, got {}",
                             range, quote_excerpt(text, 24));
        }
        const auto [ptr, ec] = std::from_chars(begin, end, v);
        if (ec == std::errc() && ptr == end && v >= lo && v <= hi) return {};
        return fmt::format("must be a whole number in {}, got {}", range, quote_excerpt(text, 24));
      },
      "in " + range, "whole_in");
}

// One range for every command and for scenes (sim::GravityLimits, checked by check_gravity).
CLI::Validator gravity_range() {
  return real_in(sim::GravityLimits::min_m_s2, sim::GravityLimits::max_m_s2, "m/s^2");
}
// A scene's seeds and the Python Scene's take the same range (core/rng.hpp).
CLI::Validator seed_range() { return whole_in(0, static_cast<int64_t>(kMaxSeed)); }
CLI::Validator bvh_scale_range() {
  return real_in(sim::BvhLimits::min_scale, sim::BvhLimits::max_scale, "m per BVH unit");
}
CLI::Validator sample_rate_range() { return real_in(0.0, 1e6, "Hz", LowEnd::open); }

}  // namespace imukit::cli
