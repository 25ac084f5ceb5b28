// The backward room lookup as a tight loop (room_lookup_fast.h). Each step is a loop over a whole view row
// with no branch, so the compiler vectorises it (gathers for the source's 2x2), built per SIMD level.
#include <gst/vclassroom/vva/room_lookup_fast.h>

#include <algorithm>
#include <array>
#include <cmath>

#include <gst/vclassroom/core/simd.h>

#include <emmintrin.h>

namespace vclassroom {

namespace {

// One row of pack_room_records: the room's depth and colour where the label is 0, the memory's room where a
// learner hides it, else nothing (depth 0).
VCLASSROOM_SIMD_CLONES
void room_records_row(int n, const uint16_t* depth, const uint8_t* label, const uint8_t* color,
                      const uint16_t* room_depth, const uint8_t* room_color, uint64_t* out) {
  for (int x = 0; x < n; ++x) {
    const bool seen = label[x] == 0 && depth[x] != 0;
    const uint16_t rd = room_depth ? room_depth[x] : 0;
    const uint16_t d = seen ? depth[x] : rd;
    const uint8_t* c = seen || !room_color ? color + 3 * x : room_color + 3 * x;
    out[x] = uint64_t(d) | uint64_t(c[0]) << 16 | uint64_t(c[1]) << 32 | uint64_t(c[2]) << 48;
  }
}

}  // namespace

void pack_room_records(const CameraCalib& camera, const uint16_t* depth, const uint8_t* label, const cv::Mat& color,
                       const cv::Mat& room_depth, const cv::Mat& room_color, RoomTexture* out) {
  const int W = color.cols, H = color.rows;
  CV_Assert(!camera.has_distortion() && color.type() == CV_8UC3);
  const bool room = !room_depth.empty() && room_depth.size() == color.size() && room_color.size() == color.size();
  out->camera = camera;
  out->width = W, out->height = H;
  out->packed.resize(size_t(W) * H);
  for (int y = 0; y < H; ++y)
    room_records_row(W, depth + size_t(y) * W, label + size_t(y) * W, color.ptr<uint8_t>(y),
                     room ? room_depth.ptr<uint16_t>(y) : nullptr, room ? room_color.ptr<uint8_t>(y) : nullptr,
                     out->packed.data() + size_t(y) * W);
}

void pack_room_texture(const RoomLookupSource& s, RoomTexture* out) {
  CV_Assert(!s.camera.has_distortion());
  const int W = s.color.cols, H = s.color.rows;
  out->camera = s.camera;
  out->width = W, out->height = H;
  out->depth.resize(size_t(W) * H);
  out->color.resize(size_t(W) * H);
  out->scale.resize(size_t(W) * H);
  out->packed.resize(size_t(W) * H);
  out->planes.resize(4 * size_t(W) * H);
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = s.depth.ptr<uint16_t>(y);
    const uint8_t* c = s.color.ptr<uint8_t>(y);
    const uint8_t* m = s.remembered.empty() ? nullptr : s.remembered.ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      out->depth[i] = float(d[x]);
      out->color[i] = uint32_t(c[3 * x]) | uint32_t(c[3 * x + 1]) << 8 | uint32_t(c[3 * x + 2]) << 16;
      out->scale[i] = m && m[x] ? 0.5f : 1.0f;
      const size_t N = size_t(W) * H;
      out->planes[i] = d[x], out->planes[N + i] = c[3 * x], out->planes[2 * N + i] = c[3 * x + 1];
      out->planes[3 * N + i] = c[3 * x + 2];
      out->packed[i] = uint64_t(d[x]) | uint64_t(c[3 * x]) << 16 | uint64_t(c[3 * x + 1]) << 32 |
                       uint64_t(c[3 * x + 2]) << 48;
    }
  }
}

