#include "imukit/core/rng.hpp"

#include <bit>
#include <cassert>
#include <cmath>
#include <limits>

namespace imukit {
namespace {

// ---- SplitMix64 (Steele, Lea & Flood 2014; the seeding generator Vigna recommends) ----

constexpr uint64_t kGolden = 0x9e3779b97f4a7c15ULL;  // 2^64 / golden ratio

// The SplitMix64 output function: a bijection of 64-bit words with full avalanche.
constexpr uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

constexpr uint64_t splitmix64_next(uint64_t& state) {
  state += kGolden;
  return mix64(state);
}

// Key of the (seed, stream) pair. For a fixed stream it is a bijection of the seed, so two seeds
// of one stream never share a generator state; the stream enters through its own hash so that
// (seed, stream) and (stream, seed) differ.
constexpr uint64_t pair_key(uint64_t seed, uint64_t stream) {
  return mix64(seed ^ mix64(stream + 0xd1b54a32d192ed03ULL));
}

// ---- xoshiro256++ (Blackman & Vigna, "Scrambled linear pseudorandom number generators", 2021) --

constexpr uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

// One xoshiro256++ step on four words held wherever the caller keeps them.
inline uint64_t xoshiro_step(uint64_t& s0, uint64_t& s1, uint64_t& s2, uint64_t& s3) {
  const uint64_t result = rotl(s0 + s3, 23) + s0;
  const uint64_t t = s1 << 17;
  s2 ^= s0;
  s3 ^= s1;
  s1 ^= s2;
  s0 ^= s3;
  s2 ^= t;
  s3 = rotl(s3, 45);
  return result;
}

// The engine state as four scalars, passed by value in the normal sampler's slow path and held
// as a local in fill_normal, so that the compiler keeps it in registers (state whose address
// escapes lives on the stack).
struct Xoshiro256pp {
  uint64_t s0, s1, s2, s3;
  uint64_t next() { return xoshiro_step(s0, s1, s2, s3); }
  Xoshiro256pp snapshot() const { return *this; }
  void assign(const Xoshiro256pp& g) { *this = g; }
};

// The same engine working in place on Rng's member array (used by single draws, which would
// otherwise copy the state in and out on every call).
struct InPlaceXoshiro {
  std::array<uint64_t, 4>& s;
  uint64_t next() { return xoshiro_step(s[0], s[1], s[2], s[3]); }
  Xoshiro256pp snapshot() const { return {s[0], s[1], s[2], s[3]}; }
  void assign(const Xoshiro256pp& g) { s = {g.s0, g.s1, g.s2, g.s3}; }
};

inline uint64_t xoshiro_next(std::array<uint64_t, 4>& s) { return InPlaceXoshiro{s}.next(); }

// [0, 1) from the top 53 bits: every multiple of 2^-53 equally likely.
inline double to_unit(uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }
// (0, 1]: the same grid shifted by one step, so log() never sees 0.
inline double to_unit_open_left(uint64_t bits) {
  return static_cast<double>((bits >> 11) + 1) * 0x1.0p-53;
}

// 64 x 64 -> 128-bit product split in halves, in portable integer arithmetic.
inline void mul_64x64(uint64_t a, uint64_t b, uint64_t& hi, uint64_t& lo) {
  const uint64_t a_lo = a & 0xffffffffULL, a_hi = a >> 32;
  const uint64_t b_lo = b & 0xffffffffULL, b_hi = b >> 32;
  const uint64_t ll = a_lo * b_lo;
  const uint64_t lh = a_lo * b_hi;
  const uint64_t hl = a_hi * b_lo;
  const uint64_t hh = a_hi * b_hi;
  const uint64_t mid = (ll >> 32) + (lh & 0xffffffffULL) + (hl & 0xffffffffULL);
  lo = (mid << 32) | (ll & 0xffffffffULL);
  hi = hh + (lh >> 32) + (hl >> 32) + (mid >> 32);
}

// ---- Ziggurat for N(0, 1) (Marsaglia & Tsang, J. Stat. Softw. 5(8), 2000), 256 layers ----
//
// The half density f(x) = exp(-x^2 / 2) is covered by 256 layers of equal area v: layer 0 is the
// rectangle [0, r] x [0, f(r)] plus the tail beyond r (drawn as a strip of pseudo-width
// x_0 = v / f(r)); layer i >= 1 is [0, x_i] x [f(x_i), f(x_i+1)], with x_1 = r, x_256 = 0 and
// f(x_i+1) = f(x_i) + v / x_i. A point x = u x_i with x < x_i+1 lies under the curve and is
// accepted at once (98.5 % of draws).
//
// r and v were computed once with Python's double-precision math (bisection on r until the top
// layer's area equals v, mismatch 5e-16):
//   f_r = math.exp(-r*r/2)
//   v = r*f_r + math.sqrt(math.pi/2)*math.erfc(r/math.sqrt(2))   # rectangle + tail area
// The table is then built at first use from these literals with sqrt and portable_log only, so it
// is the same on every platform.
constexpr int kLayers = 256;
constexpr double kZigR = 0x1.d3bb48209ad33p+1;    // 3.654152885361009
constexpr double kZigV = 0x1.43016a5a43735p-8;    // 0.004928673233974658
constexpr double kZigFR = 0x1.4a605b6b9f70fp-10;  // exp(-r^2/2) = 0.001260285930498598

struct ZigguratTable {
  double x[kLayers + 1];  // layer widths x_0 .. x_256 (x_0 the base strip's pseudo-width)
  double f[kLayers + 1];  // f(x_i); f_0 unused, f_256 = 1
  double w[kLayers];      // x_i * 2^-53: scales a 53-bit integer into [0, x_i)
};

ZigguratTable make_ziggurat_table() {
  ZigguratTable t{};
  t.x[0] = kZigV / kZigFR;
  t.f[0] = 0.0;
  t.x[1] = kZigR;
  t.f[1] = kZigFR;
  for (int i = 1; i < kLayers - 1; ++i) {
    t.f[i + 1] = t.f[i] + kZigV / t.x[i];
    assert(t.f[i + 1] < 1.0);
    t.x[i + 1] = std::sqrt(-2.0 * portable_log(t.f[i + 1]));
  }
  t.x[kLayers] = 0.0;
  t.f[kLayers] = 1.0;
  for (int i = 0; i < kLayers; ++i) t.w[i] = t.x[i] * 0x1.0p-53;
  return t;
}

const ZigguratTable& ziggurat_table() {
  static const ZigguratTable table = make_ziggurat_table();
  return table;
}

// x with its sign bit flipped when bit 8 of the draw is set: the same value as
// (bit ? -x : x), without a branch that a random sign would mispredict half the time.
inline double with_random_sign(double x, uint64_t bits) {
  return std::bit_cast<double>(std::bit_cast<uint64_t>(x) ^ ((bits & 0x100u) << 55));
}

// The tail beyond r (Marsaglia 1964): with a = -log(u1) / r and b = -log(u2), accept r + a when
// 2 b > a^2. u1, u2 in (0, 1].
double normal_tail(Xoshiro256pp& g) {
  for (;;) {
    const double a = -portable_log(to_unit_open_left(g.next())) / kZigR;
    const double b = -portable_log(to_unit_open_left(g.next()));
    if (b + b > a * a) return kZigR + a;
  }
}

// Bits of one 64-bit draw: 0-7 the layer, 8 the sign, 11-63 the position x = (bits >> 11) w_i.
inline double position(uint64_t bits, const ZigguratTable& t) {
  return static_cast<double>(bits >> 11) * t.w[bits & 0xffu];
}

struct SlowDraw {
  Xoshiro256pp g;
  double value;
};

// Everything after a draw `bits` missed its layer's inner rectangle (1.5 % of draws): the wedge
// test, the tail, and on rejection new draws until one is accepted. Takes and returns the engine
// by value so that the fast path's state never has its address taken.
SlowDraw normal_slow_path(Xoshiro256pp g, const ZigguratTable& t, uint64_t bits) {
  for (;;) {
    const unsigned layer = static_cast<unsigned>(bits & 0xffu);
    const double x = position(bits, t);
    if (x < t.x[layer + 1]) return {g, with_random_sign(x, bits)};
    if (layer == 0) {
      const double tail = normal_tail(g);
      return {g, with_random_sign(tail, bits)};
    }
    // Wedge between x_i+1 and x_i: accept if a uniform height in [f(x_i), f(x_i+1)) is below
    // the curve, tested as x^2 < -2 log(y) to need only the portable log.
    const double y = t.f[layer] + to_unit(g.next()) * (t.f[layer + 1] - t.f[layer]);
    if (x * x < -2.0 * portable_log(y)) return {g, with_random_sign(x, bits)};
    // Rejected: start over with a new layer (retrying in the same layer would bias the draw).
    bits = g.next();
  }
}

// One N(0, 1) draw; the fast path inline, the rest out of line.
template <class Engine>
inline double draw_normal(Engine& e, const ZigguratTable& t) {
  const uint64_t bits = e.next();
  const double x = position(bits, t);
  if (x < t.x[(bits & 0xffu) + 1]) [[likely]] {
    return with_random_sign(x, bits);
  }
  const SlowDraw slow = normal_slow_path(e.snapshot(), t, bits);
  e.assign(slow.g);
  return slow.value;
}

}  // namespace

// log(x) = e ln2 + log(1 + f) with x = 2^e (1 + f), 1 + f in [sqrt(1/2), sqrt(2)). With
// s = f / (2 + f), log(1 + f) = 2 atanh(s) = 2 s + s R(s^2), R(z) = sum_{k>=1} 2 z^k / (2k + 1),
// and 2 s = f - s f = f - hfsq + s hfsq with hfsq = f^2 / 2, so the big term f is exact and only
// small corrections carry rounding (the arrangement of Tang 1990 and fdlibm). |s| <= 0.1716, so
// z <= 0.0295 and ten terms of R leave a truncation below 1e-18 relative. ln 2 is split into a
// 32-bit head (e * head is exact) and a tail.
double portable_log(double x) {
  assert(std::isfinite(x) && x > 0.0);
  constexpr double kLn2Hi = 0x1.62e42fee00000p-1;
  constexpr double kLn2Lo = 0x1.a39ef35793c76p-33;
  constexpr double kSqrtHalf = 0x1.6a09e667f3bcdp-1;
  int e = 0;
  double m = std::frexp(x, &e);  // exact: x = m 2^e, m in [0.5, 1), also for subnormal x
  if (m < kSqrtHalf) {
    m *= 2.0;  // exact
    --e;
  }
  const double f = m - 1.0;  // exact (Sterbenz: m is within a factor 2 of 1)
  const double s = f / (2.0 + f);
  const double z = s * s;
  // 2 / (2k + 1), k = 1 .. 10.
  static constexpr double kR[] = {2.0 / 3.0,  2.0 / 5.0,  2.0 / 7.0,  2.0 / 9.0,  2.0 / 11.0,
                                  2.0 / 13.0, 2.0 / 15.0, 2.0 / 17.0, 2.0 / 19.0, 2.0 / 21.0};
  double poly = kR[9];
  for (int i = 8; i >= 0; --i) poly = poly * z + kR[i];
  const double r = z * poly;
  const double hfsq = 0.5 * f * f;
  const double k = static_cast<double>(e);
  return k * kLn2Hi + (f - (hfsq - (s * (hfsq + r) + k * kLn2Lo)));
}

Rng::Rng(uint64_t seed, uint64_t stream) : seed_(seed), stream_(stream) {
  uint64_t sm = pair_key(seed, stream);
  // Four consecutive SplitMix64 outputs are distinct (its output function is a bijection of
  // distinct counters), so the state is never all zero.
  for (auto& word : state_) word = splitmix64_next(sm);
}

Rng Rng::child(uint64_t index) const {
  // Hash (stream, index) into a new stream of the same seed: independent of how far this
  // generator has run, and children of children stay distinct.
  return Rng(seed_, mix64(mix64(stream_ ^ 0x8bb84b93962eacc9ULL) + mix64(index + kGolden)));
}

uint64_t Rng::next_u64() { return xoshiro_next(state_); }

double Rng::uniform() { return to_unit(xoshiro_next(state_)); }

double Rng::uniform(double lo, double hi) {
  assert(std::isfinite(lo) && std::isfinite(hi) && lo < hi && std::isfinite(hi - lo));
  const double v = lo + (hi - lo) * uniform();
  // lo + (hi - lo) u can round up to hi for u close to 1; keep the interval half-open.
  return v < hi ? v : std::nextafter(hi, lo);
}

double Rng::uniform_in(double lo, double hi) {
  const double u = uniform();
  return lo == hi ? lo : lo + (hi - lo) * u;
}

uint64_t Rng::uniform_index(uint64_t n) {
  assert(n > 0);
  // Lemire, "Fast random integer generation in an interval" (ACM TOMACS 2019): the high word of
  // x * n is uniform on [0, n) once the low words below 2^64 mod n are rejected.
  uint64_t hi = 0, lo = 0;
  mul_64x64(xoshiro_next(state_), n, hi, lo);
  if (lo < n) {
    const uint64_t threshold = (0 - n) % n;  // 2^64 mod n
    while (lo < threshold) mul_64x64(xoshiro_next(state_), n, hi, lo);
  }
  return hi;
}

double Rng::normal() {
  InPlaceXoshiro e{state_};
  return draw_normal(e, ziggurat_table());
}

void Rng::fill_normal(std::span<double> out) {
  const ZigguratTable& table = ziggurat_table();
  Xoshiro256pp g{state_[0], state_[1], state_[2], state_[3]};  // a local copy stays in registers
  for (double& v : out) v = draw_normal(g, table);
  state_ = {g.s0, g.s1, g.s2, g.s3};
}

}  // namespace imukit
