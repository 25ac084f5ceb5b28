// room_lookup() 8 view pixels at a time with AVX2 and FMA: the projection in 8 float lanes; the 2x2 around
// each position fetched as two 128-bit loads of the packed records (16-bit depth, r, g, b) and transposed to
// 16-bit lanes (top row | bottom row); the depth test, the strict coverage and the bilinear weights in 16-bit
// lanes (Q15, _mm256_mulhrs_epi16); colour x weight summed exactly (_mm256_madd_epi16); each camera's colour
// divided once in float and the cameras blended in float accumulators. Groups of 8 with no depth are skipped.
// A row is taken camera by camera, each in two passes over its groups: the projections, then the samples.
// It computes what lookup_row_portable() computes (room_lookup.cpp), in that order; the weights' square root
// is the CPU's approximate one.
#include <gst/vclassroom/vva/room_lookup.h>

#include <cstring>

#include <immintrin.h>

namespace vclassroom {
namespace room_lookup_detail {

#if defined(__GNUC__) && defined(__x86_64__)
#define VCLASSROOM_AVX2 __attribute__((target("avx2,fma")))

namespace {

// One camera for one view row, each constant broadcast once so that the loop reads it as a memory operand.
struct CamV {
  __m256 b[3], s[3], t[3];
  __m256 umax, vmax, uclamp, vclamp, wf;
  __m256 ccx, ccy, cifx, cify, base2, place;
  const uint64_t* rec;
  long W;
};

// Per pixel sum of c x w over a 2x2 (c0, c1: the left and right members, top row | bottom row; wl, wh: the
// weights interleaved as the colours are here), 8 pixels as floats.
VCLASSROOM_AVX2 inline __attribute__((always_inline)) __m256 weighted_sum(__m256i c0, __m256i c1, __m256i wl,
                                                                        __m256i wh) {
  const __m256i l = _mm256_madd_epi16(_mm256_unpacklo_epi16(c0, c1), wl),
                h = _mm256_madd_epi16(_mm256_unpackhi_epi16(c0, c1), wh);
  return _mm256_cvtepi32_ps(
      _mm256_add_epi32(_mm256_permute2x128_si256(l, h, 0x20), _mm256_permute2x128_si256(l, h, 0x31)));
}

// A camera's weight for 8 points (view_dist2: their squared distance from the view, mm^2; h2: their depth in the
// camera; u, v: where they land in it), as camera_sample() in room_lookup.cpp: the angle's and the distance's
// term, squared, times the view's place weight.
VCLASSROOM_AVX2 inline __attribute__((always_inline)) __m256 camera_weight(const CamV& c, __m256 view_dist2, __m256 h2,
                                                                         __m256 u, __m256 v) {
  const __m256 one = _mm256_set1_ps(1.0f), du = _mm256_mul_ps(_mm256_sub_ps(u, c.ccx), c.cifx),
               dv = _mm256_mul_ps(_mm256_sub_ps(v, c.ccy), c.cify);
  const __m256 cam_dist2 = _mm256_mul_ps(_mm256_mul_ps(h2, h2), _mm256_fmadd_ps(du, du, _mm256_fmadd_ps(dv, dv, one)));
  const __m256 iac = _mm256_rsqrt_ps(_mm256_max_ps(_mm256_mul_ps(view_dist2, cam_dist2), one));
  const __m256 cs = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_add_ps(view_dist2, cam_dist2), c.base2), iac),
                                  _mm256_set1_ps(0.5f));
  const __m256 cs2 = _mm256_mul_ps(cs, cs), cs4 = _mm256_mul_ps(cs2, cs2), cs8 = _mm256_mul_ps(cs4, cs4);
  const __m256 nearer = _mm256_min_ps(one, _mm256_mul_ps(view_dist2, iac));
  const __m256 q = _mm256_mul_ps(_mm256_max_ps(cs8, _mm256_set1_ps(0.02f)), nearer);
  return _mm256_mul_ps(c.place, _mm256_mul_ps(q, q));
}

