#include "imukit/hwmodel/allan.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/isa.hpp"
#include "imukit/core/rng.hpp"
#include "support/allan_reference.hpp"

namespace imukit::hwmodel {
namespace {

std::vector<TimeNs> uniform_times(int64_t n, double rate_hz) {
  std::vector<TimeNs> t(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) t[size_t(i)] = sample_time(1'000'000'000, i, rate_hz);
  return t;
}

using testing::naive_avar;
using testing::naive_hvar;

// Modified Allan variance, NIST SP 1065 eq. (15) written with frequency data:
// 1/(2 m^4 (n - 3m + 2)) sum_j [ sum_{i=j}^{j+m-1} sum_{k=i}^{i+m-1} (y_{k+m} - y_k) ]^2.
double naive_mvar(const std::vector<double>& y, int64_t m) {
  const auto n = int64_t(y.size());
  const int64_t terms = n - 3 * m + 2;
  double sum = 0;
  for (int64_t j = 0; j < terms; ++j) {
    double outer = 0;
    for (int64_t i = j; i < j + m; ++i) {
      for (int64_t k = i; k < i + m; ++k) outer += y[size_t(k + m)] - y[size_t(k)];
    }
    sum += outer * outer;
  }
  const double md = double(m);
  return sum / (2.0 * md * md * md * md * double(terms));
}

// Checks ADEV and HDEV (and MDEV if `modified`) of every axis of y against the textbook
// definitions, to 1e-12 relative.
void expect_textbook_values(const Eigen::MatrixXd& y, const std::vector<int64_t>& factors,
                            bool modified, int64_t shared_factor_limit = 0) {
  const auto n = int64_t(y.cols());
  AllanOptions opt;
  opt.factors = factors;
  opt.modified = modified;
  opt.shared_factor_limit = shared_factor_limit;
  opt.threads = 2;
  const AllanResult r = allan_deviation(uniform_times(n, 100.0), y, opt);
  ASSERT_TRUE(r.allan.computed && r.hadamard.computed && r.modified.computed == modified);
  for (Eigen::Index a = 0; a < y.rows(); ++a) {
    std::vector<double> ya(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i) ya[size_t(i)] = y(a, i);
    for (size_t k = 0; k < factors.size(); ++k) {
      const int64_t m = factors[k];
      const auto K = Eigen::Index(k);
      const double adev = std::sqrt(naive_avar(ya, m)), hdev = std::sqrt(naive_hvar(ya, m));
      EXPECT_NEAR(r.allan.deviation(a, K), adev, 1e-12 * adev)
          << y.rows() << " axes, axis " << a << " m " << m;
      EXPECT_NEAR(r.hadamard.deviation(a, K), hdev, 1e-12 * hdev)
          << y.rows() << " axes, axis " << a << " m " << m;
      if (modified) {
        const double mdev = std::sqrt(naive_mvar(ya, m));
        EXPECT_NEAR(r.modified.deviation(a, K), mdev, 1e-12 * mdev) << "axis " << a << " m " << m;
      }
    }
  }
}

TEST(AllanDeviation, EqualsTextbookDefinitionsOnSmallInputs) {
  const int64_t n = 61;
  Rng rng(11);
  Eigen::MatrixXd y(3, n);
  for (int64_t i = 0; i < n; ++i) {
    // A large offset and a drift on top of noise: mean removal and exact differences matter.
    y(0, i) = 1000.0 + rng.normal();
    y(1, i) = -3.0 + 0.05 * double(i) + 0.1 * rng.normal();
    y(2, i) = 1e-4 * rng.normal();
  }
  std::vector<int64_t> factors;
  for (int64_t m = 1; m <= n / 3; ++m) factors.push_back(m);
  expect_textbook_values(y, factors, true);
}

TEST(AllanDeviation, EqualsTextbookDefinitionsForLargeFactorsAndAxisCounts) {
  // Factors above 1024 take the strided sweep; 6 and 2 axes the vector lane kernels, 5 the
  // generic one.
  const int64_t n = 3400;
  Rng rng(12);
  Eigen::MatrixXd y(6, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 6; ++a) y(a, i) = double(a) - 2.0 + 1e-3 * double(i) + rng.normal();
  const std::vector<int64_t> factors = {1, 7, 1024, 1025, 1100};
  expect_textbook_values(y, factors, false);
  expect_textbook_values(y.topRows(2), factors, false);
  expect_textbook_values(y.topRows(5), factors, false);
}

TEST(AllanDeviation, EqualsTextbookDefinitionsWhicheverSweepTakesAFactor) {
  // Which factors share one pass over the cumulative sums and which sweep them alone is a tuning
  // choice (AllanOptions::shared_factor_limit; by default 65,536 for 6 axes, so the test above
  // no longer reaches the lone sweeps): each factor must give the textbook value either way, on
  // both sides of every limit, with the lane kernels (6, 2 axes) and the generic one (5).
  const int64_t n = 3400;
  Rng rng(14);
  Eigen::MatrixXd y(6, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 6; ++a) y(a, i) = 3.0 * double(a) - 7.0 + 2e-3 * double(i) + rng.normal();
  const std::vector<int64_t> factors = {1, 2, 7, 300, 1024, 1025, 1100};
  for (const int64_t limit : {1, 7, 1024, 1100}) {
    SCOPED_TRACE(::testing::Message() << "shared factor limit " << limit);
    expect_textbook_values(y, factors, false, limit);
    expect_textbook_values(y.topRows(2), factors, false, limit);
    expect_textbook_values(y.topRows(5), factors, false, limit);
  }
  // Either way, the numbers do not depend on the thread count.
  AllanOptions one;
  one.threads = 1;
  one.factors = factors;
  one.shared_factor_limit = 7;
  AllanOptions two = one;
  two.threads = 2;
  const AllanResult r1 = allan_deviation(uniform_times(n, 100.0), y, one);
  const AllanResult r2 = allan_deviation(uniform_times(n, 100.0), y, two);
  EXPECT_EQ(r1.allan.deviation, r2.allan.deviation);
  EXPECT_EQ(r1.hadamard.deviation, r2.hadamard.deviation);
  EXPECT_EQ(r1.modified.deviation, r2.modified.deviation);
  // MDEV's factors up to min(1024, limit) share its group pass, larger ones slide alone.
  const Eigen::MatrixXd head = y.leftCols(90);
  for (const int64_t limit : {1, 5, 0}) {
    SCOPED_TRACE(::testing::Message() << "shared factor limit " << limit);
    expect_textbook_values(head, {1, 2, 5, 6, 17, 30}, true, limit);
    expect_textbook_values(head.topRows(5), {1, 2, 5, 6, 17, 30}, true, limit);
  }
}

TEST(AllanDeviation, EqualsTextbookDefinitionsAcrossWorkGroups) {
  // 140,000 samples span two of the fixed groups of chunks the small factors are swept in (MDEV
  // restarts its sliding inner sum at each group's first term).
  const int64_t n = 140000;
  Rng rng(13);
  Eigen::MatrixXd y(6, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 6; ++a) y(a, i) = 0.5 * double(a) + rng.normal();
  expect_textbook_values(y, {1, 2, 5}, true);
}

TEST(AllanDeviation, ResultDoesNotDependOnThreadCountOrAxisGrouping) {
  const int64_t n = 5000;
  Rng rng(3);
  Eigen::MatrixXd y(6, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 6; ++a) y(a, i) = rng.normal();
  AllanOptions one;
  one.threads = 1;
  AllanOptions two;
  two.threads = 2;
  const auto t = uniform_times(n, 200.0);
  const AllanResult r1 = allan_deviation(t, y, one);
  const AllanResult r2 = allan_deviation(t, y, two);
  EXPECT_EQ(r1.allan.deviation, r2.allan.deviation);
  EXPECT_EQ(r1.modified.deviation, r2.modified.deviation);
  // A 5-axis input takes the generic kernel: same numbers to rounding.
  const AllanResult r5 = allan_deviation(t, y.topRows(5), one);
  EXPECT_TRUE(r5.allan.deviation.isApprox(r1.allan.deviation.topRows(5), 1e-13));
  EXPECT_TRUE(r5.hadamard.deviation.isApprox(r1.hadamard.deviation.topRows(5), 1e-13));
}

// The lane kernels run in baseline, AVX2 and AVX-512 variants (core/isa.hpp): the same numbers,
// bit for bit, for the small factors' shared pass and the large factors' strided sweeps.
TEST(AllanDeviation, EveryInstructionSetVariantGivesTheSameBits) {
  const int64_t n = 60000;
  Rng rng(8);
  Eigen::MatrixXd y(6, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 6; ++a) y(a, i) = 0.1 * double(a) + rng.normal();
  AllanOptions opt;
  opt.threads = 1;
  opt.shared_factor_limit = 64;  // factors above 64 take the strided sweep
  const auto t = uniform_times(n, 200.0);
  const Isa saved = active_isa();
  std::vector<AllanResult> results;
  for (const Isa isa : supported_isas()) {
    set_active_isa(isa);
    results.push_back(allan_deviation(t, y, opt));
  }
  set_active_isa(saved);
  ASSERT_GT(results.front().factors.back(), 64);
  for (std::size_t v = 1; v < results.size(); ++v) {
    EXPECT_EQ(results[v].allan.deviation, results[0].allan.deviation)
        << to_string(supported_isas()[v]);
    EXPECT_EQ(results[v].hadamard.deviation, results[0].hadamard.deviation);
    EXPECT_EQ(results[v].modified.deviation, results[0].modified.deviation);
  }
}

TEST(AllanDeviation, MatchesClosedFormForWhiteNoise) {
  // White rate noise of density N: per-sample sigma N sqrt(f), ADEV(tau) = N / sqrt(tau), and
  // HDEV equals ADEV for this noise.
  const double rate = 100.0, density = 0.004;
  const int64_t n = 400000;
  Rng rng(2024);
  Eigen::MatrixXd y(3, n);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) y(a, i) = density * std::sqrt(rate) * rng.normal();
  AllanOptions opt;
  opt.confidence = 0.95;
  opt.modified = false;
  const AllanResult r = allan_deviation(uniform_times(n, rate), y, opt);
  EXPECT_TRUE(r.uniform);
  EXPECT_NEAR(r.tau0_s, 0.01, 1e-12);
  ASSERT_GE(r.factors.size(), 45u);  // >= 10 per decade up to n/4 = 1e5
  int inside = 0, total = 0, white_fm = 0;
  for (int a = 0; a < 3; ++a) {
    for (size_t k = 0; k < r.factors.size(); ++k) {
      const auto K = Eigen::Index(k);
      const double truth = density / std::sqrt(r.tau_s[k]);
      for (const DeviationCurve* c : {&r.allan, &r.hadamard}) {
        inside += (c->lower(a, K) <= truth && truth <= c->upper(a, K));
        ++total;
        white_fm += (c->alpha(a, K) == 0);
      }
    }
    EXPECT_NEAR(r.allan.deviation(a, 0), density / std::sqrt(0.01), 0.01 * density / 0.1);
  }
  // 95 % intervals: nearly all contain the truth (neighbouring taus are correlated, so allow
  // some slack), and the noise is identified as white FM almost everywhere.
  EXPECT_GE(inside, int(0.88 * total)) << inside << " of " << total;
  EXPECT_GE(white_fm, int(0.9 * total));
}

TEST(AllanDeviation, LongTauScatterIsNotTakenForPhaseNoise) {
  // White FM only: the few-term estimates at the longest taus scatter, and a steep local slope
  // there once made the interval assume white PM (edf ~ 25000 where ~ 12 is right). Across many
  // seeds no point may be classified white PM, and no edf may exceed white FM's.
  const int64_t n = 20000;
  const auto t = uniform_times(n, 100.0);
  Eigen::MatrixXd y(4, n);
  AllanOptions opt;
  opt.modified = false;
  int white_pm = 0, too_many_dof = 0;
  for (uint64_t seed = 1; seed <= 25; ++seed) {
    Rng rng(seed);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int a = 0; a < 4; ++a) y(a, i) = rng.normal();
    const AllanResult r = allan_deviation(t, y, opt);
    for (int a = 0; a < 4; ++a) {
      for (size_t k = 0; k < r.factors.size(); ++k) {
        const auto K = Eigen::Index(k);
        white_pm += r.allan.alpha(a, K) == 2;
        const double white_fm_dof = equivalent_dof(Deviation::kAllan, n, r.factors[k], 0);
        too_many_dof += r.allan.edf(a, K) > white_fm_dof * (1 + 1e-12);
      }
    }
  }
  EXPECT_EQ(white_pm, 0);
  EXPECT_EQ(too_many_dof, 0);
}

// Fraction of Monte-Carlo runs whose interval contains the true deviation: the test of the
// equivalent degrees of freedom themselves.
double coverage(Deviation kind, int alpha, int64_t n, int64_t m, double truth_var, int runs,
                const std::function<void(Rng&, Eigen::MatrixXd&)>& gen) {
  AllanOptions opt;
  opt.factors = {m};
  opt.confidence = 0.9;
  opt.alpha = alpha;
  opt.threads = 1;
  opt.allan = kind == Deviation::kAllan;
  opt.hadamard = kind == Deviation::kHadamard;
  opt.modified = kind == Deviation::kModifiedAllan;
  const auto t = uniform_times(n, 1.0);
  int inside = 0;
  Eigen::MatrixXd y(4, n);
  Rng rng(77);
  for (int run = 0; run < runs; run += 4) {
    gen(rng, y);
    const AllanResult r = allan_deviation(t, y, opt);
    const DeviationCurve& c = r.curve(kind);
    for (int a = 0; a < 4; ++a) {
      inside += c.lower(a, 0) <= std::sqrt(truth_var) && std::sqrt(truth_var) <= c.upper(a, 0);
    }
  }
  return double(inside) / double(runs);
}

TEST(AllanDeviation, IntervalsHaveTheirCoverageForWhiteFrequencyNoise) {
  auto white = [](Rng& rng, Eigen::MatrixXd& y) {
    for (Eigen::Index i = 0; i < y.cols(); ++i)
      for (int a = 0; a < 4; ++a) y(a, i) = rng.normal();
  };
  // AVAR = HVAR = 1/m for unit white noise, exactly.
  for (int64_t m : {1, 20, 150}) {
    const double ca = coverage(Deviation::kAllan, 0, 1500, m, 1.0 / double(m), 800, white);
    const double ch = coverage(Deviation::kHadamard, 0, 1500, m, 1.0 / double(m), 800, white);
    EXPECT_NEAR(ca, 0.9, 0.035) << "ADEV m " << m;
    EXPECT_NEAR(ch, 0.9, 0.035) << "HDEV m " << m;
  }
}

TEST(AllanDeviation, IntervalsHaveTheirCoverageForRandomWalkFrequencyNoise) {
  auto walk = [](Rng& rng, Eigen::MatrixXd& y) {
    Eigen::Vector4d s = Eigen::Vector4d::Zero();
    for (Eigen::Index i = 0; i < y.cols(); ++i) {
      for (int a = 0; a < 4; ++a) s(a) += rng.normal();
      y.col(i) = s;
    }
  };
  // Discrete random walk with unit steps: AVAR(m) = (2 m^2 + 1) / (6 m).
  for (int64_t m : {10, 60}) {
    const double truth = (2.0 * double(m * m) + 1.0) / (6.0 * double(m));
    const double ca = coverage(Deviation::kAllan, -2, 1500, m, truth, 800, walk);
    EXPECT_NEAR(ca, 0.9, 0.04) << "ADEV m " << m;
  }
}

TEST(AllanDeviation, EquivalentDofAgreesWithSp1065SimpleFormulas) {
  // NIST SP 1065 Table 5 with N phase points (N = n + 1).
  const int64_t n = 10000;
  const double N = double(n + 1);
  for (int64_t m : {1, 10, 100, 1000}) {
    const double md = double(m);
    const double wfm = (3.0 * (N - 1.0) / (2.0 * md) - 2.0 * (N - 2.0) / N) * 4.0 * md * md /
                       (4.0 * md * md + 5.0);
    const double rwfm = (N - 2.0) / (md * (N - 3.0) * (N - 3.0)) *
                        ((N - 1.0) * (N - 1.0) - 3.0 * md * (N - 1.0) + 4.0 * md * md);
    const double wpm = (N + 1.0) * (N - 2.0 * md) / (2.0 * (N - md));
    EXPECT_NEAR(equivalent_dof(Deviation::kAllan, n, m, 0), wfm, 0.08 * wfm) << m;
    EXPECT_NEAR(equivalent_dof(Deviation::kAllan, n, m, -2), rwfm, 0.15 * rwfm) << m;
    EXPECT_NEAR(equivalent_dof(Deviation::kAllan, n, m, 2), wpm, 0.05 * wpm) << m;
  }
}

TEST(AllanDeviation, UsesMeasuredMeanPeriodAndReportsJitter) {
  // Periods alternating 0.10 s and 0.11 s (like the hfi_static log): nominal 10 Hz, mean 0.105 s.
  const int64_t n = 1001;
  std::vector<TimeNs> t(static_cast<size_t>(n));
  for (int64_t i = 1; i < n; ++i)
    t[size_t(i)] = t[size_t(i - 1)] + (i % 2 ? 100'000'000 : 110'000'000);
  Eigen::MatrixXd y = Eigen::MatrixXd::Zero(1, n);
  Rng rng(5);
  for (int64_t i = 0; i < n; ++i) y(0, i) = rng.normal();
  const AllanResult r = allan_deviation(t, y);
  EXPECT_FALSE(r.uniform);
  EXPECT_NEAR(r.tau0_s, 0.105, 1e-12);
  EXPECT_NEAR(r.tau_s.back(), 0.105 * double(r.factors.back()), 1e-12);
}

// Found in review: with samples missing tau0 was the mean period over the whole span, so every
// tau was too long by the missing fraction: 2 % of samples dropped gave N 1 % high (9 of its
// sigmas), a gap over a quarter of the span 15 %. tau0 is now the mean period between gaps.
TEST(AllanDeviation, MissingSamplesLeaveTau0AtTheSamplingPeriod) {
  const double N = 1e-3, rate = 100.0;
  Rng rng(12);
  std::vector<TimeNs> t;
  std::vector<double> v;
  for (int64_t i = 0; i < 200000; ++i) {
    const bool dropped = rng.uniform() < 0.02 || (i >= 100000 && i < 150000);  // and a gap
    if (!dropped)
      t.push_back(sample_time(0, i, rate)), v.push_back(N * std::sqrt(rate) * rng.normal());
  }
  const Eigen::MatrixXd y = Eigen::Map<const Eigen::MatrixXd>(v.data(), 1, Eigen::Index(v.size()));
  AllanOptions opt;
  opt.modified = false;
  opt.hadamard = false;
  const AllanResult r = allan_deviation(t, y, opt);
  EXPECT_GT(r.sampling.gaps, 1900u);
  EXPECT_NEAR(r.tau0_s, 0.01, 1e-12);  // every period between gaps is exactly 10 ms
  // White noise: ADEV(tau0) = N / sqrt(tau0), within 1 % (1.4e5 samples, 0.3 % sigma).
  EXPECT_NEAR(r.allan.deviation(0, 0) * std::sqrt(r.tau0_s) / N, 1.0, 0.01);
}

// Found in review of the fix above: long periods balanced by short ones are not missing
// samples. Stamps of an 800 Hz stream rounded down to 1 ms (periods 1 and 2 ms) gave tau0 1 ms
// and N 11 % low; at 2500 Hz (periods 0 and 1 ms) tau0 0; 2 ms of jitter on 100 Hz 2.4 % low.
TEST(AllanDeviation, RoundedOrJitteredStampsKeepTheMeanPeriod) {
  Rng rng(13);
  for (const double rate : {800.0, 2500.0}) {
    std::vector<TimeNs> t;
    for (int64_t i = 0; i < 200000; ++i)
      t.push_back(TimeNs(std::floor(double(i) / rate * 1e3)) * 1'000'000);
    const Eigen::MatrixXd y = Eigen::MatrixXd::NullaryExpr(1, 200000, [&] { return rng.normal(); });
    const AllanResult r = allan_deviation(t, y);
    EXPECT_FALSE(r.sampling.samples_missing()) << rate;
    // The mean period, within the last stamp's rounding (1 ms over the 80-250 s span).
    EXPECT_NEAR(r.tau0_s, 1.0 / rate, 1e-5 / rate) << rate;
  }
  std::vector<TimeNs> t;
  for (int64_t i = 0; i < 200000; ++i)
    t.push_back(i * 10'000'000 + TimeNs(std::llround(2e6 * rng.normal())));
  std::sort(t.begin(), t.end());
  const Eigen::MatrixXd y = Eigen::MatrixXd::NullaryExpr(1, 200000, [&] { return rng.normal(); });
  const AllanResult r = allan_deviation(t, y);
  EXPECT_GT(r.sampling.gaps, 0u);  // periods above 15 ms, yet none missing
  EXPECT_FALSE(r.sampling.samples_missing());
  EXPECT_NEAR(r.tau0_s, 0.01, 1e-6);
}

TEST(AllanDeviation, LogGridHasRequestedDensity) {
  const auto f = log_spaced_factors(7'200'000, 10);
  EXPECT_EQ(f.front(), 1);
  EXPECT_EQ(f.back(), 1'800'000);
  // Every decade above m = 10 holds 10 distinct factors.
  int in_decade = 0;
  for (int64_t m : f) in_decade += (m >= 1000 && m < 10000);
  EXPECT_EQ(in_decade, 10);
  for (size_t i = 1; i < f.size(); ++i) EXPECT_GT(f[i], f[i - 1]);
}

TEST(AllanDeviation, RejectsNonFiniteSamplesAnywhere) {
  // Checked through the axis means (a NaN or infinity anywhere makes its axis' sum non-finite),
  // not sample by sample.
  const auto t = uniform_times(200, 10.0);
  for (const int axes : {1, 5, 6}) {
    for (const double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL}) {
      for (const Eigen::Index at : {Eigen::Index(0), Eigen::Index(117), Eigen::Index(199)}) {
        Eigen::MatrixXd y = Eigen::MatrixXd::Ones(axes, 200);
        y(axes - 1, at) = bad;
        EXPECT_THROW(allan_deviation(t, y), Error) << axes << " axes, " << bad << " at " << at;
      }
    }
  }
}

