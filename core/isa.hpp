// The instruction sets imukit's hot kernels are built for, and which one runs.
//
// Kernels that gain from wide vectors (the simulator's frame and sample loops, PPDA's rotation
// loops, the Allan deviation's lane sums, the normal generator) are compiled three times in their
// own translation unit with IMUKIT_ISA_VARIANTS below: for the x86-64 baseline (SSE2), AVX2
// and AVX-512. No -m flag is given to whole files, so no inline function is ever compiled for
// AVX in one file and merged by the linker with another file's copy; and every variant is
// `flatten`, so whatever the kernel calls is inlined into it, compiled for the variant's own
// instruction set: no call leaves it for code built for another (on Intel cores a VEX-encoded
// caller and a legacy-SSE callee pay the AVX-SSE transition penalty; issue 17 measured 12x).
// tests/isa/check_isa_calls.py reads the built machine code to keep it so.
//
// The arithmetic and its order are the same in every variant (no FMA contraction:
// -ffp-contract=off), so every variant computes the same bits; tests compare them.
//
// The variant that runs is the best the CPU supports, or the one the environment variable
// IMUKIT_ISA names (baseline, avx2 or avx512; read once, at the first kernel call; naming one the
// CPU cannot run is an error). set_active_isa() changes it for tests and benchmarks.
#pragma once

#include <string_view>
#include <vector>

namespace imukit {

enum class Isa { baseline, avx2, avx512 };

// "baseline", "avx2", "avx512".
std::string_view to_string(Isa isa);
// The inverse; throws imukit::Error for any other name.
Isa parse_isa(std::string_view name);

// This CPU (and its operating system) can run the variant: AVX2 for avx2; AVX-512 F, DQ, BW and
// VL for avx512. Always true for the baseline.
bool isa_supported(Isa isa);
// The supported variants, baseline first.
std::vector<Isa> supported_isas();

// The variant the kernels run: IMUKIT_ISA's if set, else the best supported. Throws
// imukit::Error when IMUKIT_ISA names an unknown or unsupported instruction set.
Isa active_isa();
// Makes every kernel run `isa` from now on (for tests and benchmarks comparing variants; not
// meant to be called while kernels run on other threads). Throws imukit::Error if unsupported.
void set_active_isa(Isa isa);

}  // namespace imukit

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define IMUKIT_ISA_ATTR_BASELINE __attribute__((flatten))
#define IMUKIT_ISA_ATTR_AVX2 __attribute__((target("avx2"), flatten))
#define IMUKIT_ISA_ATTR_AVX512 \
  __attribute__((target("avx512f,avx512dq,avx512bw,avx512vl"), flatten))

// IMUKIT_ISA_VARIANTS(ret, name, kernel, (params), (args)) defines
//   ret name(params)
// which runs `kernel(args)` compiled for the active instruction set. `kernel` is an inline
// function of the same translation unit that works on plain arrays and calls nothing that cannot
// be inlined (no allocation, no virtual call, no function of another file: those leave the
// variant). The three variants have internal linkage. Use it at namespace scope.
#define IMUKIT_ISA_VARIANTS(ret, name, kernel, params, args)                         \
  IMUKIT_ISA_ATTR_BASELINE static ret name##_baseline params { return kernel args; } \
  IMUKIT_ISA_ATTR_AVX2 static ret name##_avx2 params { return kernel args; }         \
  IMUKIT_ISA_ATTR_AVX512 static ret name##_avx512 params { return kernel args; }     \
  ret name params {                                                                  \
    switch (::imukit::active_isa()) {                                                \
      case ::imukit::Isa::avx512:                                                    \
        return name##_avx512 args;                                                   \
      case ::imukit::Isa::avx2:                                                      \
        return name##_avx2 args;                                                     \
      case ::imukit::Isa::baseline:                                                  \
        break;                                                                       \
    }                                                                                \
    return name##_baseline args;                                                     \
  }
#else
#define IMUKIT_ISA_VARIANTS(ret, name, kernel, params, args) \
  ret name params { return kernel args; }
#endif