namespace {

// One camera for one view: view pixel (x, y) at view depth z (mm) lands at camera pixel h / h.z with
// h = z * (b + x * s) + t, h.z the camera's depth (mm); its centre in view coordinates (m).
struct LookupCamera {
  float b[3], s[3], t[3];
  float centre[3];
  const float* depth;
  const uint32_t* color;
  const float* scale;
  int W, H;
};

// Per view row and camera: where each pixel lands, and what the camera makes of it.
struct RowScratch {
  std::vector<float> z, u, v, zc, m2, r, g, bl, w, strict;
  void resize(int n) {
    for (auto* a : {&z, &u, &v, &zc, &m2, &r, &g, &bl, &w, &strict}) a->resize(size_t(n));
  }
};

struct Tolerance {
  float mm, ratio;
};

VCLASSROOM_SIMD_INLINE float agree(float a, float b, Tolerance tol) {
  const float lo = a < b ? a : b, d = a > b ? a - b : b - a, rel = tol.ratio * lo;
  return ((b > 0.0f) & (d <= (tol.mm > rel ? tol.mm : rel))) ? 1.0f : 0.0f;
}

// Every pixel of the row projected at its depth z.
VCLASSROOM_SIMD_CLONES
void project_row(int n, const LookupCamera& c, const float* __restrict z, float* __restrict u, float* __restrict v,
                 float* __restrict zc, float* __restrict m2) {
  for (int x = 0; x < n; ++x) {
    const float fx = float(x);
    const float a0 = c.b[0] + fx * c.s[0], a1 = c.b[1] + fx * c.s[1], a2 = c.b[2] + fx * c.s[2];
    const float h0 = z[x] * a0 + c.t[0], h1 = z[x] * a1 + c.t[1], h2 = z[x] * a2 + c.t[2];
    const float ih = 1.0f / (h2 > 1.0f ? h2 : 1.0f);
    u[x] = h0 * ih;
    v[x] = h1 * ih;
    zc[x] = h2;
    m2[x] = a2;
  }
}

// Where (u, v) lies in the camera's 2x2 of pixels: the top-left's index and the bilinear fractions; 0 in
// `inside` where it lies outside the image or behind the camera.
struct Cell {
  int i;
  float fx, fy, inside;
};
VCLASSROOM_SIMD_INLINE Cell cell_of(const LookupCamera& c, float u, float v, float zc) {
  const float inside = ((u >= -0.5f) & (v >= -0.5f) & (u <= float(c.W) - 0.5f) & (v <= float(c.H) - 0.5f) &
                        (zc >= 50.0f)) ? 1.0f : 0.0f;
  const float uc = std::clamp(u, 0.0f, float(c.W) - 1.001f), vc = std::clamp(v, 0.0f, float(c.H) - 1.001f);
  const int ix = int(uc), iy = int(vc);
  return {iy * c.W + ix, uc - float(ix), vc - float(iy), inside};
}

// One step onto the camera's own surface: the depth of its 2x2 that agrees with the point (bilinear), and
// the point moved along the view ray to it when it stays the view's surface.
VCLASSROOM_SIMD_CLONES
void refine_row(int n, const LookupCamera& c, Tolerance tol, const float* __restrict z, float* __restrict u,
                float* __restrict v, float* __restrict zc, const float* __restrict m2, float* __restrict zr) {
  const float* __restrict D = c.depth;
  for (int x = 0; x < n; ++x) {
    const Cell k = cell_of(c, u[x], v[x], zc[x]);
    const float d00 = D[k.i], d01 = D[k.i + 1], d10 = D[k.i + c.W], d11 = D[k.i + c.W + 1];
    const float w00 = (1 - k.fx) * (1 - k.fy) * agree(zc[x], d00, tol), w01 = k.fx * (1 - k.fy) * agree(zc[x], d01, tol);
    const float w10 = (1 - k.fx) * k.fy * agree(zc[x], d10, tol), w11 = k.fx * k.fy * agree(zc[x], d11, tol);
    const float sw = w00 + w01 + w10 + w11;
    const float d = (w00 * d00 + w01 * d01 + w10 * d10 + w11 * d11) / (sw > 1e-6f ? sw : 1.0f);
    const float zn = (d - c.t[2]) / (m2[x] != 0.0f ? m2[x] : 1.0f);
    const bool take = (k.inside > 0.0f) & (sw > 1e-6f) & (agree(zn, z[x], tol) > 0.0f);
    zr[x] = take ? zn : z[x];
  }
}

// The camera's colour at each position: bilinear over the 2x2 members that agree with the point, its weight
// (0: not seen) and whether the whole 2x2 agrees (strict: the warp's cell coverage).
VCLASSROOM_SIMD_CLONES
void sample_row(int n, const LookupCamera& c, Tolerance tol, const float* __restrict u, const float* __restrict v,
                const float* __restrict zc, float* __restrict r, float* __restrict g, float* __restrict bl,
                float* __restrict w, float* __restrict strict) {
  const float* __restrict D = c.depth;
  const uint32_t* __restrict C = c.color;
  for (int x = 0; x < n; ++x) {
    const Cell k = cell_of(c, u[x], v[x], zc[x]);
    const int i01 = k.i + 1, i10 = k.i + c.W, i11 = k.i + c.W + 1;
    const float a00 = agree(zc[x], D[k.i], tol), a01 = agree(zc[x], D[i01], tol), a10 = agree(zc[x], D[i10], tol),
                a11 = agree(zc[x], D[i11], tol);
    const float b00 = (1 - k.fx) * (1 - k.fy), b01 = k.fx * (1 - k.fy), b10 = (1 - k.fx) * k.fy, b11 = k.fx * k.fy;
    const float w00 = b00 * a00, w01 = b01 * a01, w10 = b10 * a10, w11 = b11 * a11;
    const float sw = w00 + w01 + w10 + w11, isw = 1.0f / (sw > 1e-6f ? sw : 1.0f);
    const uint32_t c00 = C[k.i], c01 = C[i01], c10 = C[i10], c11 = C[i11];
    r[x] = (w00 * float(c00 & 255) + w01 * float(c01 & 255) + w10 * float(c10 & 255) + w11 * float(c11 & 255)) * isw;
    g[x] = (w00 * float((c00 >> 8) & 255) + w01 * float((c01 >> 8) & 255) + w10 * float((c10 >> 8) & 255) +
            w11 * float((c11 >> 8) & 255)) * isw;
    bl[x] = (w00 * float(c00 >> 16) + w01 * float(c01 >> 16) + w10 * float(c10 >> 16) + w11 * float(c11 >> 16)) * isw;
    // A neighbour more than kEdge (a cell's reach past its centre towards an edge) away from the position
    // that does not agree: the position lies beyond the surface's cells.
    const float fxm = 1 - k.fx, fym = 1 - k.fy;
    const bool out00 = (a00 == 0.0f) & ((fxm < fym ? fxm : fym) > 0.02f);
    const bool out01 = (a01 == 0.0f) & ((k.fx < fym ? k.fx : fym) > 0.02f);
    const bool out10 = (a10 == 0.0f) & ((fxm < k.fy ? fxm : k.fy) > 0.02f);
    const bool out11 = (a11 == 0.0f) & ((k.fx < k.fy ? k.fx : k.fy) > 0.02f);
    const bool seen = (k.inside > 0.0f) & (sw > 1e-6f);
    w[x] = seen ? 1.0f : 0.0f;
    strict[x] = (seen & !(out00 | out01 | out10 | out11)) ? 1.0f : 0.0f;
  }
}

// The warp's quality for each seen point (cos^8 of the ray angle x distance ratio x the layer's scale, as a
// byte), squared: viewfuse's weight without the magnification term.
VCLASSROOM_SIMD_CLONES
void weigh_row(int n, const LookupCamera& c, float y, const float* __restrict z, const float* __restrict u,
               const float* __restrict v, const float* __restrict zc, float ifx, float ify, float vcx, float vcy,
               float* __restrict w) {
  for (int x = 0; x < n; ++x) {
    const float zm = z[x] * 0.001f;
    const float px = (float(x) - vcx) * ifx * zm, py = (y - vcy) * ify * zm, pz = zm;
    const float dx = px - c.centre[0], dy = py - c.centre[1], dz = pz - c.centre[2];
    const float p2 = px * px + py * py + pz * pz, d2 = dx * dx + dy * dy + dz * dz + 1e-12f;
    const float cs = (px * dx + py * dy + pz * dz) / std::sqrt(p2 * d2);
    const float c2 = cs * cs, c4 = c2 * c2, c8 = c4 * c4;
    const float nearer = std::sqrt(std::min(1.0f, p2 / d2));
    const Cell k = cell_of(c, u[x], v[x], zc[x]);
    const float q = std::max(0.02f, c8) * nearer * c.scale[k.i];
    const float byte = std::clamp(float(int(q * 255.0f + 0.5f)), 1.0f, 255.0f) * (1.0f / 255.0f);
    w[x] *= byte * byte + 1e-6f;
  }
}

// The cameras blended where the row's pixel is a candidate: those whose whole 2x2 agrees when there are
// any, else every camera that sees the point; written where one does. Returns the pixels written.
VCLASSROOM_SIMD_CLONES
void any_strict_row(int n, const float* __restrict w, const float* __restrict strict, float* __restrict any) {
  for (int x = 0; x < n; ++x) any[x] = (w[x] > 0.0f) & (strict[x] > 0.0f) ? 1.0f : any[x];
}

VCLASSROOM_SIMD_CLONES
void add_row(int n, const float* __restrict any, const RowScratch& s, float* __restrict r, float* __restrict g,
             float* __restrict b, float* __restrict sw) {
  const float *__restrict w = s.w.data(), *__restrict st = s.strict.data(), *__restrict sr = s.r.data(),
              *__restrict sg = s.g.data(), *__restrict sb = s.bl.data();
  for (int x = 0; x < n; ++x) {
    const float wt = any[x] > 0.0f ? w[x] * st[x] : w[x];
    r[x] += wt * sr[x];
    g[x] += wt * sg[x];
    b[x] += wt * sb[x];
    sw[x] += wt;
  }
}

// The packed sampler's set-up, vectorised: the 2x2's first record, its four bilinear weights in 1/256 (0
// where the position lies outside the image or behind the camera) and the depth range that agrees (lo, and
// the range's width, 16 bits each).
VCLASSROOM_SIMD_CLONES
void cells_row(int n, const LookupCamera& c, Tolerance tol, const float* __restrict u, const float* __restrict v,
               const float* __restrict zc, int32_t* __restrict idx, uint16_t* __restrict wq,
               uint32_t* __restrict lohi) {
  for (int x = 0; x < n; ++x) {
    const Cell k = cell_of(c, u[x], v[x], zc[x]);
    const int fx = int(k.fx * 16.0f + 0.5f), fy = int(k.fy * 16.0f + 0.5f);
    const int on = k.inside > 0.0f ? 1 : 0;
    idx[x] = k.i;
    wq[4 * x] = uint16_t((16 - fx) * (16 - fy) * on);
    wq[4 * x + 1] = uint16_t(fx * (16 - fy) * on);
    wq[4 * x + 2] = uint16_t((16 - fx) * fy * on);
    wq[4 * x + 3] = uint16_t(fx * fy * on);
    const float z = zc[x], t = tol.ratio * z, half = tol.mm > t ? tol.mm : t;
    const float lo = std::clamp(z - half, 1.0f, 65535.0f), hi = std::clamp(z + half, 1.0f, 65535.0f);
    lohi[x] = uint32_t(lo) | uint32_t(hi - lo) << 16;
  }
}

// Per position, the sums over the 2x2 members whose depth agrees: weight, weight x r, g, b (16-bit lanes;
// a weight of 256 in all: the whole 2x2 agrees, the strict coverage).
VCLASSROOM_SIMD_CLONES
void sample_packed_row(int n, const uint64_t* __restrict rec, int W, const int32_t* __restrict idx,
                       const uint16_t* __restrict wq, const uint32_t* __restrict lohi, uint16_t* __restrict out) {
  const __m128i zero = _mm_setzero_si128(), rgb = _mm_set_epi16(-1, -1, -1, 0, -1, -1, -1, 0),
                one = _mm_set_epi16(0, 0, 0, 1, 0, 0, 0, 1);
  for (int x = 0; x < n; ++x) {
    const __m128i top = _mm_loadu_si128(reinterpret_cast<const __m128i*>(rec + idx[x]));
    const __m128i bot = _mm_loadu_si128(reinterpret_cast<const __m128i*>(rec + idx[x] + W));
    const __m128i lh = _mm_set1_epi32(int(lohi[x]));
    const __m128i lo = _mm_shuffle_epi32(_mm_shufflelo_epi16(lh, 0x00), 0x00);
    const __m128i width = _mm_shuffle_epi32(_mm_shufflelo_epi16(lh, 0x55), 0x00);
    __m128i okt = _mm_cmpeq_epi16(_mm_subs_epu16(_mm_sub_epi16(top, lo), width), zero);
    __m128i okb = _mm_cmpeq_epi16(_mm_subs_epu16(_mm_sub_epi16(bot, lo), width), zero);
    okt = _mm_shufflehi_epi16(_mm_shufflelo_epi16(okt, 0x00), 0x00);  // each pixel's depth test to its lanes
    okb = _mm_shufflehi_epi16(_mm_shufflelo_epi16(okb, 0x00), 0x00);
    const __m128i w = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(wq + 4 * x));
    const __m128i w2 = _mm_unpacklo_epi16(w, w);
    const __m128i wt = _mm_unpacklo_epi32(w2, w2), wb = _mm_unpackhi_epi32(w2, w2);
    const __m128i rt = _mm_or_si128(_mm_and_si128(top, rgb), one), rb = _mm_or_si128(_mm_and_si128(bot, rgb), one);
    __m128i sum = _mm_add_epi16(_mm_mullo_epi16(rt, _mm_and_si128(wt, okt)), _mm_mullo_epi16(rb, _mm_and_si128(wb, okb)));
    sum = _mm_add_epi16(sum, _mm_srli_si128(sum, 8));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(out + 4 * x), sum);
  }
}

