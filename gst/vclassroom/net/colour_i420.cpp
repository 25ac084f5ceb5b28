#include <gst/vclassroom/net/colour_i420.h>

#include <algorithm>
#include <vector>

#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

// BT.601 limited range in 8-bit fixed point (the coefficients x 256, as ITU-R BT.601 and most converters round
// them): Y = 16 + (66 R + 129 G + 25 B) / 256, Cb = 128 + (-38 R - 74 G + 112 B) / 256,
// Cr = 128 + (112 R - 94 G - 18 B) / 256, rounded; the chroma of the sum of four pixels divided by 1024.
VCLASSROOM_SIMD_INLINE uint8_t luma(int r, int g, int b) { return uint8_t(((66 * r + 129 * g + 25 * b + 128) >> 8) + 16); }

// One RGB row into planes (so that the loops after it are plain lanes the compiler vectorises).
VCLASSROOM_SIMD_CLONES
void deinterleave(const uint8_t* __restrict rgb, int w, uint8_t* __restrict r, uint8_t* __restrict g,
                  uint8_t* __restrict b) {
  for (int x = 0; x < w; ++x) {
    r[x] = rgb[3 * x];
    g[x] = rgb[3 * x + 1];
    b[x] = rgb[3 * x + 2];
  }
}

VCLASSROOM_SIMD_CLONES
void luma_row(const uint8_t* __restrict r, const uint8_t* __restrict g, const uint8_t* __restrict b, int w,
              uint8_t* __restrict y) {
  for (int x = 0; x < w; ++x) y[x] = luma(r[x], g[x], b[x]);
}

// One chroma row from the planes of its two rows (each padded to an even width by repeating the last pixel).
// Offsets keep the sums positive before the shift (128 << 10 for the 128, 512 to round).
VCLASSROOM_SIMD_CLONES
void chroma_row(const uint8_t* __restrict r0, const uint8_t* __restrict g0, const uint8_t* __restrict b0,
                const uint8_t* __restrict r1, const uint8_t* __restrict g1, const uint8_t* __restrict b1, int pairs,
                uint8_t* __restrict cb, uint8_t* __restrict cr) {
  for (int i = 0; i < pairs; ++i) {
    const int r = r0[2 * i] + r0[2 * i + 1] + r1[2 * i] + r1[2 * i + 1];
    const int g = g0[2 * i] + g0[2 * i + 1] + g1[2 * i] + g1[2 * i + 1];
    const int b = b0[2 * i] + b0[2 * i + 1] + b1[2 * i] + b1[2 * i + 1];
    cb[i] = uint8_t((-38 * r - 74 * g + 112 * b + (128 << 10) + 512) >> 10);
    cr[i] = uint8_t((112 * r - 94 * g - 18 * b + (128 << 10) + 512) >> 10);
  }
}

// Chroma of one output row, both planes, in 1/4 (vertically interpolated: 3 x the nearer chroma row + the other).
VCLASSROOM_SIMD_CLONES
void blend_rows(const uint8_t* __restrict near_cb, const uint8_t* __restrict far_cb, const uint8_t* __restrict near_cr,
                const uint8_t* __restrict far_cr, int n, int16_t* __restrict cb4, int16_t* __restrict cr4) {
  for (int i = 0; i < n; ++i) {
    cb4[i] = int16_t(3 * near_cb[i] + far_cb[i]);
    cr4[i] = int16_t(3 * near_cr[i] + far_cr[i]);
  }
}

VCLASSROOM_SIMD_INLINE uint8_t clamp8(int v) { return uint8_t(std::clamp(v, 0, 255)); }

// Each output column's chroma offsets from the row's vertically interpolated chroma (cb4, cr4: ceil(w/2) + 2
// entries, the first and last repeating their neighbours so that no column is an edge case), horizontally
// interpolated (3 x the nearer + the other, in 1/16) less 128 x 16: column 2i from i and i - 1, 2i + 1 from
// i and i + 1 (entries shifted by one).
VCLASSROOM_SIMD_CLONES
void chroma_columns(const int16_t* __restrict cb4, const int16_t* __restrict cr4, int pairs,
                    int16_t* __restrict u, int16_t* __restrict v) {
  for (int i = 0; i < pairs; ++i) {
    u[2 * i] = int16_t(3 * cb4[i + 1] + cb4[i] - 128 * 16);
    u[2 * i + 1] = int16_t(3 * cb4[i + 1] + cb4[i + 2] - 128 * 16);
    v[2 * i] = int16_t(3 * cr4[i + 1] + cr4[i] - 128 * 16);
    v[2 * i + 1] = int16_t(3 * cr4[i + 1] + cr4[i + 2] - 128 * 16);
  }
}

