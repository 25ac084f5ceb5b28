// The calling thread's CPU time, in ms: what a stage costs, whatever else runs on the machine (the
// measuring tools' speed figures are in it, docs/benchmarks.md).
#pragma once

#include <ctime>

namespace vclassroom_tools {

inline double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

}  // namespace vclassroom_tools
