// Run-time choice of a vectorised variant for hot per-pixel loops.
//
// The build targets the Debian x86-64 baseline (SSE2); most machines running
// a classroom server have AVX2. A function marked VCLASSROOM_SIMD_CLONES is
// compiled twice and the loader picks the AVX2 copy where the CPU has it, so
// the project stays portable without a global -march flag.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define VCLASSROOM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define VCLASSROOM_SIMD_CLONES
#endif
