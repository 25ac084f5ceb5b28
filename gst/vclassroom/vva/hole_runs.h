// What both hole fills (hole_fill.cpp, hole_fill_rays.cpp) walk: the runs of unknown depth (0) along a row,
// and for each hole pixel the nearest known rows above and below it. Internal to the library (not installed).
#pragma once

#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

// Whether any of 4 depths packed in `v` is 0 (a hole).
inline bool any_zero_u16x4(uint64_t v) { return ((v - 0x0001000100010001ull) & ~v & 0x8000800080008000ull) != 0; }

// The next run of holes in row `d` (`width` depths) from *x on: true with it as [*first, *last] and *x just
// past it; false at the row's end. Most of a row is seen: it is skipped 16, then 4 depths at a time.
inline bool next_hole_run(const uint16_t* d, int width, int* x, int* first, int* last) {
  int i = *x;
  while (i < width) {
    if (i + 16 <= width) {
      uint64_t v[4];
      std::memcpy(v, d + i, 32);
      if (!(any_zero_u16x4(v[0]) | any_zero_u16x4(v[1]) | any_zero_u16x4(v[2]) | any_zero_u16x4(v[3]))) {
        i += 16;
        continue;
      }
    }
    if (i + 4 <= width) {
      uint64_t v;
      std::memcpy(&v, d + i, 8);
      if (!any_zero_u16x4(v)) {
        i += 4;
        continue;
      }
    }
    if (d[i]) {
      ++i;
      continue;
    }
    *first = i;
    while (i < width && !d[i]) ++i;
    *last = i - 1;
    *x = i;
    return true;
  }
  *x = width;
  return false;
}

// Column `h` of a hole in row `y`: above[h] becomes the nearest known row above it (-1: none) and below[h]
// the nearest below (the depth's rows: none), found once per vertical run of holes (a run starts where
// below[h] < y).
inline void find_known_rows(const cv::Mat& depth, int y, int h, std::vector<int>& above, std::vector<int>& below) {
  if (below[size_t(h)] >= y) return;
  above[size_t(h)] = y - 1;
  int yb = y + 1;
  while (yb < depth.rows && !depth.ptr<uint16_t>(yb)[h]) ++yb;
  below[size_t(h)] = yb;
}

}  // namespace vclassroom
