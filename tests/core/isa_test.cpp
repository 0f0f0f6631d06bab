#include "imukit/core/isa.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "imukit/core/error.hpp"

namespace imukit {
namespace {

// Restores the variant that was active when the test began.
class IsaTest : public ::testing::Test {
 protected:
  void TearDown() override { set_active_isa(saved_); }
  Isa saved_ = active_isa();
};

// A kernel with a loop the compiler vectorises differently in each variant: the lanes of a
// sum of squares, each lane its own chain, so every variant adds in the same order.
[[gnu::always_inline]] inline double lane_sum_kernel(const double* x, std::size_t n) {
  double lanes[8] = {};
  for (std::size_t i = 0; i + 8 <= n; i += 8)
    for (std::size_t l = 0; l < 8; ++l) lanes[l] += x[i + l] * x[i + l] + 0.5 * x[i + l];
  double s = 0.0;
  for (double v : lanes) s += v;
  return s;
}
IMUKIT_ISA_VARIANTS(double, lane_sum, lane_sum_kernel, (const double* x, std::size_t n), (x, n))

TEST_F(IsaTest, NamesRoundTripAndUnknownNamesAreErrors) {
  for (Isa isa : {Isa::baseline, Isa::avx2, Isa::avx512}) EXPECT_EQ(parse_isa(to_string(isa)), isa);
  EXPECT_EQ(to_string(Isa::avx512), "avx512");
  try {
    parse_isa("avx9");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'avx9'"), std::string::npos) << e.what();
  }
}

TEST_F(IsaTest, BaselineIsAlwaysSupportedAndTheDefaultIsTheBest) {
  const std::vector<Isa> all = supported_isas();
  ASSERT_FALSE(all.empty());
  EXPECT_EQ(all.front(), Isa::baseline);
  EXPECT_TRUE(isa_supported(Isa::baseline));
  for (Isa isa : {Isa::baseline, Isa::avx2, Isa::avx512}) {
    const bool listed = std::find(all.begin(), all.end(), isa) != all.end();
    EXPECT_EQ(listed, isa_supported(isa)) << to_string(isa);
  }
  // Unless IMUKIT_ISA chose otherwise, the kernels run the best variant the CPU has.
  const char* env = std::getenv("IMUKIT_ISA");
  if (env == nullptr || *env == '\0') {
    EXPECT_EQ(saved_, all.back());
  }
}

TEST_F(IsaTest, EveryVariantComputesTheSameBits) {
  std::vector<double> x(1000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 0.001 * static_cast<double>(i) + 0.5;
  double expected = 0.0;  // the same sum written out in order, lane by lane
  {
    double lanes[8] = {};
    for (std::size_t i = 0; i < x.size(); ++i) lanes[i % 8] += x[i] * x[i] + 0.5 * x[i];
    for (double v : lanes) expected += v;
  }
  for (Isa isa : supported_isas()) {
    set_active_isa(isa);
    EXPECT_EQ(active_isa(), isa);
    EXPECT_EQ(lane_sum(x.data(), x.size()), expected) << to_string(isa);
  }
}

TEST_F(IsaTest, UnsupportedVariantsCannotBeChosen) {
  for (Isa isa : {Isa::avx2, Isa::avx512}) {
    if (isa_supported(isa)) continue;
    EXPECT_THROW(set_active_isa(isa), Error) << to_string(isa);
  }
}

// IMUKIT_ISA is read once, at the first kernel call of a process: each case runs in a fresh
// process (threadsafe death tests re-run the test binary).
TEST(IsaEnvironment, ChoosesTheVariantOrFailsClearly) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        setenv("IMUKIT_ISA", "baseline", 1);
        std::exit(active_isa() == Isa::baseline ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(
      {
        setenv("IMUKIT_ISA", "sse9", 1);
        try {
          active_isa();
        } catch (const Error& e) {
          std::fprintf(stderr, "%s\n", e.what());
          std::exit(3);
        }
        std::exit(0);
      },
      ::testing::ExitedWithCode(3), "IMUKIT_ISA: unknown instruction set 'sse9'");
  if (!isa_supported(Isa::avx512)) {
    EXPECT_EXIT(
        {
          setenv("IMUKIT_ISA", "avx512", 1);
          try {
            active_isa();
          } catch (const Error& e) {
            std::fprintf(stderr, "%s\n", e.what());
            std::exit(3);
          }
          std::exit(0);
        },
        ::testing::ExitedWithCode(3), "cannot run the avx512 kernels");
  }
}

}  // namespace
}  // namespace imukit
