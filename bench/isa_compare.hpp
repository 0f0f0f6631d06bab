// Benchmarks of the multi-versioned kernels, once per instruction set (core/isa.hpp, issue 17).
//
// register_per_isa() registers a benchmark as NAME/isa:baseline, NAME/isa:avx2, NAME/isa:avx512
// (the variants this CPU supports), each run with its variant active. run_with_isa_ratios() runs
// the benchmarks and then prints, for every such benchmark, each variant's CPU time against the
// baseline variant's measured in the same run (the median when repeated). A vector variant
// slower than the baseline is the symptom of issue 17 (AVX code calling SSE code, which Intel
// cores pay for): a variant taking more than 1.5x the baseline's time is reported as a failure
// and the program exits non-zero, on whatever CPU runs it.
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "imukit/core/isa.hpp"

namespace imukit::bench {

// Registers fn once per supported instruction set; `configure` is applied to each (arguments,
// units, ...).
inline void register_per_isa(
    const std::string& name, std::function<void(benchmark::State&)> fn,
    const std::function<void(benchmark::internal::Benchmark*)>& configure = {}) {
  for (Isa isa : supported_isas()) {
    const std::string full = name + "/isa:" + std::string(to_string(isa));
    benchmark::internal::Benchmark* b =
        benchmark::RegisterBenchmark(full.c_str(), [fn, isa](benchmark::State& state) {
          const Isa saved = active_isa();
          set_active_isa(isa);
          fn(state);
          set_active_isa(saved);
        });
    if (configure) configure(b);
  }
}

// The console table, plus the per-variant CPU times of every "/isa:" benchmark, kept for the
// ratio table.
class IsaRatioReporter : public benchmark::ConsoleReporter {
 public:
  IsaRatioReporter() : benchmark::ConsoleReporter(OO_Tabular) {}

  void ReportRuns(const std::vector<Run>& reports) override {
    ConsoleReporter::ReportRuns(reports);
    for (const Run& r : reports) {
      if (r.error_occurred) continue;
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      const bool median = r.run_type == Run::RT_Aggregate;
      std::string name = r.benchmark_name();
      if (median) name.erase(name.size() - r.aggregate_name.size() - 1);  // "_median"
      const auto at = name.find("/isa:");
      if (at == std::string::npos) continue;
      const auto end = name.find('/', at + 1);
      const std::size_t len = end == std::string::npos ? std::string::npos : end - at - 5;
      const std::string isa = name.substr(at + 5, len);
      const std::string key =
          name.substr(0, at) + (end == std::string::npos ? "" : name.substr(end));
      // A median replaces the single repetitions seen before it. Variants stay in the order
      // they ran (baseline first).
      auto& variants = times_[key];
      auto slot = std::find_if(variants.begin(), variants.end(),
                               [&](const Variant& v) { return v.isa == isa; });
      if (slot == variants.end()) slot = variants.insert(variants.end(), Variant{isa, 0.0, false});
      if (median || !slot->median) *slot = {isa, r.GetAdjustedCPUTime(), median};
      units_[key] = r.time_unit;
    }
  }

  // Prints the ratio table; false if a variant took more than 1.5x the baseline's time.
  bool print_ratios() const {
    if (times_.empty()) return true;
    bool ok = true;
    std::printf(
        "\nInstruction-set variants against the baseline variant, same run (CPU time; speed-up = "
        "baseline time / variant time):\n");
    for (const auto& [key, variants] : times_) {
      const auto base = std::find_if(variants.begin(), variants.end(),
                                     [](const Variant& v) { return v.isa == "baseline"; });
      if (base == variants.end()) continue;
      std::printf("  %s\n", key.c_str());
      for (const Variant& v : variants) {
        const double speedup = base->cpu_time / v.cpu_time;
        const bool slow = speedup < 1.0 / 1.5;
        ok = ok && !slow;
        std::printf("    %-8s %12.4g %s  speed-up %.2fx%s\n", v.isa.c_str(), v.cpu_time,
                    benchmark::GetTimeUnitString(units_.at(key)), speedup,
                    slow ? "  SLOWER THAN THE BASELINE (issue 17?)" : "");
      }
    }
    return ok;
  }

 private:
  struct Variant {
    std::string isa;
    double cpu_time;
    bool median;
  };
  std::map<std::string, std::vector<Variant>> times_;
  std::map<std::string, benchmark::TimeUnit> units_;
};

// Initialize, run the selected benchmarks with the ratio table at the end. Returns the exit
// status: 1 for unrecognised arguments or a variant slower than 1.5x the baseline.
inline int run_with_isa_ratios(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  std::printf("kernels: %s variant by default (IMUKIT_ISA overrides); this CPU supports",
              std::string(to_string(active_isa())).c_str());
  for (Isa isa : supported_isas()) std::printf(" %s", std::string(to_string(isa)).c_str());
  std::printf("\n");
  IsaRatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return reporter.print_ratios() ? 0 : 1;
}

}  // namespace imukit::bench