// A camera's 2x2 around 8 positions: the records from the indices in `ii` (stored, 32-byte aligned) and the row
// below, `lw` the depths that agree (lo | width, 16-bit lanes), `fq` the bilinear fractions in Q15 (u | v).
struct Sample8 {
  __m256 r, g, b;     // colour x bilinear weight over the members that agree
  __m256 w;           // their bilinear weight
  __m256 not_strict;  // all bits where a member that disagrees takes part in the sample
};

VCLASSROOM_AVX2 inline __attribute__((always_inline)) Sample8 sample_2x2(const CamV& c, const int32_t* ii, __m256i lw,
                                                                       __m256i fq) {
  const __m256i ONE = _mm256_set1_epi16(32767), TH = _mm256_set1_epi16(655), Z = _mm256_setzero_si256();
  const __m256i LO = _mm256_permute4x64_epi64(lw, 0x88), WD = _mm256_permute4x64_epi64(lw, 0xDD);
  const __m256i FX = _mm256_permute4x64_epi64(fq, 0x88), FY = _mm256_permute4x64_epi64(fq, 0xDD);
  const __m256i X0 = _mm256_sub_epi16(ONE, FX), Y = _mm256_blend_epi32(_mm256_sub_epi16(ONE, FY), FY, 0xF0);
  const __m256i W0 = _mm256_mulhrs_epi16(X0, Y), W1 = _mm256_mulhrs_epi16(FX, Y);
  // The 2x2s: per pixel [t00 t01 | t10 t11], 4 x 16 bits each, transposed to (texel, channel) x pixel.
  // The indices from memory (project_groups stored them a pass before): a load per pixel that addresses both
  // rows.
  const uint64_t *R = c.rec, *RW = c.rec + c.W;
  __m256i p[8];
  for (int j = 0; j < 8; ++j) {
    const long i = ii[j];
    p[j] = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(R + i))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(RW + i)), 1);
  }
  const __m256i a_0 = _mm256_unpacklo_epi16(p[0], p[1]), a_1 = _mm256_unpackhi_epi16(p[0], p[1]),
                a_2 = _mm256_unpacklo_epi16(p[2], p[3]), a_3 = _mm256_unpackhi_epi16(p[2], p[3]),
                a_4 = _mm256_unpacklo_epi16(p[4], p[5]), a_5 = _mm256_unpackhi_epi16(p[4], p[5]),
                a_6 = _mm256_unpacklo_epi16(p[6], p[7]), a_7 = _mm256_unpackhi_epi16(p[6], p[7]);
  const __m256i b_0 = _mm256_unpacklo_epi32(a_0, a_2), b_1 = _mm256_unpackhi_epi32(a_0, a_2),
                b_2 = _mm256_unpacklo_epi32(a_1, a_3), b_3 = _mm256_unpackhi_epi32(a_1, a_3),
                b_4 = _mm256_unpacklo_epi32(a_4, a_6), b_5 = _mm256_unpackhi_epi32(a_4, a_6),
                b_6 = _mm256_unpacklo_epi32(a_5, a_7), b_7 = _mm256_unpackhi_epi32(a_5, a_7);
  const __m256i D0 = _mm256_unpacklo_epi64(b_0, b_4), R0 = _mm256_unpackhi_epi64(b_0, b_4),
                G0 = _mm256_unpacklo_epi64(b_1, b_5), B0 = _mm256_unpackhi_epi64(b_1, b_5),
                D1 = _mm256_unpacklo_epi64(b_2, b_6), R1 = _mm256_unpackhi_epi64(b_2, b_6),
                G1 = _mm256_unpacklo_epi64(b_3, b_7), B1 = _mm256_unpackhi_epi64(b_3, b_7);
  const __m256i ok0 = _mm256_cmpeq_epi16(_mm256_subs_epu16(_mm256_sub_epi16(D0, LO), WD), Z),
                ok1 = _mm256_cmpeq_epi16(_mm256_subs_epu16(_mm256_sub_epi16(D1, LO), WD), Z);
  // Strict: each member that disagrees has a bilinear weight factor of at most 1/50 (room_lookup.h).
  const __m256i out = _mm256_or_si256(_mm256_andnot_si256(ok0, _mm256_cmpgt_epi16(_mm256_min_epi16(X0, Y), TH)),
                                      _mm256_andnot_si256(ok1, _mm256_cmpgt_epi16(_mm256_min_epi16(FX, Y), TH)));
  const __m256 not_strict = _mm256_castsi256_ps(_mm256_cvtepi16_epi32(
      _mm_or_si128(_mm256_castsi256_si128(out), _mm256_extracti128_si256(out, 1))));
  const __m256i w0 = _mm256_and_si256(W0, ok0), w1 = _mm256_and_si256(W1, ok1);
  // Colour x weight summed exactly in 32 bits: t0 and t1 of a row paired for _mm256_madd_epi16 (lanes:
  // pixels 0-3 top | 0-3 bottom, and 4-7), then the rows added.
  const __m256i SW = _mm256_add_epi16(w0, w1);
  const __m256i wl = _mm256_unpacklo_epi16(w0, w1), wh = _mm256_unpackhi_epi16(w0, w1);
  const __m256 fw = _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(
      _mm_add_epi16(_mm256_castsi256_si128(SW), _mm256_extracti128_si256(SW, 1))));
  return Sample8{weighted_sum(R0, R1, wl, wh), weighted_sum(G0, G1, wl, wh), weighted_sum(B0, B1, wl, wh), fw,
                 not_strict};
}

