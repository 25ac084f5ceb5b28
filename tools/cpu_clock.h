// CPU clocks for the measuring tools (their speed figures: docs/benchmarks.md).
#pragma once

#include <ctime>

namespace vclassroom_tools {

// The calling thread's CPU time, in ms: what a stage costs, whatever else runs on the machine.
inline double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// The whole process's CPU time, in ms: what a stage costs with the threads it hands work to (OpenCV's, for
// parallel_for_), where nothing else of the process runs meanwhile.
inline double process_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

}  // namespace vclassroom_tools
