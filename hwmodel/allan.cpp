#include "imukit/hwmodel/allan.hpp"

#include <fmt/core.h>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>

#include "imukit/core/error.hpp"
#include "imukit/core/isa.hpp"
#include "imukit/core/parallel.hpp"
#include "imukit/hwmodel/chi_square.hpp"

namespace imukit::hwmodel {
namespace {

// Squared differences are added into a block sum that is flushed every kBlock terms, so the
// rounding error of an n-term sum grows like (kBlock + n / kBlock) ulp instead of n ulp.
constexpr int64_t kBlock = 1024;

// Memory traffic, not arithmetic, bounds these sweeps (a 6-axis, 7.2 M-sample S is 345 MB), so
// the work is ordered for cache reuse:
// - the factors whose window of S (the 2m or 3m samples a term spans, times the axes) fits in
//   kSharedWindowBytes are done together, chunk by chunk of kChunk terms, in increasing j: every
//   one of them reads the newest part of S from memory at most once between them and the rest of
//   its window from the cache (for m <= kSmallFactor the chunk's neighbourhood, kChunk + 3 m
//   samples, stays in L2; above that the window stays in L3, which is 32 MB here, shared by the
//   cores and the other processes, so the budget is a fraction of it). So all of them together
//   cost one pass over S from memory instead of one pass each;
// - a larger factor visits its chunks in the order j0, j0 + m, j0 + 2m, ...: the chunk read at
//   offset j + m for one step is the chunk at offset j for the next, so each part of S is read
//   from memory about once per factor instead of two or three times.
// Sums run per chunk (at most kChunk terms) and chunks are added in a fixed order, so results
// do not depend on the number of threads.
constexpr int64_t kChunk = 4096;
constexpr int64_t kSmallFactor = 1024;
constexpr int64_t kSharedWindowBytes = int64_t(6) << 20;

// Adds sum over j in [j0, j1) of the squared difference of order `Order` (2: S_{j+2m} - 2 S_{j+m}
// + S_j; 3: S_{j+3m} - 3 S_{j+2m} + 3 S_{j+m} - S_j) to acc[0..axes). The generic kernel, for
// axis counts the lane kernels below do not serve.
// With Prefetch, also asks for S_{j+(Order+1)m}: the part of S the strided order (below) reads
// new in its next step, a whole chunk ahead, so the jump between chunks does not stall.
template <int Order, bool Prefetch = false>
inline void add_diff_squares(const double* S, int64_t m, int axes, int64_t j0, int64_t j1,
                             double* acc) {
  const int k = axes;
  double local[16] = {};
  for (int64_t j = j0; j < j1; ++j) {
    const double* s0 = S + j * k;
    const double* s1 = s0 + m * k;
    const double* s2 = s1 + m * k;
    if constexpr (Prefetch) {
      // Integer arithmetic: the address may lie past the end of S near the last chunks, which
      // a prefetch tolerates but pointer arithmetic would not.
      const auto ahead = reinterpret_cast<std::uintptr_t>(s2) +
                         std::uintptr_t((Order - 1) * m * k) * sizeof(double);
      __builtin_prefetch(reinterpret_cast<const void*>(ahead), 0, 2);
    }
    if constexpr (Order == 2) {
      for (int a = 0; a < k; ++a) {
        const double d = s2[a] - 2.0 * s1[a] + s0[a];
        local[a] += d * d;
      }
    } else {
      const double* s3 = s2 + m * k;
      for (int a = 0; a < k; ++a) {
        const double d = s3[a] - 3.0 * s2[a] + 3.0 * s1[a] - s0[a];
        local[a] += d * d;
      }
    }
  }
  for (int a = 0; a < k; ++a) acc[a] += local[a];
}

// One large factor: chunks in strided order (see above). out = sum of squared differences.
template <int Order>
void strided_sum(const double* S, int64_t n, int64_t m, int axes, double* out) {
  const int64_t terms = n + 1 - Order * m;
  for (int a = 0; a < axes; ++a) out[a] = 0.0;
  for (int64_t base = 0; base < m; base += kChunk) {
    const int64_t w = std::min(kChunk, m - base);
    for (int64_t j0 = base; j0 < terms; j0 += m) {
      double block[16] = {};
      add_diff_squares<Order, true>(S, m, axes, j0, std::min(j0 + w, terms), block);
      for (int a = 0; a < axes; ++a) out[a] += block[a];
    }
  }
}

// The lane kernels. With the axes interleaved (S sample-major), the terms of all axes over
// j in [j0, j1) are one contiguous run of flat indices f in [j0 k, j1 k), each reading
// S[f], S[f + m k], S[f + 2 m k] (and S[f + 3 m k]). The run is cut into blocks of kLanes
// entries, each lane with its own accumulator: independent chains the compiler turns into
// whole vector registers (SSE2, AVX2 or AVX-512, see the clones below) without reordering any
// sum, so every build computes the same numbers. kLanes is a multiple of every axis count it
// serves (1, 2, 3, 4, 6, 8, 12), so lane l always holds axis l mod k, and folding the lanes into
// the axes is a fixed sequence of additions.
constexpr int kLanes = 24;

bool lane_kernels_serve(int axes) { return kLanes % axes == 0; }

template <int Order, bool Prefetch>
[[gnu::always_inline]] inline void lane_diff_squares(const double* __restrict S, int64_t lag,
                                                     int64_t f0, int64_t f1,
                                                     double* __restrict lanes) {
  double local[kLanes] = {};
  int64_t f = f0;
  for (; f + kLanes <= f1; f += kLanes) {
    const double* s0 = S + f;
    const double* s1 = s0 + lag;
    const double* s2 = s1 + lag;
    if constexpr (Prefetch) {
      // The next strided step's new data (integer arithmetic: see add_diff_squares); one block
      // is three cache lines.
      const auto ahead =
          reinterpret_cast<std::uintptr_t>(s2) + std::uintptr_t((Order - 1) * lag) * sizeof(double);
      __builtin_prefetch(reinterpret_cast<const void*>(ahead), 0, 2);
      __builtin_prefetch(reinterpret_cast<const void*>(ahead + 64), 0, 2);
      __builtin_prefetch(reinterpret_cast<const void*>(ahead + 128), 0, 2);
    }
    if constexpr (Order == 2) {
      for (int l = 0; l < kLanes; ++l) {
        const double d = s2[l] - 2.0 * s1[l] + s0[l];
        local[l] += d * d;
      }
    } else {
      const double* s3 = s2 + lag;
      for (int l = 0; l < kLanes; ++l) {
        const double d = s3[l] - 3.0 * s2[l] + 3.0 * s1[l] - s0[l];
        local[l] += d * d;
      }
    }
  }
  for (int l = 0; f < f1; ++f, ++l) {
    const double* s0 = S + f;
    const double d = Order == 2 ? s0[2 * lag] - 2.0 * s0[lag] + s0[0]
                                : s0[3 * lag] - 3.0 * s0[2 * lag] + 3.0 * s0[lag] - s0[0];
    local[l] += d * d;
  }
  for (int l = 0; l < kLanes; ++l) lanes[l] += local[l];
}

[[gnu::always_inline]] inline void fold_lanes(const double* lanes, int axes, double* acc) {
  for (int l = 0; l < kLanes; ++l) acc[l % axes] += lanes[l];
}

// The small factors' kernel (one chunk) and a large factor's strided sweep (see above), built
// for the baseline, AVX2 and AVX-512 with IMUKIT_ISA_VARIANTS (core/isa.hpp), the variant
// picked at run time from the CPU. The arithmetic and its order are the same in each, so are the
// results. The kernels are inlined into each variant, which compiles them for its own
// instruction set.

template <int Order>
[[gnu::always_inline]] inline void lane_chunk(const double* S, int64_t m, int axes, int64_t j0,
                                              int64_t j1, double* acc) {
  double lanes[kLanes] = {};
  lane_diff_squares<Order, false>(S, m * axes, j0 * axes, j1 * axes, lanes);
  fold_lanes(lanes, axes, acc);
}

template <int Order>
[[gnu::always_inline]] inline void lane_strided(const double* S, int64_t n, int64_t m, int axes,
                                                double* out) {
  const int64_t terms = n + 1 - Order * m;
  double lanes[kLanes] = {};
  for (int64_t base = 0; base < m; base += kChunk) {
    const int64_t w = std::min(kChunk, m - base);
    for (int64_t j0 = base; j0 < terms; j0 += m) {
      lane_diff_squares<Order, true>(S, m * axes, j0 * axes, std::min(j0 + w, terms) * axes, lanes);
    }
  }
  for (int a = 0; a < axes; ++a) out[a] = 0.0;
  fold_lanes(lanes, axes, out);
}

// Two ADEV factors over the same chunk in one loop, sharing the loads of S_j (five streams
// instead of six; about 10 % less time for the factors whose other two streams come from L3).
// Each factor's lanes add the same terms in the same order as the single kernel, so the numbers
// are the same.
[[gnu::always_inline]] inline void chunk_pair_order2_kernel(const double* __restrict S, int64_t ma,
                                                            int64_t mb, int axes, int64_t j0,
                                                            int64_t j1, double* __restrict acc_a,
                                                            double* __restrict acc_b) {
  double la[kLanes] = {}, lb[kLanes] = {};
  const int64_t lag_a = ma * axes, lag_b = mb * axes, f1 = j1 * axes;
  int64_t f = j0 * axes;
  for (; f + kLanes <= f1; f += kLanes) {
    const double* s0 = S + f;
    for (int l = 0; l < kLanes; ++l) {
      const double x0 = s0[l];
      const double da = s0[2 * lag_a + l] - 2.0 * s0[lag_a + l] + x0;
      const double db = s0[2 * lag_b + l] - 2.0 * s0[lag_b + l] + x0;
      la[l] += da * da;
      lb[l] += db * db;
    }
  }
  for (int l = 0; f < f1; ++f, ++l) {
    const double* s0 = S + f;
    const double da = s0[2 * lag_a] - 2.0 * s0[lag_a] + s0[0];
    const double db = s0[2 * lag_b] - 2.0 * s0[lag_b] + s0[0];
    la[l] += da * da;
    lb[l] += db * db;
  }
  fold_lanes(la, axes, acc_a);
  fold_lanes(lb, axes, acc_b);
}
IMUKIT_ISA_VARIANTS(void, chunk_pair_order2, chunk_pair_order2_kernel,
                    (const double* S, int64_t ma, int64_t mb, int axes, int64_t j0, int64_t j1,
                     double* acc_a, double* acc_b),
                    (S, ma, mb, axes, j0, j1, acc_a, acc_b))
IMUKIT_ISA_VARIANTS(void, chunk_order2, lane_chunk<2>,
                    (const double* S, int64_t m, int axes, int64_t j0, int64_t j1, double* acc),
                    (S, m, axes, j0, j1, acc))
IMUKIT_ISA_VARIANTS(void, chunk_order3, lane_chunk<3>,
                    (const double* S, int64_t m, int axes, int64_t j0, int64_t j1, double* acc),
                    (S, m, axes, j0, j1, acc))
IMUKIT_ISA_VARIANTS(void, strided_order2, lane_strided<2>,
                    (const double* S, int64_t n, int64_t m, int axes, double* out),
                    (S, n, m, axes, out))
IMUKIT_ISA_VARIANTS(void, strided_order3, lane_strided<3>,
                    (const double* S, int64_t n, int64_t m, int axes, double* out),
                    (S, n, m, axes, out))

using SumFn = void (*)(const double*, int64_t, int64_t, int, double*);
using ChunkFn = void (*)(const double*, int64_t, int, int64_t, int64_t, double*);

SumFn pick_strided(int order, int axes) {
  if (lane_kernels_serve(axes)) return order == 2 ? &strided_order2 : &strided_order3;
  return order == 2 ? &strided_sum<2> : &strided_sum<3>;
}
ChunkFn pick_chunk(int order, int axes) {
  if (lane_kernels_serve(axes)) return order == 2 ? &chunk_order2 : &chunk_order3;
  return order == 2 ? &add_diff_squares<2> : &add_diff_squares<3>;
}

// The modified deviation's kernel over S (axes x (n+1), sample-major). A is the compile-time
// axis count (0: runtime `axes`).
// The inner sum W_j = sum_{i=j}^{j+m-1} D_i, D_i = S_{i+2m} - 2 S_{i+m} + S_i, slides:
// W_{j+1} = W_j + D_{j+m} - D_j, kept with Kahan compensation (w, wc per axis) so it does not
// drift. It must run in j order, so it is cut into spans that each start from a directly summed
// W: a whole factor (large m), or a group of chunks that all small factors sweep together.
// Two axes side by side in one SSE2 register (GCC/Clang vector extension: portable, and the
// operations per axis are those of the scalar code, in the same order, so are the results).
// The MDEV slide of 6 axes runs as three such pairs: gcc leaves the scalar loop unvectorised.
using Pair = double __attribute__((vector_size(16)));
inline Pair load_pair(const double* p) {
  Pair v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store_pair(double* p, Pair v) { std::memcpy(p, &v, sizeof v); }

template <int A>
struct Kernels {
  static int count(int axes) { return A > 0 ? A : axes; }

  static double D(const double* S, int64_t m, int k, int64_t i, int a) {
    return S[(i + 2 * m) * k + a] - 2.0 * S[(i + m) * k + a] + S[i * k + a];
  }

  // w, wc = W_j summed directly (Kahan): D_j + ... + D_{j+m-1}.
  static void start(const double* S, int64_t m, int axes, int64_t j, double* w, double* wc) {
    if constexpr (A == 6) {
      const Pair two = {2.0, 2.0};
      Pair pw[3] = {}, pwc[3] = {};
      for (int64_t i = j; i < j + m; ++i) {
        const double* s0 = S + i * 6;
        for (int q = 0; q < 3; ++q) {
          const Pair d = load_pair(s0 + 12 * m + 2 * q) - two * load_pair(s0 + 6 * m + 2 * q) +
                         load_pair(s0 + 2 * q);
          const Pair y = d - pwc[q];
          const Pair t = pw[q] + y;
          pwc[q] = (t - pw[q]) - y;
          pw[q] = t;
        }
      }
      for (int q = 0; q < 3; ++q) store_pair(w + 2 * q, pw[q]), store_pair(wc + 2 * q, pwc[q]);
      return;
    }
    const int k = count(axes);
    for (int a = 0; a < k; ++a) w[a] = wc[a] = 0.0;
    for (int64_t i = j; i < j + m; ++i) {
      for (int a = 0; a < k; ++a) {
        const double y = D(S, m, k, i, a) - wc[a];
        const double t = w[a] + y;
        wc[a] = (t - w[a]) - y;
        w[a] = t;
      }
    }
  }

  // Adds W_j^2 for j in [j0, j1) to acc, with w, wc holding W_{j0} on entry and W_{j1} on exit
  // (no slide past the last of the `terms` terms, whose successor would read past S).
  static void run(const double* S, int64_t m, int axes, int64_t j0, int64_t j1, int64_t terms,
                  double* w, double* wc, double* acc) {
    if constexpr (A == 6) {
      const Pair two = {2.0, 2.0};
      Pair pw[3], pwc[3], block[3] = {};
      for (int q = 0; q < 3; ++q) pw[q] = load_pair(w + 2 * q), pwc[q] = load_pair(wc + 2 * q);
      const int64_t slide_end = std::min(j1, terms - 1);
      int64_t j = j0;
      for (; j < slide_end; ++j) {
        const double* s0 = S + j * 6;
        const double* s1 = s0 + 6 * m;
        const double* s2 = s1 + 6 * m;
        const double* s3 = s2 + 6 * m;
        for (int q = 0; q < 3; ++q) {
          block[q] += pw[q] * pw[q];
          const Pair a0 = load_pair(s0 + 2 * q), a1 = load_pair(s1 + 2 * q);
          const Pair a2 = load_pair(s2 + 2 * q), a3 = load_pair(s3 + 2 * q);
          const Pair y = ((a3 - two * a2 + a1) - (a2 - two * a1 + a0)) - pwc[q];
          const Pair t = pw[q] + y;
          pwc[q] = (t - pw[q]) - y;
          pw[q] = t;
        }
      }
      for (; j < j1; ++j)
        for (int q = 0; q < 3; ++q) block[q] += pw[q] * pw[q];
      for (int q = 0; q < 3; ++q) {
        acc[2 * q] += block[q][0];
        acc[2 * q + 1] += block[q][1];
        store_pair(w + 2 * q, pw[q]);
        store_pair(wc + 2 * q, pwc[q]);
      }
      return;
    }
    const int k = count(axes);
    double block[16] = {};
    for (int64_t j = j0; j < j1; ++j) {
      for (int a = 0; a < k; ++a) block[a] += w[a] * w[a];
      if (j + 1 < terms) {
        for (int a = 0; a < k; ++a) {
          const double y = (D(S, m, k, j + m, a) - D(S, m, k, j, a)) - wc[a];
          const double t = w[a] + y;
          wc[a] = (t - w[a]) - y;
          w[a] = t;
        }
      }
    }
    for (int a = 0; a < k; ++a) acc[a] += block[a];
  }

  // One factor over all terms: sum of W_j^2 added block by block (kBlock terms each).
  static void modified(const double* S, int64_t n, int64_t m, int axes, double* out) {
    const int k = count(axes);
    double w[16], wc[16], total[16] = {};
    start(S, m, axes, 0, w, wc);
    const int64_t terms = n + 2 - 3 * m;
    for (int64_t j0 = 0; j0 < terms; j0 += kBlock) {
      double block[16] = {};
      run(S, m, axes, j0, std::min(terms, j0 + kBlock), terms, w, wc, block);
      for (int a = 0; a < k; ++a) total[a] += block[a];
    }
    for (int a = 0; a < k; ++a) out[a] = total[a];
  }
};

using StartFn = void (*)(const double*, int64_t, int, int64_t, double*, double*);
using RunFn = void (*)(const double*, int64_t, int, int64_t, int64_t, int64_t, double*, double*,
                       double*);

template <int A>
std::pair<StartFn, RunFn> modified_span_kernels() {
  return {&Kernels<A>::start, &Kernels<A>::run};
}

std::pair<StartFn, RunFn> pick_modified_span(int axes) {
  switch (axes) {
    case 1:
      return modified_span_kernels<1>();
    case 3:
      return modified_span_kernels<3>();
    case 6:
      return modified_span_kernels<6>();
    default:
      return modified_span_kernels<0>();
  }
}

using KernelFn = void (*)(const double*, int64_t, int64_t, int, double*);

KernelFn pick_modified(int axes) {
  switch (axes) {
    case 1:
      return &Kernels<1>::modified;
    case 3:
      return &Kernels<3>::modified;
    case 6:
      return &Kernels<6>::modified;
    default:
      return &Kernels<0>::modified;
  }
}

int64_t estimator_terms(Deviation kind, int64_t n, int64_t m) {
  switch (kind) {
    case Deviation::kAllan:
      return n + 1 - 2 * m;
    case Deviation::kModifiedAllan:
      return n + 2 - 3 * m;
    case Deviation::kHadamard:
      return n + 1 - 3 * m;
  }
  return 0;
}

// Generalised autocovariance of the phase of power-law noise with frequency exponent alpha, up
// to a positive factor (which cancels in the edf): see the header.
double phase_gacv(double t, int alpha) {
  const double at = std::abs(t);
  switch (alpha) {
    case 0:
      return -at;
    case -1:
      return at == 0.0 ? 0.0 : t * t * std::log(at);
    case -2:
      return at * at * at;
    default:
      return at < 0.5 ? 1.0 : 0.0;  // white PM: an impulse at lag 0
  }
}

// Autocorrelation of the difference weights: ADEV (1,-2,1) -> (1,-4,6,-4,1); HDEV (-1,3,-3,1)
// -> (-1,6,-15,20,-15,6,-1); offsets in units of m.
struct WeightAcf {
  std::vector<std::pair<int, double>> taps;
};
WeightAcf weight_acf(Deviation kind) {
  if (kind == Deviation::kHadamard) {
    return {{{-3, -1.0}, {-2, 6.0}, {-1, -15.0}, {0, 20.0}, {1, -15.0}, {2, 6.0}, {3, -1.0}}};
  }
  return {{{-2, 1.0}, {-1, -4.0}, {0, 6.0}, {1, -4.0}, {2, 1.0}}};
}

// Covariance of the estimator's terms at lag l (samples).
double term_covariance(Deviation kind, int64_t m, double l, int alpha) {
  const WeightAcf acf = weight_acf(kind);
  const double md = double(m);
  auto second_diff_cov = [&](double lag) {
    double c = 0.0;
    for (const auto& [k, w] : acf.taps) c += w * phase_gacv(lag + k * md, alpha);
    return c;
  };
  if (kind != Deviation::kModifiedAllan) return second_diff_cov(l);
  // MDEV's term is a box sum of m second differences: cov = sum_{|u|<m} (m - |u|) c2(l + u).
  if (alpha == 2) {
    // Impulse phase covariance: the box sums collapse to a triangle, exactly.
    double c = 0.0;
    for (const auto& [k, w] : acf.taps) c += w * std::max(0.0, md - std::abs(l + k * md));
    return c;
  }
  // Other noises: c2 is smooth between kinks at multiples of m; integrate the triangle-weighted
  // sum with at most 64 nodes per side (trapezoid), exact when m <= 64.
  const int64_t step = std::max<int64_t>(1, m / 64);
  double c = 0.0;
  for (int64_t u = -(m - 1); u <= m - 1; u += step) {
    c += double(step) * (md - std::abs(double(u))) * second_diff_cov(l + double(u));
  }
  return c;
}

// Per axis, the mean and a power of two near the largest |sample|. The cumulative sums are
// built from y / scale - mean / scale, so the squares the kernels take are of order 1 whatever
// the signal's unit (found in review: white noise of 1e-170 squared to 0 and read as a constant
// axis, one sample of 1e200 to infinity); the deviations are multiplied back. A power of two
// divides exactly, so a record scaled by 2^k gives the same bits times 2^k.
struct AxisLevels {
  Eigen::VectorXd mean;
  Eigen::VectorXd scale;
};

// For interleaved axes the flat run of values is summed in kLanes lanes (lane l holds axis
// l mod k, as in the kernels), a pass at the speed of memory where Eigen's row-wise mean of a
// 6-row matrix takes about 2.5 times longer. The mean only keeps S small (it cancels in every
// difference), so a plain sum is exact enough. A NaN or infinity makes the mean non-finite.
AxisLevels axis_levels(const Eigen::Ref<const Eigen::MatrixXd>& samples) {
  const int axes = int(samples.rows());
  const auto n = int64_t(samples.cols());
  AxisLevels out;
  Eigen::VectorXd largest;
  if (samples.outerStride() != axes || !lane_kernels_serve(axes)) {
    out.mean = samples.rowwise().mean();
    largest = samples.cwiseAbs().rowwise().maxCoeff();
  } else {
    const double* p = samples.data();
    const int64_t total = n * axes;
    double lanes[kLanes] = {}, peaks[kLanes] = {};
    int64_t f = 0;
    for (; f + kLanes <= total; f += kLanes) {
      for (int l = 0; l < kLanes; ++l) {
        lanes[l] += p[f + l];
        peaks[l] = std::max(peaks[l], std::abs(p[f + l]));
      }
    }
    for (int l = 0; f < total; ++f, ++l) {
      lanes[l] += p[f];
      peaks[l] = std::max(peaks[l], std::abs(p[f]));
    }
    out.mean = Eigen::VectorXd::Zero(axes);
    largest = Eigen::VectorXd::Zero(axes);
    for (int l = 0; l < kLanes; ++l) {
      out.mean(l % axes) += lanes[l];
      largest(l % axes) = std::max(largest(l % axes), peaks[l]);
    }
    out.mean /= double(n);
  }
  out.scale.resize(axes);
  for (int a = 0; a < axes; ++a) {
    // 2^-1022 to 2^1022: the scale and its inverse are both finite normal numbers (2^1023's
    // inverse would be subnormal). An axis of zeros gets 1; one whose largest |y| is 2^1023 or
    // more is scaled to below 4, one of subnormals only to below 1.
    const int e = largest(a) > 0.0 ? std::clamp(std::ilogb(largest(a)), -1022, 1022) : 0;
    out.scale(a) = std::ldexp(1.0, e);
  }
  // Finite samples whose sum overflows (values near 1e308): the mean of the scaled samples.
  if (!out.mean.allFinite() && samples.allFinite()) {
    out.mean = (samples.array().colwise() / out.scale.array()).rowwise().mean().matrix();
    out.mean = out.mean.cwiseProduct(out.scale);
  }
  return out;
}

// S_0 = 0, S_{i+1} = S_i + (y_i / scale - mean / scale), Kahan-compensated per axis
// (independent chains, so the axes run side by side). The caller has checked that the means are
// finite, which they are only if every sample is (a NaN or infinity anywhere makes its axis' sum
// NaN or infinite). Scaled samples and means are below 4 in magnitude (see axis_levels), so the
// sums, at most 8 n, cannot overflow.
template <int A>
void build_cumsum(const Eigen::Ref<const Eigen::MatrixXd>& samples, const AxisLevels& levels,
                  double* S, int axes) {
  const int k = A > 0 ? A : axes;
  double sum[16] = {}, comp[16] = {}, mu[16] = {}, inv[16] = {};
  for (int a = 0; a < k; ++a) {
    inv[a] = 1.0 / levels.scale(a);
    mu[a] = levels.mean(a) * inv[a];
    S[a] = 0.0;
  }
  const auto n = int64_t(samples.cols());
  const double* base = samples.data();
  const int64_t stride = samples.outerStride();
  for (int64_t i = 0; i < n; ++i) {
    const double* col = base + i * stride;
    double* out = S + (i + 1) * k;
    for (int a = 0; a < k; ++a) {
      const double y = (col[a] * inv[a] - mu[a]) - comp[a];
      const double t = sum[a] + y;
      comp[a] = (t - sum[a]) - y;
      sum[a] = t;
      out[a] = t;
    }
  }
}

}  // namespace

std::vector<int64_t> log_spaced_factors(int64_t n, int points_per_decade, int64_t max_factor) {
  if (points_per_decade < 1) throw Error("Allan deviation: points per decade must be at least 1");
  if (max_factor <= 0) max_factor = n / 4;
  std::vector<int64_t> f;
  if (max_factor < 1) return f;
  const double decades = std::log10(double(max_factor));
  const int steps = int(std::floor(decades * points_per_decade + 1e-9));
  for (int i = 0; i <= steps; ++i) {
    const auto m = int64_t(std::llround(std::pow(10.0, double(i) / points_per_decade)));
    if (m >= 1 && m <= max_factor && (f.empty() || m > f.back())) f.push_back(m);
  }
  if (f.empty() || f.back() != max_factor) f.push_back(max_factor);
  return f;
}

int64_t default_shared_factor_limit(int axes) {
  return std::max<int64_t>(kSmallFactor, kSharedWindowBytes / (2 * int64_t(std::max(axes, 1)) *
                                                               int64_t(sizeof(double))));
}

double equivalent_dof(Deviation kind, int64_t n, int64_t m, int alpha) {
  assert(m >= 1 && n >= 1);
  if (alpha == 1 || alpha > 2) alpha = 2;
  if (alpha < -2) alpha = -2;
  const int64_t M = estimator_terms(kind, n, m);
  if (M < 1) return 0.0;
  const double c0 = term_covariance(kind, m, 0.0, alpha);
  auto f = [&](double l) {
    const double c = term_covariance(kind, m, l, alpha);
    return (1.0 - l / double(M)) * c * c;
  };
  double sum = 0.0;  // sum over l = 1 .. M-1 of f(l)
  const int span = kind == Deviation::kAllan ? 2 : 3;
  if (alpha == 2 && kind != Deviation::kModifiedAllan) {
    // Impulse covariance: only lags that are multiples of m correlate.
    for (int k = 1; k <= span && k * m < M; ++k) sum += f(double(k * m));
  } else {
    // Every lag up to 256, then a trapezoid rule with step max(1, m/64) up to 4 spans (c_l is
    // smooth between kinks at multiples of m), then log-spaced nodes for the decaying tail.
    const int64_t exact_end = std::min<int64_t>(M - 1, 256);
    for (int64_t l = 1; l <= exact_end; ++l) sum += f(double(l));
    int64_t l = exact_end;
    const int64_t mid_end = std::min<int64_t>(M - 1, std::max<int64_t>(exact_end, 4 * span * m));
    const int64_t step = std::max<int64_t>(1, m / 64);
    double prev = f(double(l));
    while (l < mid_end) {
      const int64_t next = std::min(mid_end, l + step);
      const double cur = f(double(next));
      // Sum of f over the integers in (l, next], exact when f is linear there.
      sum += 0.5 * (prev + cur) * double(next - l) + 0.5 * (cur - prev);
      prev = cur;
      l = next;
    }
    while (l < M - 1) {
      const int64_t next =
          std::min<int64_t>(M - 1, std::max<int64_t>(l + 1, int64_t(double(l) * 1.05)));
      const double cur = f(double(next));
      sum += 0.5 * (prev + cur) * double(next - l) + 0.5 * (cur - prev);
      prev = cur;
      l = next;
    }
  }
  const double denom = c0 * c0 + 2.0 * sum;
  if (!(denom > 0.0)) return 1.0;
  return std::max(1.0, double(M) * c0 * c0 / denom);
}

std::pair<double, double> deviation_interval(double dev, double nu, double confidence) {
  assert(confidence > 0.0 && confidence < 1.0 && nu > 0.0);
  const double tail = 0.5 * (1.0 - confidence);
  // dev times the factor, not the square root of nu dev^2 / q: dev^2 underflows for 1e-170.
  const double lo = dev * std::sqrt(nu / chi_square_quantile(1.0 - tail, nu));
  const double hi = dev * std::sqrt(nu / chi_square_quantile(tail, nu));
  return {lo, hi};
}

int alpha_from_avar_slope(double mu) {
  if (std::isnan(mu)) return 0;  // no slope to read (an overflowed curve): white FM
  if (mu <= -1.5) return 2;
  const double a = std::round(-mu - 1.0);
  return int(std::clamp(a, -2.0, 0.0));
}

namespace {

// The variance of each computed deviation, axes x factors.
using Variances = std::map<Deviation, Eigen::MatrixXd>;

// Checks the input against the options, measures the sampling and picks the averaging factors
// and their taus.
AllanResult grid_and_sampling(std::span<const TimeNs> t,
                              const Eigen::Ref<const Eigen::MatrixXd>& samples,
                              const AllanOptions& options) {
  const auto n = int64_t(samples.cols());
  const int axes = int(samples.rows());
  if (axes < 1 || axes > 16) throw Error("Allan deviation: between 1 and 16 axes are supported");
  if (!(options.confidence > 0.0 && options.confidence < 1.0)) {
    throw Error(fmt::format(
        "Allan deviation: the confidence of the intervals must be between 0 and 1, got {:g}",
        options.confidence));
  }
  if (int64_t(t.size()) != n) {
    throw Error("Allan deviation: " + std::to_string(t.size()) + " time stamps for " +
                std::to_string(n) + " samples");
  }
  if (n < 8)
    throw Error("Allan deviation: at least 8 samples are needed, got " + std::to_string(n));
  AllanResult r;
  r.sampling = analyze_sampling(t);
  if (r.sampling.min_period_s < 0) {
    // Found in review: two swapped stamps only set uniform = false (Python's t; files are
    // checked line by line when read).
    const auto back = std::adjacent_find(t.begin(), t.end(), std::greater<>());
    const auto i = back - t.begin();
    throw Error(
        fmt::format("Allan deviation: time stamp {} ({} ns) is after the next one ({} ns): "
                    "the times must not decrease",
                    i, *back, *(back + 1)));
  }
  if (!(r.sampling.duration > 0)) throw Error("Allan deviation: the time stamps span no time");
  // The mean period measured from the time stamps, never a nominal rate (seed-summary s. 3).
  // Where samples are missing (periods above 1.5 median ones), the mean of the other periods:
  // the samples are taken as consecutive, and the mean over the span made every tau too long
  // by the missing fraction (found in review: 2 % of samples dropped gave N 1 % high, 9 of its
  // sigmas; a gap over a quarter of the span 15 %).
  // Only where samples are missing (SamplingStats::samples_missing): stamps rounded to 1 ms at
  // 800 Hz have periods of 1 and 2 ms with none missing, and the mean of the 1 ms ones was
  // 20 % short (found in review of the first version).
  r.tau0_s = r.sampling.samples_missing() ? r.sampling.mean_period_between_gaps_s
                                          : r.sampling.mean_period_s;
  // The rates imukit takes everywhere (RateLimits), at the stamps' resolution.
  check_period(r.tau0_s, "Allan deviation: the time stamps' sample rate");
  r.uniform = r.sampling.is_uniform();
  r.factors = options.factors.empty()
                  ? log_spaced_factors(n, options.points_per_decade, options.max_factor)
                  : options.factors;
  for (int64_t m : r.factors) {
    if (m < 1 || 3 * m > n) {
      throw Error("Allan deviation: averaging factor " + std::to_string(m) +
                  " outside [1, n/3] for n = " + std::to_string(n));
    }
  }
  if (options.max_factor > 0 && options.factors.empty() && 3 * options.max_factor > n) {
    throw Error("Allan deviation: maximum averaging factor above n/3");
  }
  for (int64_t m : r.factors) r.tau_s.push_back(double(m) * r.tau0_s);
  return r;
}

// S: the cumulative sums of the mean-free samples over levels.scale, Kahan-compensated,
// axes x (n+1), sample-major.
std::unique_ptr<double[]> cumulative_sums(const Eigen::Ref<const Eigen::MatrixXd>& samples,
                                          const AxisLevels& levels) {
  const auto n = int64_t(samples.cols());
  const int axes = int(samples.rows());
  if (!levels.mean.allFinite()) throw Error("Allan deviation: the samples contain NaN or infinity");
  // Not value-initialised: every entry is written below, and zeroing 345 MB first (6 axes of
  // 7.2 M samples) would cost a full extra pass over memory.
  std::unique_ptr<double[]> S_storage(new double[size_t(n + 1) * size_t(axes)]);
  double* const S = S_storage.get();
  switch (axes) {
    case 1:
      build_cumsum<1>(samples, levels, S, axes);
      break;
    case 3:
      build_cumsum<3>(samples, levels, S, axes);
      break;
    case 6:
      build_cumsum<6>(samples, levels, S, axes);
      break;
    default:
      build_cumsum<0>(samples, levels, S, axes);
      break;
  }
  return S_storage;
}

// What the variance tasks read: S (see cumulative_sums) and its size.
struct Sums {
  const double* S;
  int64_t n;
  int axes;
};

constexpr int64_t kChunksPerGroup = 64;

// How the sums are split into work items: the small factors of ADEV and HDEV together, in fixed
// groups of chunks, and those of MDEV likewise; each larger factor alone.
struct WorkPlan {
  // shared: ADEV/HDEV factors of the shared pass (see kSharedWindowBytes); small: MDEV's factors
  // of its group pass (its sliding sum restarts at each group with an O(m) direct sum, so its
  // limit stays at kSmallFactor). Both hold indices into the factors.
  int64_t shared_limit = 0, small_limit = 0;
  std::vector<size_t> shared, small;
  std::vector<int> orders;  // 2: ADEV, 3: HDEV
  int64_t n_chunks = 0, groups = 0;
};

WorkPlan plan_work(const std::vector<int64_t>& factors, const AllanOptions& options, int axes,
                   int64_t n) {
  WorkPlan p;
  p.shared_limit = options.shared_factor_limit > 0 ? options.shared_factor_limit
                                                   : default_shared_factor_limit(axes);
  p.small_limit = std::min(kSmallFactor, p.shared_limit);
  for (size_t k = 0; k < factors.size(); ++k) {
    if (factors[k] <= p.shared_limit) p.shared.push_back(k);
    if (factors[k] <= p.small_limit) p.small.push_back(k);
  }
  if (options.allan) p.orders.push_back(2);
  if (options.hadamard) p.orders.push_back(3);
  p.n_chunks = (n + kChunk - 1) / kChunk;
  p.groups = (p.n_chunks + kChunksPerGroup - 1) / kChunksPerGroup;
  return p;
}

// The per-chunk sums of the grouped passes, each task writing its own slots.
struct Partials {
  // partial[order slot][chunk][shared index * axes + a]
  std::vector<std::vector<double>> partial;
  // modified[chunk][small index * axes + a]
  std::vector<double> modified;