VCLASSROOM_SIMD_CLONES
void any_strict_packed_row(int n, const uint16_t* __restrict s, float* __restrict any) {
  for (int x = 0; x < n; ++x) any[x] = s[4 * x] == 256 ? 1.0f : any[x];
}

VCLASSROOM_SIMD_CLONES
void add_packed_row(int n, const float* __restrict any, const uint16_t* __restrict s, float* __restrict r,
                    float* __restrict g, float* __restrict b, float* __restrict sw) {
  for (int x = 0; x < n; ++x) {
    const float w = float(s[4 * x]);
    const bool take = any[x] > 0.0f ? w == 256.0f : w > 0.0f;
    const float k = take ? 1.0f / (w > 0.0f ? w : 1.0f) : 0.0f;
    r[x] += k * float(s[4 * x + 1]);
    g[x] += k * float(s[4 * x + 2]);
    b[x] += k * float(s[4 * x + 3]);
    sw[x] += take ? 1.0f : 0.0f;
  }
}

// The blended colour where a camera saw the candidate pixel, the view's colour elsewhere (a select: the
// loop vectorises).
VCLASSROOM_SIMD_CLONES
void store_row(int n, const float* __restrict z, const float* __restrict r, const float* __restrict g,
               const float* __restrict b, const float* __restrict sw, uint8_t* __restrict out,
               uint8_t* __restrict written = nullptr) {
  if (written)
    for (int x = 0; x < n; ++x) written[x] = uint8_t(((sw[x] > 0.0f) & (z[x] != 0.0f)) ? 255 : 0);
  for (int x = 0; x < n; ++x) {
    const bool take = (sw[x] > 0.0f) & (z[x] != 0.0f);  // z 0: not a candidate, projects nowhere useful
    const float i = 1.0f / (sw[x] > 0.0f ? sw[x] : 1.0f);
    const int nr = int(std::min(255.0f, r[x] * i + 0.5f)), ng = int(std::min(255.0f, g[x] * i + 0.5f)),
              nb = int(std::min(255.0f, b[x] * i + 0.5f));
    out[3 * x] = take ? uint8_t(nr) : out[3 * x];
    out[3 * x + 1] = take ? uint8_t(ng) : out[3 * x + 1];
    out[3 * x + 2] = take ? uint8_t(nb) : out[3 * x + 2];
  }
}