// One row's groups of 8 view pixels with a depth, and what the cameras added to each so far.
struct alignas(32) RowGroup {
  float z[8], view_dist2[8];
  float sr[8], sg[8], sb[8], sn[8], seen_strictly[8];
  int x0;
  bool active;  // the camera at hand is looked at here (a far one only where no nearer one sees all strictly)
};
// What one camera's projection gave for a group: the 2x2's record indices, the depths that agree (lo | width),
// the bilinear fractions (Q15, u | v), where the point lands in the camera and the camera's weight there.
struct alignas(32) Projected {
  int32_t idx[8];
  __m256i lw, fq;
  __m256 in, weight;
};

// The camera's projection of the active groups (the first pass over a row): their work is independent, so the
// CPU overlaps the groups' divisions and conversions, where one group's chain from its depth to its records'
// indices (a division, conversions, the indices through memory) held up its gathers.
VCLASSROOM_AVX2 void project_groups(const CamV& c, const LookupView& view, const RowGroup* groups, int n,
                                    Projected* out) {
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), mhalf = _mm256_set1_ps(-0.5f),
               near = _mm256_set1_ps(50.0f), q15 = _mm256_set1_ps(32767.0f), mm = _mm256_set1_ps(view.tol_mm),
               k1 = _mm256_set1_ps(1.0f / (1.0f + view.tol_ratio)), k2 = _mm256_set1_ps(1.0f + view.tol_ratio);
  for (int g = 0; g < n; ++g) {
    const RowGroup& rg = groups[g];
    if (!rg.active) continue;
    const __m256 z = _mm256_load_ps(rg.z), view_dist2 = _mm256_load_ps(rg.view_dist2);
    const __m256 xv = _mm256_add_ps(_mm256_set1_ps(float(rg.x0)), _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256 a0 = _mm256_fmadd_ps(xv, c.s[0], c.b[0]), a1 = _mm256_fmadd_ps(xv, c.s[1], c.b[1]),
                 a2 = _mm256_fmadd_ps(xv, c.s[2], c.b[2]);
    const __m256 h0 = _mm256_fmadd_ps(z, a0, c.t[0]), h1 = _mm256_fmadd_ps(z, a1, c.t[1]),
                 h2 = _mm256_fmadd_ps(z, a2, c.t[2]);
    const __m256 ih = _mm256_div_ps(one, _mm256_max_ps(h2, one));
    const __m256 u = _mm256_mul_ps(h0, ih), v = _mm256_mul_ps(h1, ih);
    const __m256 in = _mm256_and_ps(
        _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(u, mhalf, _CMP_GE_OQ), _mm256_cmp_ps(v, mhalf, _CMP_GE_OQ)),
                      _mm256_and_ps(_mm256_cmp_ps(u, c.umax, _CMP_LE_OQ), _mm256_cmp_ps(v, c.vmax, _CMP_LE_OQ))),
        _mm256_cmp_ps(h2, near, _CMP_GE_OQ));
    const __m256 uc = _mm256_min_ps(_mm256_max_ps(u, zero), c.uclamp),
                 vc = _mm256_min_ps(_mm256_max_ps(v, zero), c.vclamp);
    const __m256 fu = _mm256_round_ps(uc, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC),
                 fv = _mm256_round_ps(vc, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    Projected& p = out[g];
    const __m256i idx = _mm256_cvttps_epi32(_mm256_fmadd_ps(fv, c.wf, fu));
    _mm256_store_si256(reinterpret_cast<__m256i*>(p.idx), idx);
    // The records the samples will read, on their way to the cache while the rest of the row is projected: the
    // first and last pixel's, both rows (a group's 2x2s lie along a few cache lines of each).
    const long first = _mm256_cvtsi256_si32(idx), last = _mm_extract_epi32(_mm256_extracti128_si256(idx, 1), 3);
    for (const long i : {first, last}) {
      _mm_prefetch(reinterpret_cast<const char*>(c.rec + i), _MM_HINT_T0);
      _mm_prefetch(reinterpret_cast<const char*>(c.rec + c.W + i), _MM_HINT_T0);
    }
    // The depths that agree with h2: lo .. lo + width (integer mm).
    const __m256 lo = _mm256_min_ps(_mm256_sub_ps(h2, mm), _mm256_mul_ps(h2, k1)),
                 hi = _mm256_max_ps(_mm256_add_ps(h2, mm), _mm256_mul_ps(h2, k2));
    const __m256i loi = _mm256_cvttps_epi32(_mm256_round_ps(lo, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
    p.lw = _mm256_packus_epi32(loi, _mm256_sub_epi32(_mm256_cvttps_epi32(hi), loi));
    // Bilinear fractions in Q15.
    p.fq = _mm256_packus_epi32(_mm256_cvtps_epi32(_mm256_mul_ps(_mm256_sub_ps(uc, fu), q15)),
                               _mm256_cvtps_epi32(_mm256_mul_ps(_mm256_sub_ps(vc, fv), q15)));
    p.in = in;
    p.weight = camera_weight(c, view_dist2, h2, u, v);
  }
}

// The camera's samples of the active groups added to their sums (the second pass over a row).
VCLASSROOM_AVX2 void add_samples(const CamV& c, bool far, RowGroup* groups, int n, Projected* projected) {
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), only_seen = _mm256_set1_ps(1.0f / 65536.0f);
  for (int g = 0; g < n; ++g) {
    RowGroup& rg = groups[g];
    if (!rg.active) continue;
    Projected& p = projected[g];
    const Sample8 sample = sample_2x2(c, p.idx, p.lw, p.fq);
    const __m256 fr = sample.r, fg = sample.g, fb = sample.b, fw = sample.w, strict_keep = sample.not_strict;
    const __m256 seen = _mm256_and_ps(p.in, _mm256_cmp_ps(fw, zero, _CMP_GT_OQ));
    const __m256 strict = _mm256_andnot_ps(strict_keep, seen);
    // The camera's weight where it sees the point strictly, 2^-16 of it where it only sees it (so the strict
    // cameras decide where there are any); its colour sums divided by their bilinear weight.
    // Masked after the product: where the camera does not see the point its weight may be infinite (a point
    // behind it), and 0 x inf is NaN.
    __m256 wt = _mm256_and_ps(seen, _mm256_mul_ps(_mm256_blendv_ps(only_seen, one, strict), p.weight));
    const __m256 seen_strictly = _mm256_load_ps(rg.seen_strictly);
    if (far) wt = _mm256_andnot_ps(seen_strictly, wt);
    _mm256_store_ps(rg.seen_strictly, _mm256_or_ps(seen_strictly, strict));
    const __m256 kw = _mm256_div_ps(wt, _mm256_max_ps(fw, one));
    _mm256_store_ps(rg.sr, _mm256_fmadd_ps(fr, kw, _mm256_load_ps(rg.sr)));
    _mm256_store_ps(rg.sg, _mm256_fmadd_ps(fg, kw, _mm256_load_ps(rg.sg)));
    _mm256_store_ps(rg.sb, _mm256_fmadd_ps(fb, kw, _mm256_load_ps(rg.sb)));
    _mm256_store_ps(rg.sn, _mm256_add_ps(_mm256_load_ps(rg.sn), wt));
  }
}

