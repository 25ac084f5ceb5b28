// CPU clocks for the measuring tools (their speed figures: docs/benchmarks.md).
#pragma once

#include <ctime>

namespace vclassroom_tools {

// A clock's time, in ms.
inline double clock_ms(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// The calling thread's CPU time, in ms: what a stage costs, whatever else runs on the machine.
inline double thread_cpu_ms() { return clock_ms(CLOCK_THREAD_CPUTIME_ID); }

// The whole process's CPU time, in ms: what a stage costs with the threads it hands work to (OpenCV's, for
// parallel_for_), where nothing else of the process runs meanwhile.
inline double process_cpu_ms() { return clock_ms(CLOCK_PROCESS_CPUTIME_ID); }

}  // namespace vclassroom_tools
