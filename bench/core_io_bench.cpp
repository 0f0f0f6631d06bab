// Text I/O throughput: EuRoC CSV and column-mapped text parsing in MB/s, next to two baselines
// measured in the same run: scanning for newlines only (the memory floor) and a plain
// std::strtod loop over the same bytes (what a hand-written reader typically does).
#include <benchmark/benchmark.h>

#include <fmt/format.h>
#include <cstdlib>
#include <cstring>
#include <string>

#include "imukit/core/column_text.hpp"
#include "imukit/core/euroc_csv.hpp"

namespace {

// 200,000 rows of a 200 Hz stream with realistic magnitudes (about 29 MB, 145 bytes a row).
const std::string& euroc_text() {
  static const std::string text = [] {
    std::string s(imukit::kEurocHeader);
    s += '\n';
    uint64_t x = 88172645463325252ull;  // xorshift: cheap, deterministic values
    auto next = [&x] {
      x ^= x << 13;
      x ^= x >> 7;
      x ^= x << 17;
      return static_cast<double>(x >> 11) * 0x1.0p-53 - 0.5;
    };
    for (int i = 0; i < 200000; ++i) {
      s += fmt::format("{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n",
                       1403636579758555392 + int64_t{5000000} * i, 0.1 * next(), 0.1 * next(),
                       0.1 * next(), next(), next(), 9.81 + next());
    }
    return s;
  }();
  return text;
}

void BM_NewlineScanFloor(benchmark::State& state) {
  const std::string& text = euroc_text();
  for (auto _ : state) {
    std::size_t lines = 0;
    for (const char* p = text.data();
         (p = static_cast<const char*>(std::memchr(p, '\n', text.data() + text.size() - p))); ++p) {
      ++lines;
    }
    benchmark::DoNotOptimize(lines);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_NewlineScanFloor)->Unit(benchmark::kMillisecond);

void BM_StrtodBaseline(benchmark::State& state) {
  const std::string& text = euroc_text();
  const char* body = text.data() + text.find('\n') + 1;
  for (auto _ : state) {
    double sum = 0.0;
    const char* p = body;
    char* end = nullptr;
    while (*p) {
      sum += std::strtod(p, &end);
      p = end;
      if (*p == ',' || *p == '\n') ++p;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_StrtodBaseline)->Unit(benchmark::kMillisecond);

void BM_ParseEurocCsv(benchmark::State& state) {
  const std::string& text = euroc_text();
  for (auto _ : state) {
    imukit::ImuSeries s = imukit::parse_euroc_csv(text, "bench.csv");
    benchmark::DoNotOptimize(s.accel.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
  state.counters["rows/s"] = benchmark::Counter(200000.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ParseEurocCsv)->Unit(benchmark::kMillisecond);

void BM_ParseColumnTextSkippingColumns(benchmark::State& state) {
  const std::string& text = euroc_text();
  const auto spec = imukit::ColumnSpec::parse("t,_3,ax,ay,az", {}, imukit::TimeUnit::ns);
  for (auto _ : state) {
    imukit::ColumnTable t = imukit::parse_column_text(text, "bench.csv", spec);
    benchmark::DoNotOptimize(t.rows);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ParseColumnTextSkippingColumns)->Unit(benchmark::kMillisecond);

void BM_FormatEurocCsv(benchmark::State& state) {
  const imukit::ImuSeries s = imukit::parse_euroc_csv(euroc_text(), "bench.csv");
  std::FILE* sink = std::fopen("/dev/null", "wb");
  for (auto _ : state) imukit::write_euroc_csv(sink, "/dev/null", s.view());
  std::fclose(sink);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * euroc_text().size()));
}
BENCHMARK(BM_FormatEurocCsv)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