// The blended colour of a row's groups written where a camera sees the point, black elsewhere.
VCLASSROOM_AVX2 void write_groups(const RowGroup* groups, int n, uint8_t* out, uint8_t* out_written) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f),
               c255 = _mm256_set1_ps(255.0f), tiny = _mm256_set1_ps(1e-30f);
  const __m256i pick = _mm256_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1, 0, 1, 2, 4, 5, 6, 8,
                                        9, 10, 12, 13, 14, -1, -1, -1, -1);
  for (int g = 0; g < n; ++g) {
    const RowGroup& rg = groups[g];
    const int x0 = rg.x0;
    const __m256 sn = _mm256_load_ps(rg.sn);
    const __m256 write =
        _mm256_and_ps(_mm256_cmp_ps(sn, zero, _CMP_GT_OQ), _mm256_cmp_ps(_mm256_load_ps(rg.z), zero, _CMP_NEQ_OQ));
    const int wm = _mm256_movemask_ps(write);
    for (int j = 0; j < 8; ++j) out_written[x0 + j] = uint8_t((wm >> j & 1) * 255);
    uint8_t* o = out + 3 * x0;
    if (!wm) {
      std::memset(o, 0, 24);
      continue;
    }
    const __m256 in_ = _mm256_div_ps(one, _mm256_max_ps(sn, tiny));
    const __m256i r = _mm256_cvttps_epi32(_mm256_min_ps(c255, _mm256_fmadd_ps(_mm256_load_ps(rg.sr), in_, half))),
                  g8 = _mm256_cvttps_epi32(_mm256_min_ps(c255, _mm256_fmadd_ps(_mm256_load_ps(rg.sg), in_, half))),
                  b = _mm256_cvttps_epi32(_mm256_min_ps(c255, _mm256_fmadd_ps(_mm256_load_ps(rg.sb), in_, half)));
    const __m256i rgb = _mm256_and_si256(
        _mm256_castps_si256(write),
        _mm256_or_si256(r, _mm256_or_si256(_mm256_slli_epi32(g8, 8), _mm256_slli_epi32(b, 16))));
    const __m256i q = _mm256_shuffle_epi8(rgb, pick);
    const __m128i hi = _mm256_extracti128_si256(q, 1);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(o), _mm256_castsi256_si128(q));  // 12 + 4 overwritten next
    _mm_storel_epi64(reinterpret_cast<__m128i*>(o + 12), hi);
    const int last = _mm_extract_epi32(hi, 2);
    std::memcpy(o + 20, &last, 4);
  }
}