// best_only: each camera's weight kept where it is the best so far of the cameras that count (ties: the
// first), zeroed in the others.
void keep_best(int n, int nc, const float* any, std::vector<RowScratch>& cams) {
  for (int x = 0; x < n; ++x) {
    int best = -1;
    float wb = 0;
    for (int k = 0; k < nc; ++k) {
      const RowScratch& s = cams[size_t(k)];
      const float w = any[x] > 0.0f ? s.w[size_t(x)] * s.strict[size_t(x)] : s.w[size_t(x)];
      if (w > wb) wb = w, best = k;
    }
    for (int k = 0; k < nc; ++k)
      if (k != best) cams[size_t(k)].w[size_t(x)] = 0;
  }
}

long blend_row(int n, int nc, RowScratch& acc, std::vector<RowScratch>& cams, uint8_t* out, bool best_only) {
  float *any = acc.m2.data(), *r = acc.r.data(), *g = acc.g.data(), *b = acc.bl.data(), *sw = acc.w.data();
  std::fill_n(any, n, 0.0f), std::fill_n(r, n, 0.0f), std::fill_n(g, n, 0.0f), std::fill_n(b, n, 0.0f);
  std::fill_n(sw, n, 0.0f);
  for (int k = 0; k < nc; ++k) any_strict_row(n, cams[size_t(k)].w.data(), cams[size_t(k)].strict.data(), any);
  if (best_only) keep_best(n, nc, any, cams);
  for (int k = 0; k < nc; ++k) add_row(n, any, cams[size_t(k)], r, g, b, sw);
  store_row(n, acc.z.data(), r, g, b, sw, out);
  return 0;  // counted by the caller, outside the timed loop
}

