// The z-buffer record a warp draws into, and how a record is written: the
// bilinear colour of the source at a fixed-point position, depth in mm, the
// camera's quality. Internal to the warp (view_warp.cpp); GStreamer-free.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include <opencv2/imgproc.hpp>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace vclassroom {
namespace warp_record {

constexpr float kNear = 0.05f;  // metres: nearer points are behind the virtual lens
// Source positions are kept in OpenCV's fixed-point remap format: 1/32 px.
constexpr int kSubBits = cv::INTER_BITS;
constexpr int kSub = 1 << kSubBits;
// What the z-buffer keeps per virtual pixel: the winning sample, colour
// included. Nearly every sample written survives (a cell rarely lands behind
// another), so sampling the colour when writing costs no more than after,
// and reads the source near the row being splatted, in cache.
struct Sample {
  uint16_t z;  // mm along the virtual axis; kNoSample = nothing yet
  uint8_t rgb[3];
  uint8_t weight;  // 1..255
  uint8_t label;
  uint8_t unused;
};
constexpr uint16_t kNoSample = 0xffff;
static_assert(sizeof(Sample) == 8, "one z-buffer record is 8 bytes");
// An empty record as the z-buffer stores it (one word): z = kNoSample, the
// rest 0.
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
constexpr uint64_t kEmptyRecord = uint64_t(kNoSample) << 48;
#else
constexpr uint64_t kEmptyRecord = kNoSample;
#endif

// floor/ceil without a libm call (x86-64 baseline has no SSE4.1 round).
inline int fast_floor(float x) {
  const int i = int(x);
  return i > x ? i - 1 : i;
}
inline int fast_ceil(float x) {
  const int i = int(x);
  return i < x ? i + 1 : i;
}

// Depth in mm and weight in 1..255 as the z-buffer keeps them. The row
// kernels convert to 32-bit lanes (narrower conversions cost them shuffles).
// The mesh path extrapolates a little beyond its triangles: clamped both ways.
inline int32_t depth_mm_lane(float z_m) { return int32_t(std::clamp(z_m * 1000.0f + 0.5f, 0.0f, 65534.0f)); }
inline uint16_t depth_mm(float z_m) { return uint16_t(depth_mm_lane(z_m)); }
inline int32_t weight_lane(float w) { return int32_t(std::clamp(w * 255.0f + 0.5f, 1.0f, 255.0f)); }
inline uint8_t weight_byte(float w) { return uint8_t(weight_lane(w)); }
// A source position in remap fixed point (1/32 px), clamped into the image.
inline int32_t to_fixed(float s, float max) { return int32_t(std::clamp(s, 0.0f, max) * kSub + 0.5f); }

// Bilinear colour of the source at a fixed-point position (1/32 px) inside
// the image, packed 0x00bbggrr. Taken for nearly every virtual pixel of every
// camera: with SSE2 the three channels go through one multiply-add per stage
// (exactly the same integers as the scalar form, which serves the last
// row and column, where the neighbour to the right or below is the pixel
// itself, and machines without SSE2).
struct ColorSampler {
  const uint8_t* data;
  size_t step;
  int max_x, max_y;
  uint32_t operator()(int32_t fu, int32_t fv) const {
    const int ix = fu >> kSubBits, iy = fv >> kSubBits, fx = fu & (kSub - 1), fy = fv & (kSub - 1);
    const uint8_t* p0 = data + size_t(iy) * step + 3 * size_t(ix);
#ifdef __SSE2__
    if ((ix < max_x) & (iy < max_y)) {
      // Bytes 0..5 of both rows (two pixels), read as 0..3 and 2..5 so
      // nothing past the right neighbour is touched.
      auto load = [](const uint8_t* p) {
        uint32_t v;
        std::memcpy(&v, p, sizeof v);
        return _mm_cvtsi32_si128(int(v));
      };
      const uint8_t* p1 = p0 + step;
      const __m128i zero = _mm_setzero_si128();
      const __m128i top = _mm_unpacklo_epi8(_mm_unpacklo_epi8(load(p0), _mm_srli_epi32(load(p0 + 2), 8)), zero);
      const __m128i bot = _mm_unpacklo_epi8(_mm_unpacklo_epi8(load(p1), _mm_srli_epi32(load(p1 + 2), 8)), zero);
      // 16-bit lanes r0 r1 g0 g1 b0 b1 . . : one madd blends each pair.
      const __m128i wx = _mm_set1_epi32((fx << 16) | (kSub - fx)), wy = _mm_set1_epi32((fy << 16) | (kSub - fy));
      const __m128i ht = _mm_madd_epi16(top, wx), hb = _mm_madd_epi16(bot, wx);  // <= 255 * 32 each
      __m128i v = _mm_madd_epi16(_mm_or_si128(ht, _mm_slli_epi32(hb, 16)), wy);
      v = _mm_srli_epi32(_mm_add_epi32(v, _mm_set1_epi32(kSub * kSub / 2)), 2 * kSubBits);
      v = _mm_packs_epi32(v, v);
      return uint32_t(_mm_cvtsi128_si32(_mm_packus_epi16(v, v))) & 0xffffffu;
    }
#endif
    const uint8_t* p1 = iy < max_y ? p0 + step : p0;
    const int dx = ix < max_x ? 3 : 0;
    const int w00 = (kSub - fx) * (kSub - fy), w01 = fx * (kSub - fy), w10 = (kSub - fx) * fy, w11 = fx * fy;
    uint32_t rgb = 0;
    for (int c = 0; c < 3; ++c)
      rgb |= uint32_t((w00 * p0[c] + w01 * p0[dx + c] + w10 * p1[c] + w11 * p1[dx + c] + kSub * kSub / 2) >>
                      (2 * kSubBits))
             << (8 * c);
    return rgb;
  }
};


inline void store(Sample& s, uint16_t zmm, int32_t fu, int32_t fv, const ColorSampler& color, uint8_t weight,
                  uint8_t label) {
  const uint32_t rgb = color(fu, fv);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  // The whole record in one store.
  static_assert(offsetof(Sample, rgb) == 2 && offsetof(Sample, weight) == 5 && offsetof(Sample, label) == 6,
                "the record's layout as store() packs it");
  const uint64_t record = uint64_t(zmm) | uint64_t(rgb) << 16 | uint64_t(weight) << 40 | uint64_t(label) << 48;
  std::memcpy(&s, &record, sizeof record);
#else
  s.z = zmm;
  for (int c = 0; c < 3; ++c) s.rgb[c] = uint8_t(rgb >> (8 * c));
  s.weight = weight;
  s.label = label;
#endif
}


}  // namespace warp_record
}  // namespace vclassroom
