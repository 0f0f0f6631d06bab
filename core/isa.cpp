#include "imukit/core/isa.hpp"

#include <atomic>
#include <cstdlib>
#include <string>

#include "imukit/core/error.hpp"

namespace imukit {
namespace {

constexpr Isa kIsas[] = {Isa::baseline, Isa::avx2, Isa::avx512};

bool cpu_supports(Isa isa) {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  // libgcc / compiler-rt check both the CPUID bits and that the OS saves the registers (XCR0).
  __builtin_cpu_init();
  switch (isa) {
    case Isa::baseline:
      return true;
    case Isa::avx2:
      return __builtin_cpu_supports("avx2");
    case Isa::avx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl");
  }
  return false;
#else
  return isa == Isa::baseline;  // the kernels have only their baseline variant here
#endif
}

std::string supported_list() {
  std::string s;
  for (Isa isa : supported_isas()) {
    if (!s.empty()) s += ", ";
    s += to_string(isa);
  }
  return s;
}

void require_supported(Isa isa, const std::string& who) {
  if (!cpu_supports(isa)) {
    throw Error(who + ": this CPU cannot run the " + std::string(to_string(isa)) +
                " kernels (it supports: " + supported_list() + ")");
  }
}

Isa initial_isa() {
  const char* env = std::getenv("IMUKIT_ISA");
  if (env != nullptr && *env != '\0') {
    Isa isa;
    try {
      isa = parse_isa(env);
    } catch (const Error& e) {
      throw Error(std::string("IMUKIT_ISA: ") + e.what());
    }
    require_supported(isa, std::string("IMUKIT_ISA=") + env);
    return isa;
  }
  Isa best = Isa::baseline;
  for (Isa isa : kIsas)
    if (cpu_supports(isa)) best = isa;
  return best;
}

// -1 until the first call resolves it.
std::atomic<int> g_active{-1};

}  // namespace

std::string_view to_string(Isa isa) {
  switch (isa) {
    case Isa::baseline:
      return "baseline";
    case Isa::avx2:
      return "avx2";
    case Isa::avx512:
      return "avx512";
  }
  return "?";
}

Isa parse_isa(std::string_view name) {
  for (Isa isa : kIsas)
    if (name == to_string(isa)) return isa;
  throw Error("unknown instruction set '" + std::string(name) + "' (baseline, avx2 or avx512)");
}

bool isa_supported(Isa isa) { return cpu_supports(isa); }

std::vector<Isa> supported_isas() {
  std::vector<Isa> out;
  for (Isa isa : kIsas)
    if (cpu_supports(isa)) out.push_back(isa);
  return out;
}

Isa active_isa() {
  int v = g_active.load(std::memory_order_relaxed);
  if (v < 0) {
    // Resolved once; a thread racing here computes the same value.
    v = static_cast<int>(initial_isa());
    int expected = -1;
    if (!g_active.compare_exchange_strong(expected, v, std::memory_order_relaxed)) v = expected;
  }
  return static_cast<Isa>(v);
}

void set_active_isa(Isa isa) {
  require_supported(isa, "set_active_isa");
  g_active.store(static_cast<int>(isa), std::memory_order_relaxed);
}

}  // namespace imukit