VCLASSROOM_AVX2 void lookup_rows(const std::vector<LookupCamera>& cf, const LookupView& view,
                                 const cv::Mat& view_depth, int y_begin, int y_end, cv::Mat* color, cv::Mat* written) {
  const int VW = view_depth.cols, nc = int(cf.size());
  CV_Assert(nc <= 8);
  CamV cams[8];  // on the stack: 32-byte aligned
  for (int k = 0; k < nc; ++k) {
    const LookupCamera& f = cf[size_t(k)];
    CamV& c = cams[k];
    for (int j = 0; j < 3; ++j) c.s[j] = _mm256_set1_ps(f.s[j]), c.t[j] = _mm256_set1_ps(f.t[j]);
    c.umax = _mm256_set1_ps(float(f.W) - 0.5f), c.vmax = _mm256_set1_ps(float(f.H) - 0.5f);
    c.uclamp = _mm256_set1_ps(float(f.W) - 1.001f), c.vclamp = _mm256_set1_ps(float(f.H) - 1.001f);
    c.wf = _mm256_set1_ps(float(f.W));
    c.ccx = _mm256_set1_ps(f.cx), c.ccy = _mm256_set1_ps(f.cy), c.cifx = _mm256_set1_ps(f.ifx);
    c.cify = _mm256_set1_ps(f.ify), c.base2 = _mm256_set1_ps(f.base2), c.place = _mm256_set1_ps(f.place);
    c.rec = f.rec, c.W = f.W;
  }
  const __m256 zero = _mm256_setzero_ps(), vcx = _mm256_set1_ps(view.cx), vifx = _mm256_set1_ps(view.ifx);
  // Over-aligned element types: C++17's allocator aligns them.
  std::vector<RowGroup> groups(size_t(VW / 8));
  std::vector<Projected> projected(groups.size());
  for (int y = y_begin; y < y_end; ++y) {
    for (int k = 0; k < nc; ++k)
      for (int j = 0; j < 3; ++j)
        cams[k].b[j] = _mm256_set1_ps(cf[size_t(k)].b[j] + float(y) * cf[size_t(k)].dy[j]);
    const float ry = (float(y) - view.cy) * view.ify;
    const __m256 ray_y2 = _mm256_set1_ps(1.0f + ry * ry);  // 1 + the view ray's y^2 (z = 1)
    const uint16_t* drow = view_depth.ptr<uint16_t>(y);
    uint8_t* out = color->ptr<uint8_t>(y);
    uint8_t* out_written = written->ptr<uint8_t>(y);
    int n = 0, x0 = 0;
    for (; x0 + 8 <= VW; x0 += 8) {
      const __m128i z16 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(drow + x0));
      if (_mm_testz_si128(z16, z16)) {  // no depth in these 8
        std::memset(out_written + x0, 0, 8);
        std::memset(out + 3 * x0, 0, 24);
        continue;
      }
      RowGroup& rg = groups[size_t(n++)];
      const __m256 z = _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(z16));
      const __m256 xv = _mm256_add_ps(_mm256_set1_ps(float(x0)), _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7));
      const __m256 rx = _mm256_mul_ps(_mm256_sub_ps(xv, vcx), vifx);
      _mm256_store_ps(rg.z, z);
      _mm256_store_ps(rg.view_dist2, _mm256_mul_ps(_mm256_mul_ps(z, z), _mm256_fmadd_ps(rx, rx, ray_y2)));
      for (float* sum : {rg.sr, rg.sg, rg.sb, rg.sn, rg.seen_strictly}) _mm256_store_ps(sum, zero);
      rg.x0 = x0;
      rg.active = true;
    }
    for (int k = 0; k < nc; ++k) {
      const bool far = k >= view.first_far_camera;
      if (far) {  // a far camera: not where a nearer one sees every point strictly (lookup_row_portable likewise)
        bool any = false;
        for (int g = 0; g < n; ++g) {
          RowGroup& rg = groups[size_t(g)];
          const __m256 wanted = _mm256_cmp_ps(_mm256_load_ps(rg.z), zero, _CMP_NEQ_OQ);
          rg.active = rg.active && _mm256_movemask_ps(_mm256_andnot_ps(_mm256_load_ps(rg.seen_strictly), wanted));
          any = any || rg.active;
        }
        if (!any) break;
      }
      project_groups(cams[k], view, groups.data(), n, projected.data());
      add_samples(cams[k], far, groups.data(), n, projected.data());
    }
    write_groups(groups.data(), n, out, out_written);
    lookup_row_portable(cf, view, y, x0, VW, drow, out, out_written);  // the row's last pixels
  }
}