// The deviations of a record scaled by s are s times the record's (found in review: white
// noise of 1e-170 came back all 0, its squares underflowed, and the fit found "fewer than 2
// usable points"; one value of 1e200, or an axis of +-1e300, squared to infinity, and 1e307s
// overflowed the cumulative sums). Every sample is divided by a power of two near the largest
// before anything is squared: a power-of-two scale gives the same bits, any other one the same
// deviations to rounding. The noise type of a NaN slope stays defined (it was undefined
// behaviour in the conversion to an int, caught by UBSan in the bad-input sweep).
TEST(AllanDeviation, DeviationsScaleWithTheSamplesFromTinyToHuge) {
  EXPECT_EQ(alpha_from_avar_slope(std::nan("")), 0);
  const auto t = uniform_times(300, 100.0);
  Eigen::MatrixXd unit(4, 300);
  Rng rng(5);
  for (Eigen::Index i = 0; i < 300; ++i) {
    unit(0, i) = 0.01 * rng.normal();
    unit(1, i) = i % 2 ? 1.0 : -1.0;
    unit(2, i) = i == 100 ? 1.0 : 0.0;  // one value, the rest 0
    unit(3, i) = i < 150 ? 1.0 : -1.0;  // a step: its sums reach 150 times the value
  }
  const AllanResult r1 = allan_deviation(t, unit);
  for (const double s : {1e-170, 1e-300, 1e200, 1e300, 1e307}) {
    const AllanResult rs = allan_deviation(t, unit * s);
    for (const Deviation d : {Deviation::kAllan, Deviation::kModifiedAllan, Deviation::kHadamard}) {
      const DeviationCurve &c1 = r1.curve(d), &cs = rs.curve(d);
      ASSERT_TRUE(cs.deviation.allFinite()) << s;
      // Relative to each axis' largest: +-1's HDEV is 0 at even factors, 3e-17 times 1e-170.
      const auto off = [&](const Eigen::MatrixXd& scaled, const Eigen::MatrixXd& one) {
        return ((scaled / s - one).array().abs().colwise() / one.rowwise().maxCoeff().array())
            .maxCoeff();
      };
      EXPECT_LT(off(cs.deviation, c1.deviation), 1e-12) << s << " " << int(d);
      EXPECT_LT(off(cs.upper, c1.upper), 1e-12) << s << " " << int(d);
      EXPECT_EQ(cs.alpha, c1.alpha) << s;
    }
  }
  // +-1: ADEV(tau0) = sqrt(2) exactly as the definition gives it.
  EXPECT_NEAR(allan_deviation(t, unit * 1e300).allan.deviation(1, 0), std::sqrt(2.0) * 1e300,
              1e-12 * 1e300);
  for (const int k : {-900, -600, 600, 900}) {
    const double s = std::ldexp(1.0, k);
    const AllanResult rs = allan_deviation(t, unit * s);
    EXPECT_EQ(rs.allan.deviation, r1.allan.deviation * s) << k;
    EXPECT_EQ(rs.modified.lower, r1.modified.lower * s) << k;
  }
}

