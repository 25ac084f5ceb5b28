// Run-time choice of a vectorised variant for hot per-pixel loops.
//
// The build targets the Debian x86-64 baseline (SSE2); most machines running
// a classroom server have AVX2. A function marked VCLASSROOM_SIMD_CLONES is
// compiled twice and the loader picks the AVX2 copy where the CPU has it, so
// the project stays portable without a global -march flag.
//
// Plain "avx2", not x86-64-v3, on purpose: without FMA the compiler cannot
// contract a * b + c, so both copies round alike and results do not depend on
// the CPU they run on.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define VCLASSROOM_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
// Helpers called from a cloned loop must be inlined into each copy to be
// compiled for its target.
#define VCLASSROOM_SIMD_INLINE inline __attribute__((always_inline))
#else
#define VCLASSROOM_SIMD_CLONES
#define VCLASSROOM_SIMD_INLINE inline
#endif