// Four pixels' records: the colour (12 bytes of the 16 at `color`) and the depth (4 x 16 bits at `depth`) in
// place, 8 bytes a pixel: depth, r, g, b as 16-bit lanes.
VCLASSROOM_AVX2 inline __attribute__((always_inline)) __m256i four_records(const uint8_t* color,
                                                                           const uint16_t* depth) {
  // Within each 128-bit lane (pixels 0-1, 2-3) the bytes each record takes from the colour and the depth.
  const __m256i from_color = _mm256_setr_epi8(-1, -1, 0, -1, 1, -1, 2, -1, -1, -1, 3, -1, 4, -1, 5, -1,  //
                                              -1, -1, 6, -1, 7, -1, 8, -1, -1, -1, 9, -1, 10, -1, 11, -1);
  const __m256i from_depth = _mm256_setr_epi8(0, 1, -1, -1, -1, -1, -1, -1, 2, 3, -1, -1, -1, -1, -1, -1,  //
                                              4, 5, -1, -1, -1, -1, -1, -1, 6, 7, -1, -1, -1, -1, -1, -1);
  const __m256i c = _mm256_broadcastsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(color)));
  const __m256i d = _mm256_broadcastsi128_si256(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(depth)));
  return _mm256_or_si256(_mm256_shuffle_epi8(c, from_color), _mm256_shuffle_epi8(d, from_depth));
}