// Finite samples whose deviations or intervals are beyond the largest double are an error
// naming the axis and its sample furthest from the mean (found in review: with the scaling above
// the overflow check had gone, and +-1.5e308 gave an ADEV of inf with intervals of inf, a fit of
// Q = 1.2e306 from the other points, and `characterize` failed only writing the profile).
TEST(AllanDeviation, DeviationsBeyondTheLargestDoubleAreAnErrorNamingTheSample) {
  const auto t = uniform_times(300, 100.0);
  const auto message = [&](const Eigen::MatrixXd& y) {
    try {
      allan_deviation(t, y);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  Eigen::MatrixXd y(6, 300);
  for (Eigen::Index i = 0; i < 300; ++i) {
    for (Eigen::Index a = 0; a < 6; ++a) y(a, i) = 0.01 * double(a + 1) * (i % 3 == 0 ? 1 : -1);
  }
  EXPECT_EQ(message(y), "");
  // Axis 4 alternates +-1.5e308: ADEV(tau0) = sqrt(2) 1.5e308. Sample 0 is the first largest.
  for (Eigen::Index i = 0; i < 300; ++i) y(4, i) = i % 2 ? -1.5e308 : 1.5e308;
  EXPECT_EQ(message(y),
            "Allan deviation: axis 4: the Allan deviation at tau 0.01 s is beyond the largest "
            "double (1.79769e+308): sample 0 of axis 4 is 1.5e+308, too large for its "
            "differences");
  // One axis alone, and the sample furthest from the mean named: +-1.7e308 after a first 1e308
  // has a mean of -2.3e305, so the first +1.7e308 (sample 2), not the first -1.7e308.
  Eigen::MatrixXd one(1, 300);
  for (Eigen::Index i = 0; i < 300; ++i) one(0, i) = i % 2 ? -1.7e308 : 1.7e308;
  one(0, 0) = 1e308;
  EXPECT_EQ(message(one),
            "Allan deviation: axis 0: the Allan deviation at tau 0.01 s is beyond the largest "
            "double (1.79769e+308): sample 2 of axis 0 is 1.7e+308, too large for its "
            "differences");
  // A finite ADEV of 1.77e308 whose interval's upper bound is not.
  for (Eigen::Index i = 0; i < 300; ++i) one(0, i) = i % 2 ? -1.25e308 : 1.25e308;
  EXPECT_EQ(message(one),
            "Allan deviation: axis 0: the Allan deviation at tau 0.01 s, or its confidence "
            "interval, is beyond the largest double (1.79769e+308): sample 0 of axis 0 is "
            "1.25e+308, too large for its differences");
  // Just below: every number finite.
  for (Eigen::Index i = 0; i < 300; ++i) one(0, i) = i % 2 ? -1e308 : 1e308;
  AllanOptions adev_only;
  adev_only.modified = adev_only.hadamard = false;
  const AllanResult r = allan_deviation(t, one, adev_only);
  EXPECT_TRUE(r.allan.deviation.allFinite() && r.allan.upper.allFinite());
  EXPECT_NEAR(r.allan.deviation(0, 0), std::sqrt(2.0) * 1e308, 1e-12 * 1e308);
}

// A record whose samples are all equal has deviations of exactly 0 (characterize calls such an
// axis constant) at any magnitude, down to the smallest subnormal: the scaling of the tiny and
// huge ones above makes no noise of its own.
TEST(AllanDeviation, ARecordOfEqualSamplesHasZeroDeviationsAtAnyMagnitude) {
  const auto t = uniform_times(1000, 10.0);
  for (const double c : {0.0, 0.1, 9.80665, -1e-170, 1e300, -1.7e308, 4.9e-324}) {
    const AllanResult r = allan_deviation(t, Eigen::MatrixXd::Constant(3, 1000, c));
    EXPECT_TRUE(r.allan.deviation.isZero(0.0)) << c;
    EXPECT_TRUE(r.modified.deviation.isZero(0.0)) << c;
    EXPECT_TRUE(r.hadamard.deviation.isZero(0.0)) << c;
  }
}

// Rates are limited to [1/3600, 1e6] Hz everywhere (RateLimits): the time stamps' mean period,
// to the nanosecond, gives the rate (found in review: only Python's rate_hz was unchecked, and
// overflowed building its times; here the bound is the same).
TEST(AllanDeviation, TheTimeStampsRateMustBeWithinTheRateLimits) {
  const Eigen::MatrixXd y = Eigen::MatrixXd::Random(1, 100);
  std::vector<TimeNs> t(100);
  const auto message = [&](TimeNs period_ns) {
    for (std::size_t i = 0; i < t.size(); ++i) t[i] = TimeNs(i) * period_ns;
    try {
      allan_deviation(t, y);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message(1000), "");               // 1 MHz
  EXPECT_EQ(message(3'600'000'000'000), "");  // one an hour
  EXPECT_EQ(message(999),
            "Allan deviation: the time stamps' sample rate 1.001e+06 Hz is outside [1/3600 (one "
            "an hour), 1e6] Hz");
  EXPECT_EQ(message(3'600'000'000'001),
            "Allan deviation: the time stamps' sample rate 0.000277778 Hz is outside [1/3600 (one "
            "an hour), 1e6] Hz");
  EXPECT_EQ(message(1),
            "Allan deviation: the time stamps' sample rate 1e+09 Hz is outside [1/3600 (one an "
            "hour), 1e6] Hz");
}

TEST(AllanDeviation, RejectsBadInput) {
  Eigen::MatrixXd y = Eigen::MatrixXd::Ones(1, 100);
  const auto t = uniform_times(100, 10.0);
  {
    auto swapped = t;
    std::swap(swapped[40], swapped[41]);
    try {
      allan_deviation(swapped, y);
      ADD_FAILURE() << "swapped time stamps were accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(
                    "time stamp 40 (5100000000 ns) is after the next one (5000000000 ns)"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(allan_deviation(std::span(t).first(5), y.leftCols(5)), Error);
  y(0, 50) = std::nan("");
  EXPECT_THROW(allan_deviation(t, y), Error);
  AllanOptions opt;
  opt.factors = {40};
  EXPECT_THROW(allan_deviation(t, Eigen::MatrixXd::Ones(1, 100), opt), Error);
  const std::vector<TimeNs> same(100, 7);
  EXPECT_THROW(allan_deviation(same, Eigen::MatrixXd::Ones(1, 100)), Error);
  // A confidence outside (0, 1) is an error, not an assertion deep in the interval code.
  for (const double c : {0.0, 1.0, 1.5, std::nan("")}) {
    AllanOptions o;
    o.confidence = c;
    EXPECT_THROW(allan_deviation(t, Eigen::MatrixXd::Ones(1, 100), o), Error) << c;
  }
}

}  // namespace
}  // namespace imukit::hwmodel
