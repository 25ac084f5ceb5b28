// Where something lies in a view, at the grain of tiles of 8 x 8 pixels: per row of tiles the column spans of
// its marked tiles (the learners' samples of a sparse warped view: view_warp.h; the holes the near cameras'
// meshes leave: room_view.cpp). GStreamer-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vclassroom {

// Where the samples of a sparse warped view may lie: the view in tiles of kPx x kPx pixels, and per row of
// tiles the column spans of its marked tiles (neighbours joined). Learners spread over a room leave most of
// their box empty (about 42 k pixels a camera in a box of 830 x 360 at 960 x 540): the view is unpacked,
// cleared and fused over these spans only.
struct SampleTiles {
  static constexpr int kShift = 3, kPx = 1 << kShift;
  // Per row of tiles, the index of its first span; one more entry at the end. Empty: samples anywhere.
  std::vector<int32_t> row_first;
  std::vector<std::pair<int, int>> spans;  // pixel columns [first, second)
  bool anywhere() const { return row_first.empty(); }
  // Whether these are tiles of a width x height view (a reader given them by another checks before of_row).
  bool fit(int width, int height) const;
  // Made the tiles `marks` sets (per row of tiles `stride` bytes, one per tile; at least as many rows and
  // columns of tiles as the width x height view has), as spans of each row of tiles.
  void set_marked(const uint8_t* marks, size_t stride, int width, int height);
  // Made the tiles of a view `height` pixels high with nothing marked.
  void set_none(int height);
  // The indices [first, second) in `spans` of pixel row y's spans (y within the view).
  std::pair<int32_t, int32_t> of_row(int y) const {
    const size_t t = size_t(y >> kShift);
    return {row_first[t], row_first[t + 1]};
  }
};

// Calls fn(y, x0, x1) for every span [x0, x1) of every pixel row y < height of `tiles` (not anywhere()), row
// by row, left to right.
template <typename Fn>
void for_each_tile_span(const SampleTiles& tiles, int height, Fn&& fn) {
  for (int y = 0; y < height; ++y) {
    const auto [first, end] = tiles.of_row(y);
    for (int32_t i = first; i < end; ++i) fn(y, tiles.spans[size_t(i)].first, tiles.spans[size_t(i)].second);
  }
}

// Whether `first` (one entry per row of spans, and one more) indexes `spans` from 0 to its end, never going
// back, and each row's spans are ordered, apart and within [0, width): the index is checked whole before a span
// is read.
template <typename Index>
bool spans_fit(const std::vector<Index>& first, const std::vector<std::pair<int, int>>& spans, int width) {
  if (first.empty() || first.front() != 0 || size_t(first.back()) != spans.size()) return false;
  for (size_t r = 0; r + 1 < first.size(); ++r)
    if (first[r] > first[r + 1]) return false;
  for (size_t r = 0; r + 1 < first.size(); ++r) {
    int end = 0;
    for (size_t i = size_t(first[r]); i < size_t(first[r + 1]); ++i) {
      const auto [x0, x1] = spans[i];
      if (x0 < end || x1 <= x0 || x1 > width) return false;
      end = x1;
    }
  }
  return true;
}

}  // namespace vclassroom
