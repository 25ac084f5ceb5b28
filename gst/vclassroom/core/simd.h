// Run-time choice of a vectorised variant for hot per-pixel loops.
//
// The build targets the Debian x86-64 baseline (SSE2); most machines running
// a classroom server have AVX2, many AVX-512. A function marked
// VCLASSROOM_SIMD_CLONES is compiled three times and the loader picks the
// best copy the CPU runs (x86-64-v4: AVX-512 with its 32 vector registers,
// which the wide per-pixel loops need to stop spilling; AVX2; baseline), so
// the project stays portable without a global -march flag.
//
// Results do not depend on the copy: meson.build turns off floating-point
// contraction, so the FMA of the newer copies never fuses a * b + c.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define VCLASSROOM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
// Helpers called from a cloned loop must be inlined into each copy to be
// compiled for its target.
#define VCLASSROOM_SIMD_INLINE inline __attribute__((always_inline))
#else
#define VCLASSROOM_SIMD_CLONES
#define VCLASSROOM_SIMD_INLINE inline
#endif