VCLASSROOM_AVX2 int records_avx2(int n, const uint16_t* depth, const uint8_t* label, const uint8_t* color,
                                 const uint16_t* room_depth, const uint8_t* room_color, uint64_t* out) {
  const __m256i zero = _mm256_setzero_si256(), depth_lane = _mm256_set1_epi64x(0xffff);
  int x = 0;
  for (; x + 6 <= n; x += 4) {  // 16 bytes of colour from pixel x stay within the row's 3n
    const __m256i live = four_records(color + 3 * x, depth + x);
    int32_t four_labels;
    std::memcpy(&four_labels, label + x, 4);
    const __m256i room_label = _mm256_cmpeq_epi64(_mm256_cvtepu8_epi64(_mm_cvtsi32_si128(four_labels)), zero);
    __m256i rec;
    if (room_depth) {  // the frame's room where it shows it, the memory's behind the learners
      const __m256i no_depth = _mm256_cmpeq_epi64(_mm256_and_si256(live, depth_lane), zero);
      const __m256i seen = _mm256_andnot_si256(no_depth, room_label);
      rec = _mm256_blendv_epi8(four_records(room_color + 3 * x, room_depth + x), live, seen);
    } else {  // the frame's colour everywhere, its depth where it shows the room
      rec = _mm256_andnot_si256(_mm256_andnot_si256(room_label, depth_lane), live);
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + x), rec);
  }
  return x;
}

}  // namespace

int room_records_avx2(int n, const uint16_t* depth, const uint8_t* label, const uint8_t* color,
                      const uint16_t* room_depth, const uint8_t* room_color, uint64_t* out) {
  if (!__builtin_cpu_supports("avx2")) return 0;
  return records_avx2(n, depth, label, color, room_depth, room_color, out);
}

bool lookup_avx2(const std::vector<LookupCamera>& cams, const LookupView& view, const cv::Mat& view_depth,
                 int y_begin, int y_end, cv::Mat* color, cv::Mat* written) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma") || cams.size() > 8) return false;
  lookup_rows(cams, view, view_depth, y_begin, y_end, color, written);
  return true;
}

#else
int room_records_avx2(int, const uint16_t*, const uint8_t*, const uint8_t*, const uint16_t*, const uint8_t*,
                      uint64_t*) {
  return 0;
}
bool lookup_avx2(const std::vector<LookupCamera>&, const LookupView&, const cv::Mat&, int, int, cv::Mat*, cv::Mat*) {
  return false;
}
#endif

}  // namespace room_lookup_detail
}  // namespace vclassroom
