// Rng: a seedable random number generator whose output is the same on every platform and
// compiler, owned and passed explicitly by callers (no global state). Child streams give
// independent generators for parallel work, so results do not depend on the thread count.
//
// Engine: xoshiro256++ (Blackman & Vigna 2019), state seeded through SplitMix64. Uniform
// doubles use the top 53 bits. Normal draws use our own transform built only from IEEE-exact
// operations and a portable logarithm (std::normal_distribution differs between standard
// libraries, and libm's log may differ in the last bit between platforms).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <span>

namespace imukit {

// The largest seed a user may give (imukit simulate --seed, a scene's seeds, the Python Scene):
// seeds are the integers 0 to 2^63 - 1, the range an int64 holds, so the command line, a JSON
// integer (read exactly, unlike a number with a fraction or exponent, which is a double and
// beyond 2^53 not exact) and Python's int all represent every seed (docs/simulation.md, "Seeds").
inline constexpr uint64_t kMaxSeed = std::numeric_limits<int64_t>::max();

class Rng {
 public:
  explicit Rng(uint64_t seed, uint64_t stream = 0);

  // An independent generator for (this seed, this stream, index): derived by hashing, so it
  // neither advances nor depends on how far this generator has been used.
  Rng child(uint64_t index) const;

  uint64_t next_u64();
  // Uniform on [0, 1) with 53 random bits.
  double uniform();
  // Uniform on [lo, hi).
  double uniform(double lo, double hi);
  // lo + (hi - lo) u from one uniform() draw, taken even when lo == hi (which returns lo), so a
  // zero range consumes the same draws as any other (augmentation ranges rely on it). Unlike
  // uniform(lo, hi) it accepts lo == hi and does not clamp the result below hi.
  double uniform_in(double lo, double hi);
  // Uniform integer on [0, n), n > 0, without modulo bias.
  uint64_t uniform_index(uint64_t n);
  // Standard normal N(0, 1).
  double normal();
  double normal(double mean, double sigma) { return mean + sigma * normal(); }
  // Fills out with N(0, 1) draws: the same values as calling normal() out.size() times.
  void fill_normal(std::span<double> out);

  uint64_t seed() const { return seed_; }
  uint64_t stream() const { return stream_; }

 private:
  uint64_t seed_;
  uint64_t stream_;
  std::array<uint64_t, 4> state_;
};

// Natural logarithm of a finite x > 0 (asserted), built only from frexp and IEEE-exact
// arithmetic, so it gives the same bits on every platform (libm's log may differ in the last
// bit). Error below 1 ulp; normal() and its tables use it.
double portable_log(double x);

}  // namespace imukit