void blend_packed_row(int n, int nc, RowScratch& acc, const std::vector<std::vector<uint16_t>>& sums, uint8_t* out,
                      uint8_t* written) {
  float *any = acc.m2.data(), *r = acc.r.data(), *g = acc.g.data(), *b = acc.bl.data(), *sw = acc.w.data();
  std::fill_n(any, n, 0.0f), std::fill_n(r, n, 0.0f), std::fill_n(g, n, 0.0f), std::fill_n(b, n, 0.0f);
  std::fill_n(sw, n, 0.0f);
  for (int k = 0; k < nc; ++k) any_strict_packed_row(n, sums[size_t(k)].data(), any);
  for (int k = 0; k < nc; ++k) add_packed_row(n, any, sums[size_t(k)].data(), r, g, b, sw);
  store_row(n, acc.z.data(), r, g, b, sw, out, written);
}

// The camera for row 0; row y adds y * dy to b.
LookupCamera lookup_camera(const RoomTexture& t, const CameraCalib& virt, float dy[3]) {
  const CameraCalib& cam = t.camera;
  const Eigen::Isometry3d T = cam.cam_to_rig.inverse() * virt.cam_to_rig;  // view -> camera
  const Eigen::Matrix3d M = cam.K() * T.linear() * virt.K().inverse();
  const Eigen::Vector3d tt = cam.K() * T.translation() * 1000.0;
  const Eigen::Vector3d b = M * Eigen::Vector3d(0, 0, 1), s = M.col(0);
  const Eigen::Vector3d centre = T.inverse().translation();
  LookupCamera c{};
  for (int k = 0; k < 3; ++k) {
    c.b[k] = float(b[k]), c.s[k] = float(s[k]), c.t[k] = float(tt[k]), c.centre[k] = float(centre[k]);
    dy[k] = float(M(k, 1));
  }
  c.depth = t.depth.data(), c.color = t.color.data(), c.scale = t.scale.data();
  c.W = t.width, c.H = t.height;
  return c;
}

}  // namespace

