#include <gst/vclassroom/vva/sample_tiles.h>

#include <algorithm>

namespace vclassroom {

bool SampleTiles::fit(int width, int height) const {
  return width > 0 && height > 0 && row_first.size() == size_t((height + kPx - 1) / kPx) + 1 &&
         spans_fit(row_first, spans, width);
}

void SampleTiles::set_none(int height) {
  spans.clear();
  row_first.assign(size_t((height + kPx - 1) / kPx) + 1, 0);
}

void SampleTiles::set_marked(const uint8_t* marks, size_t stride, int width, int height) {
  spans.clear();
  const int rows = (height + kPx - 1) / kPx;  // a mark past the view's last row or column marks nothing there
  row_first.assign(size_t(rows) + 1, 0);
  for (int ty = 0; ty < rows; ++ty) {
    const uint8_t* m = marks + size_t(ty) * stride;
    row_first[size_t(ty)] = int32_t(spans.size());
    for (int tx = 0; tx * kPx < width;) {
      if (!m[tx]) {
        ++tx;
        continue;
      }
      const int first = tx;
      while (tx * kPx < width && m[tx]) ++tx;
      spans.emplace_back(first * kPx, std::min(width, tx * kPx));
    }
  }
  row_first[size_t(rows)] = int32_t(spans.size());
}

}  // namespace vclassroom
