// Overlapping Allan and Hadamard variances straight from their textbook definitions, the slow
// way: the reference the fast implementations (hwmodel/allan.cpp) and the generated noise
// (core/hardware_model.cpp) are tested against. Header-only.
#pragma once

#include <cstdint>
#include <vector>

namespace imukit::testing {

// Mean of the m samples starting at k, for every k, each summed on its own (O(n m)): no
// running sums whose rounding the fast code might share.
inline std::vector<double> window_means(const std::vector<double>& y, int64_t m) {
  const auto n = int64_t(y.size());
  std::vector<double> mean(size_t(n - m + 1));
  for (int64_t k = 0; k + m <= n; ++k) {
    double s = 0.0;
    for (int64_t i = k; i < k + m; ++i) s += y[size_t(i)];
    mean[size_t(k)] = s / double(m);
  }
  return mean;
}

// The mean over k of (sum_i w_i avg_{k + i m})^2, over the sum of the squared weights w_i:
// Allan with weights (-1, 1) (normalised by 2), Hadamard with (1, -2, 1) (by 6).
inline double naive_difference_var(const std::vector<double>& y, int64_t m,
                                   const std::vector<double>& weights) {
  const std::vector<double> avg = window_means(y, m);
  double norm = 0.0;
  for (double w : weights) norm += w * w;
  double sum = 0.0;
  const int64_t terms = int64_t(y.size()) - int64_t(weights.size()) * m + 1;
  for (int64_t k = 0; k < terms; ++k) {
    double d = 0.0;
    for (size_t i = 0; i < weights.size(); ++i) d += weights[i] * avg[size_t(k + int64_t(i) * m)];
    sum += d * d;
  }
  return sum / (norm * double(terms));
}

inline double naive_avar(const std::vector<double>& y, int64_t m) {
  return naive_difference_var(y, m, {-1.0, 1.0});
}
inline double naive_hvar(const std::vector<double>& y, int64_t m) {
  return naive_difference_var(y, m, {1.0, -2.0, 1.0});
}

}  // namespace imukit::testing