  Partials(const WorkPlan& p, bool with_modified, int axes)
      : partial(p.orders.size(),
                std::vector<double>(size_t(p.n_chunks) * p.shared.size() * size_t(axes), 0.0)),
        modified(with_modified ? size_t(p.n_chunks) * p.small.size() * size_t(axes) : 0, 0.0) {}
};

using Tasks = std::vector<std::function<void()>>;

// Each factor above the group passes' limits alone, the largest (most expensive) first: MDEV's,
// then ADEV's and HDEV's strided sweeps.
void large_factor_tasks(Sums s, const std::vector<int64_t>& factors, const WorkPlan& plan,
                        const AllanOptions& options, Variances& variance, Tasks& tasks) {
  for (size_t k = factors.size(); k-- > 0;) {
    const int64_t m = factors[k];
    if (options.modified && m > plan.small_limit) {
      tasks.emplace_back([s, &variance, k, m] {
        double out[16];
        pick_modified(s.axes)(s.S, s.n, m, s.axes, out);
        const double md = double(m);
        const double scale = 1.0 / (2.0 * md * md * md * md * double(s.n + 2 - 3 * m));
        for (int a = 0; a < s.axes; ++a)
          variance.at(Deviation::kModifiedAllan)(a, Eigen::Index(k)) = out[a] * scale;
      });
    }
    for (size_t o = 0; o < plan.orders.size() && m > plan.shared_limit; ++o) {
      tasks.emplace_back([s, &plan, &variance, k, m, o] {
        double out[16];
        const int order = plan.orders[o];
        pick_strided(order, s.axes)(s.S, s.n, m, s.axes, out);
        const int64_t terms = s.n + 1 - order * m;
        const double scale =
            1.0 / ((order == 2 ? 2.0 : 6.0) * double(m) * double(m) * double(terms));
        const Deviation d = order == 2 ? Deviation::kAllan : Deviation::kHadamard;
        for (int a = 0; a < s.axes; ++a) variance.at(d)(a, Eigen::Index(k)) = out[a] * scale;
      });
    }
  }
}

// MDEV's small factors: per group, W of each factor summed directly at the group's first j,
// then slid chunk by chunk, every small factor on one chunk before the next.
void modified_group_tasks(Sums s, const std::vector<int64_t>& factors, const WorkPlan& plan,
                          Partials& partials, Tasks& tasks) {
  for (int64_t g = 0; g < plan.groups; ++g) {
    tasks.emplace_back([s, &factors, &plan, &partials, g] {
      const auto& small = plan.small;
      const int axes = s.axes;
      const int64_t n = s.n;
      const auto [start, run] = pick_modified_span(axes);
      std::vector<double> w(small.size() * size_t(axes)), wc(small.size() * size_t(axes));
      const int64_t g0 = g * kChunksPerGroup * kChunk;
      for (size_t q = 0; q < small.size(); ++q) {
        const int64_t m = factors[small[q]];
        if (g0 < n + 2 - 3 * m)
          start(s.S, m, axes, g0, &w[q * size_t(axes)], &wc[q * size_t(axes)]);
      }
      for (int64_t c = g * kChunksPerGroup; c < std::min(plan.n_chunks, (g + 1) * kChunksPerGroup);
           ++c) {
        const int64_t j0 = c * kChunk;
        for (size_t q = 0; q < small.size(); ++q) {
          const int64_t m = factors[small[q]];
          const int64_t terms = n + 2 - 3 * m;
          const int64_t j1 = std::min(j0 + kChunk, terms);
          if (j1 <= j0) continue;
          run(s.S, m, axes, j0, j1, terms, &w[q * size_t(axes)], &wc[q * size_t(axes)],
              &partials.modified[(size_t(c) * small.size() + q) * size_t(axes)]);
        }
      }
    });
  }
}

// ADEV's and HDEV's shared factors: per group of chunks, every shared factor on one chunk
// before the next (see kSharedWindowBytes).
void shared_group_tasks(Sums s, const std::vector<int64_t>& factors, const WorkPlan& plan,
                        Partials& partials, Tasks& tasks) {
  for (int64_t g = 0; g < plan.groups; ++g) {
    tasks.emplace_back([s, &factors, &plan, &partials, g] {
      const auto& shared = plan.shared;
      const auto& orders = plan.orders;
      const int axes = s.axes;
      const int64_t n = s.n;
      for (int64_t c = g * kChunksPerGroup; c < std::min(plan.n_chunks, (g + 1) * kChunksPerGroup);
           ++c) {
        const int64_t j0 = c * kChunk;
        for (size_t o = 0; o < orders.size(); ++o) {
          const ChunkFn fn = pick_chunk(orders[o], axes);
          // ADEV's factors two at a time (see chunk_pair_order2), while both have a full chunk.
          const bool pairs = orders[o] == 2 && lane_kernels_serve(axes);
          for (size_t q = 0; q < shared.size(); ++q) {
            const int64_t m = factors[shared[q]];
            const int64_t terms = n + 1 - orders[o] * m;
            const int64_t j1 = std::min(j0 + kChunk, terms);
            if (j1 <= j0) continue;
            double* const acc =
                &partials.partial[o][(size_t(c) * shared.size() + q) * size_t(axes)];
            if (pairs && q + 1 < shared.size()) {
              const int64_t mb = factors[shared[q + 1]];
              if (std::min(j0 + kChunk, n + 1 - 2 * mb) == j1) {
                chunk_pair_order2(s.S, m, mb, axes, j0, j1, acc, acc + axes);
                ++q;
                continue;
              }
            }
            fn(s.S, m, axes, j0, j1, acc);
          }
        }
      }
    });
  }
}

// Every work item of the pass, the most expensive first (threads take the next item from a
// counter). Each writes its own slots of `variance` or `partials`, which must outlive the tasks.
Tasks variance_tasks(Sums s, const std::vector<int64_t>& factors, const WorkPlan& plan,
                     const AllanOptions& options, Partials& partials, Variances& variance) {
  Tasks tasks;
  large_factor_tasks(s, factors, plan, options, variance, tasks);
  if (!plan.small.empty() && options.modified)
    modified_group_tasks(s, factors, plan, partials, tasks);
  if (!plan.shared.empty() && !plan.orders.empty())
    shared_group_tasks(s, factors, plan, partials, tasks);
  return tasks;
}

// The grouped passes' variances: the chunks' partial sums added in chunk order.
void add_partials(Sums s, const std::vector<int64_t>& factors, const WorkPlan& plan,
                  const Partials& partials, const AllanOptions& options, Variances& variance) {
  const auto& small = plan.small;
  const auto& shared = plan.shared;
  const int axes = s.axes;
  const int64_t n = s.n;
  const int64_t n_chunks = plan.n_chunks;
  if (options.modified) {
    for (size_t q = 0; q < small.size(); ++q) {
      const double md = double(factors[small[q]]);
      const double scale = 1.0 / (2.0 * md * md * md * md * double(n + 2 - 3 * factors[small[q]]));
      for (int a = 0; a < axes; ++a) {
        double total = 0.0;
        for (int64_t c = 0; c < n_chunks; ++c)
          total += partials.modified[(size_t(c) * small.size() + q) * size_t(axes) + size_t(a)];
        variance.at(Deviation::kModifiedAllan)(a, Eigen::Index(small[q])) = total * scale;
      }
    }
  }
  for (size_t o = 0; o < plan.orders.size(); ++o) {
    const int order = plan.orders[o];
    const Deviation d = order == 2 ? Deviation::kAllan : Deviation::kHadamard;
    for (size_t q = 0; q < shared.size(); ++q) {
      const int64_t m = factors[shared[q]];
      const int64_t terms = n + 1 - order * m;
      const double scale = 1.0 / ((order == 2 ? 2.0 : 6.0) * double(m) * double(m) * double(terms));
      for (int a = 0; a < axes; ++a) {
        double total = 0.0;
        for (int64_t c = 0; c < n_chunks; ++c)
          total += partials.partial[o][(size_t(c) * shared.size() + q) * size_t(axes) + size_t(a)];
        variance.at(d)(a, Eigen::Index(shared[q])) = total * scale;
      }
    }
  }
}

// Noise type per (axis, tau) from the local log-log slope of the variance, over neighbours
// within +-0.25 decade (or options.alpha everywhere when given).
Eigen::MatrixXi noise_types(const Eigen::MatrixXd& slope_source, const std::vector<double>& tau_s,
                            const AllanOptions& options) {
  const auto axes = slope_source.rows();
  const size_t grid = tau_s.size();
  Eigen::MatrixXi alpha(axes, Eigen::Index(grid));
  for (Eigen::Index a = 0; a < axes; ++a) {
    for (size_t k = 0; k < grid; ++k) {
      if (options.alpha) {
        alpha(a, Eigen::Index(k)) = *options.alpha;
        continue;
      }
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      int cnt = 0;
      const double lk = std::log10(tau_s[k]);
      for (size_t q = 0; q < grid; ++q) {
        const double lq = std::log10(tau_s[q]);
        const double v = slope_source(a, Eigen::Index(q));
        if (std::abs(lq - lk) <= 0.25 + 1e-12 && v > 0.0 && std::isfinite(v)) {
          const double y = std::log10(v);
          sx += lq, sy += y, sxx += lq * lq, sxy += lq * y;
          ++cnt;
        }
      }
      const double den = cnt * sxx - sx * sx;
      const double mu = (cnt >= 2 && den > 0) ? (cnt * sxy - sx * sy) / den : -1.0;
      // ADEV's slope of -2 covers both white and flicker PM, which are treated alike.
      alpha(a, Eigen::Index(k)) = alpha_from_avar_slope(mu);
    }
    // In an IMU, phase noise (quantisation) can dominate only the shortest taus: past the first
    // tau where it does not, a steep local slope is the scatter of a few long-tau estimates, and
    // taking it for white PM would claim thousands of degrees of freedom where there are a
    // dozen. Such points get white FM, the steepest frequency-noise type.
    if (!options.alpha) {
      bool phase_noise_prefix = true;
      for (size_t k = 0; k < grid; ++k) {
        int& al = alpha(a, Eigen::Index(k));
        if (al != 2) {
          phase_noise_prefix = false;
        } else if (!phase_noise_prefix) {
          al = 0;
        }
      }
    }
  }
  return alpha;
}

// The deviation curves of r (their terms, edf and confidence intervals) from the variances
// of the scaled samples (see AxisLevels): each axis' deviations times its scale.
void fill_curves(AllanResult& r, const std::vector<Deviation>& kinds, const Variances& variance,
                 const Eigen::VectorXd& scale, const Eigen::MatrixXi& alpha, int64_t n,
                 const AllanOptions& options) {
  const auto axes = alpha.rows();
  const size_t grid = r.factors.size();
  for (Deviation d : kinds) {
    DeviationCurve& c = d == Deviation::kAllan           ? r.allan
                        : d == Deviation::kModifiedAllan ? r.modified
                                                         : r.hadamard;
    c.computed = true;
    const Eigen::MatrixXd& v = variance.at(d);
    c.deviation = scale.asDiagonal() * v.cwiseMax(0.0).cwiseSqrt();
    c.lower.resize(axes, Eigen::Index(grid));
    c.upper.resize(axes, Eigen::Index(grid));
    c.edf.resize(axes, Eigen::Index(grid));
    c.alpha = alpha;
    for (size_t k = 0; k < grid; ++k) {
      c.terms.push_back(estimator_terms(d, n, r.factors[k]));
      std::map<int, double> edf_cache;
      for (Eigen::Index a = 0; a < axes; ++a) {
        const int al = alpha(a, Eigen::Index(k));
        auto it = edf_cache.find(al);
        if (it == edf_cache.end()) {
          it = edf_cache.emplace(al, equivalent_dof(d, n, r.factors[k], al)).first;
        }
        const double nu = it->second;
        const auto [lo, hi] =
            deviation_interval(c.deviation(a, Eigen::Index(k)), nu, options.confidence);
        c.edf(a, Eigen::Index(k)) = nu;
        c.lower(a, Eigen::Index(k)) = lo;
        c.upper(a, Eigen::Index(k)) = hi;
      }
    }
  }
}

// Finite samples whose deviations (each axis' scale times the root of a variance of order 1)
// or intervals are beyond the largest double: an error naming the axis and its sample furthest
// from the mean, not infinities in the result (found in review: samples alternating +-1.5e308
// gave an ADEV of inf with intervals of inf, a fit from the other points, Q = 1.2e306, and
// `characterize` failed writing the profile without naming its input).
void check_curves_finite(const AllanResult& r, const std::vector<Deviation>& kinds,
                         const Eigen::Ref<const Eigen::MatrixXd>& samples,
                         const AxisLevels& levels) {
  for (Eigen::Index a = 0; a < samples.rows(); ++a) {
    for (Deviation d : kinds) {
      const DeviationCurve& c = r.curve(d);
      for (Eigen::Index k = 0; k < c.deviation.cols(); ++k) {
        const bool deviation_finite = std::isfinite(c.deviation(a, k));
        if (deviation_finite && std::isfinite(c.lower(a, k)) && std::isfinite(c.upper(a, k)))
          continue;
        // Found among the scaled samples: y - mean itself may overflow.
        Eigen::Index sample = 0;
        const double inv = 1.0 / levels.scale(a);
        (samples.row(a).array() * inv - levels.mean(a) * inv).abs().maxCoeff(&sample);
        const char* name = d == Deviation::kAllan           ? "Allan deviation"
                           : d == Deviation::kModifiedAllan ? "modified Allan deviation"
                                                            : "Hadamard deviation";
        throw Error(fmt::format(
            "Allan deviation: axis {}: the {} at tau {:g} s{} is beyond the largest double "
            "({:g}): sample {} of axis {} is {:g}, too large for its differences",
            a, name, r.tau_s[static_cast<std::size_t>(k)],
            deviation_finite ? ", or its confidence interval," : "",
            std::numeric_limits<double>::max(), sample, a, samples(a, sample)));
      }
    }
  }
}

}  // namespace

AllanResult allan_deviation(std::span<const TimeNs> t,
                            const Eigen::Ref<const Eigen::MatrixXd>& samples,
                            const AllanOptions& options) {
  AllanResult r = grid_and_sampling(t, samples, options);
  const auto n = int64_t(samples.cols());
  const int axes = int(samples.rows());
  const AxisLevels levels = axis_levels(samples);
  const std::unique_ptr<double[]> S = cumulative_sums(samples, levels);
  const Sums sums{S.get(), n, axes};

  std::vector<Deviation> kinds;
  if (options.allan) kinds.push_back(Deviation::kAllan);
  if (options.modified) kinds.push_back(Deviation::kModifiedAllan);
  if (options.hadamard) kinds.push_back(Deviation::kHadamard);
  Variances variance;
  for (Deviation d : kinds)
    variance[d] = Eigen::MatrixXd::Zero(axes, Eigen::Index(r.factors.size()));

  const WorkPlan plan = plan_work(r.factors, options, axes, n);
  Partials partials(plan, options.modified, axes);
  const Tasks tasks = variance_tasks(sums, r.factors, plan, options, partials, variance);
  // Every task writes its own slots, so the result does not depend on the thread count; a task
  // that throws (bad_alloc) stops the rest and is rethrown here.
  parallel_for(tasks.size(), options.threads, [&](std::size_t i, unsigned) { tasks[i](); });
  add_partials(sums, r.factors, plan, partials, options, variance);
  // ADEV's slopes when computed.
  const Eigen::MatrixXd& slope_source =
      options.allan ? variance.at(Deviation::kAllan) : variance.at(kinds.front());
  const Eigen::MatrixXi alpha = noise_types(slope_source, r.tau_s, options);
  fill_curves(r, kinds, variance, levels.scale, alpha, n, options);
  check_curves_finite(r, kinds, samples, levels);
  return r;
}

}  // namespace imukit::hwmodel