// One output row from its luma row and its columns' chroma offsets (u, v in 1/16). BT.601 limited range back
// to RGB, the coefficients x 256: R = 298 (Y - 16) + 409 Cr', G = 298 (Y - 16) - 100 Cb' - 208 Cr',
// B = 298 (Y - 16) + 516 Cb' (Cb' = Cb - 128, Cr' = Cr - 128), rounded.
VCLASSROOM_SIMD_CLONES
void rgb_row(const uint8_t* __restrict y, const int16_t* __restrict u, const int16_t* __restrict v, int w,
             uint8_t* __restrict rgb) {
  for (int x = 0; x < w; ++x) {
    const int l = 298 * 16 * (int(y[x]) - 16) + 2048;
    rgb[3 * x] = clamp8((l + 409 * v[x]) >> 12);
    rgb[3 * x + 1] = clamp8((l - 100 * u[x] - 208 * v[x]) >> 12);
    rgb[3 * x + 2] = clamp8((l + 516 * u[x]) >> 12);
  }
}

}  // namespace

void i420_to_rgb(const uint8_t* y, int y_stride, const uint8_t* cb, int cb_stride, const uint8_t* cr, int cr_stride,
                 int w, int h, uint8_t* rgb, int rgb_stride) {
  const int cw = (w + 1) / 2, ch = (h + 1) / 2;
  std::vector<int16_t> cb4(size_t(cw) + 2), cr4(size_t(cw) + 2), u(2 * size_t(cw)), v(2 * size_t(cw));
  for (int row = 0; row < h; ++row) {
    // The chroma row this row lies in and the one on its other side (centred siting: below for an odd row).
    const int near = row / 2, far = std::clamp((row & 1) ? near + 1 : near - 1, 0, ch - 1);
    blend_rows(cb + size_t(near) * size_t(cb_stride), cb + size_t(far) * size_t(cb_stride),
               cr + size_t(near) * size_t(cr_stride), cr + size_t(far) * size_t(cr_stride), cw, cb4.data() + 1,
               cr4.data() + 1);
    cb4[0] = cb4[1];
    cr4[0] = cr4[1];
    cb4[size_t(cw) + 1] = cb4[size_t(cw)];
    cr4[size_t(cw) + 1] = cr4[size_t(cw)];
    chroma_columns(cb4.data(), cr4.data(), cw, u.data(), v.data());
    rgb_row(y + size_t(row) * size_t(y_stride), u.data(), v.data(), w, rgb + size_t(row) * size_t(rgb_stride));
  }
}

void rgb_to_i420(const uint8_t* rgb, int rgb_stride, int w, int h, uint8_t* y, int y_stride, uint8_t* cb,
                 int cb_stride, uint8_t* cr, int cr_stride) {
  const int cw = (w + 1) / 2;
  // Two rows' planes, each 2 cw wide: an odd last column is repeated, an odd last row uses its own planes twice.
  std::vector<uint8_t> planes(6 * size_t(cw) * 2);
  uint8_t* p[6];
  for (int i = 0; i < 6; ++i) p[i] = planes.data() + size_t(i) * 2 * size_t(cw);
  for (int row = 0; row < h; row += 2) {
    const int rows = std::min(2, h - row);
    for (int k = 0; k < rows; ++k) {
      uint8_t *r = p[3 * k], *g = p[3 * k + 1], *b = p[3 * k + 2];
      deinterleave(rgb + size_t(row + k) * size_t(rgb_stride), w, r, g, b);
      if (w & 1) r[w] = r[w - 1], g[w] = g[w - 1], b[w] = b[w - 1];
      luma_row(r, g, b, w, y + size_t(row + k) * size_t(y_stride));
    }
    const int second = rows == 2 ? 3 : 0;
    chroma_row(p[0], p[1], p[2], p[second], p[second + 1], p[second + 2], cw, cb + size_t(row / 2) * size_t(cb_stride),
               cr + size_t(row / 2) * size_t(cr_stride));
  }
}

}  // namespace vclassroom