long room_lookup_fast(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt,
                      const cv::Mat& view_depth, const cv::Mat& mask, const RoomLookupFastParams& p,
                      cv::Mat* color, cv::Mat* written) {
  CV_Assert(view_depth.type() == CV_16UC1 && mask.type() == CV_8UC1 && color->type() == CV_8UC3);
  // With packed as well, the packed SSE2 loop is the fallback where the CPU lacks AVX2.
  if (p.avx2 && p.refine_steps == 0 && p.equal_weights && !p.best_only &&
      room_lookup_avx2(cameras, virt, view_depth, mask, p, color, written))
    return 0;
  CV_Assert(!written || p.packed);  // the other loops do not say which pixels they wrote
  if (written) written->create(view_depth.size(), CV_8UC1);
  const int VW = view_depth.cols, VH = view_depth.rows, nc = int(cameras.size());
  const Tolerance tol{float(p.depth_tol_mm), float(p.depth_tol_ratio)};
  static thread_local std::vector<RowScratch> cam_rows;
  static thread_local RowScratch row;
  static thread_local std::vector<int32_t> idx;
  static thread_local std::vector<uint16_t> wq;
  static thread_local std::vector<uint32_t> lohi;
  static thread_local std::vector<std::vector<uint16_t>> sums;
  idx.resize(size_t(VW)), wq.resize(4 * size_t(VW)), lohi.resize(size_t(VW));
  sums.resize(size_t(nc));
  for (auto& v : sums) v.resize(4 * size_t(VW));
  cam_rows.resize(size_t(nc));
  for (auto& s : cam_rows) s.resize(VW);
  row.resize(VW);
  std::vector<LookupCamera> cams0(static_cast<size_t>(nc));
  std::vector<std::array<float, 3>> dys(static_cast<size_t>(nc));
  for (int k = 0; k < nc; ++k) cams0[size_t(k)] = lookup_camera(*cameras[size_t(k)], virt, dys[size_t(k)].data());
  for (int y = 0; y < VH; ++y) {
    const uint16_t* d = view_depth.ptr<uint16_t>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    float* z = row.z.data();
    for (int x = 0; x < VW; ++x) z[x] = m[x] ? float(d[x]) : 0.0f;
    for (int k = 0; k < nc; ++k) {
      LookupCamera c = cams0[size_t(k)];
      for (int j = 0; j < 3; ++j) c.b[j] += float(y) * dys[size_t(k)][size_t(j)];
      RowScratch& s = cam_rows[size_t(k)];
      project_row(VW, c, z, s.u.data(), s.v.data(), s.zc.data(), s.m2.data());
      for (int step = 0; step < p.refine_steps; ++step) {
        refine_row(VW, c, tol, z, s.u.data(), s.v.data(), s.zc.data(), s.m2.data(), s.z.data());
        project_row(VW, c, s.z.data(), s.u.data(), s.v.data(), s.zc.data(), s.m2.data());
      }
      if (p.packed) {
        cells_row(VW, c, tol, s.u.data(), s.v.data(), s.zc.data(), idx.data(), wq.data(), lohi.data());
        sample_packed_row(VW, cameras[size_t(k)]->packed.data(), c.W, idx.data(), wq.data(), lohi.data(),
                          sums[size_t(k)].data());
        continue;
      }
      sample_row(VW, c, tol, s.u.data(), s.v.data(), s.zc.data(), s.r.data(), s.g.data(), s.bl.data(), s.w.data(),
                 s.strict.data());
      if (!p.equal_weights)
        weigh_row(VW, c, float(y), p.refine_steps ? s.z.data() : z, s.u.data(), s.v.data(), s.zc.data(),
                  float(1 / virt.fx), float(1 / virt.fy), float(virt.cx), float(virt.cy), s.w.data());
    }
    if (p.packed) blend_packed_row(VW, nc, row, sums, color->ptr<uint8_t>(y), written ? written->ptr<uint8_t>(y) : nullptr);
    else blend_row(VW, nc, row, cam_rows, color->ptr<uint8_t>(y), p.best_only);
  }
  return 0;
}

}  // namespace vclassroom
