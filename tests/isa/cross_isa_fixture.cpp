// The mistake tests/isa/check_isa_calls.py must catch, made on purpose: an AVX2 function that
// calls a function compiled for the baseline (legacy SSE encodings) which is not inlined into it,
// as an out-of-line Eigen helper or a lambda was in issue 17. The checker's own test runs it on
// this program and expects exactly this call to be reported.
#include <cstdio>
#include <cstdlib>

namespace {

// Baseline code (SSE2 mulsd/addsd), kept out of line.
[[gnu::noinline]] double baseline_sum_of_squares(const double* x, int n) {
  double s = 0.0;
  for (int i = 0; i < n; ++i) s += x[i] * x[i];
  return s;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2")))
#endif
double
avx2_caller_of_baseline_code(double* x, int n) {
  for (int i = 0; i < n; ++i) x[i] = 0.5 * x[i] + 1.0;  // VEX-encoded vector code
  return baseline_sum_of_squares(x, n);
}

}  // namespace

int main(int argc, char**) {
  double x[64];
  for (int i = 0; i < 64; ++i) x[i] = i + argc;
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  if (!__builtin_cpu_supports("avx2")) return 0;
#endif
  std::printf("%g\n", avx2_caller_of_baseline_code(x, 64));
  return EXIT_SUCCESS;
}
