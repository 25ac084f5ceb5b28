#include <gst/vclassroom/vva/view_warp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/simd.h>
#include <gst/vclassroom/vva/view_cull.h>
#include <gst/vclassroom/vva/warp_record.h>


namespace vclassroom {

using namespace warp_record;  // the record the warp draws

namespace {

constexpr float kRoomLayerWeight = 0.5f;  // the remembered room's quality against what a camera sees now
// Link flags: same surface as the right / lower neighbour. Several bits each,
// so that testing one is a compare, not a 1-bit cast GCC will not vectorise.
constexpr uint32_t kRight = 0x0f, kDown = 0xf0;


// Whether a warp with these settings skips what cannot land in the view (the cell warp only).
bool culls(const WarpParams& prm) { return prm.cull_outside_view && !prm.mesh; }
// Whether a warp draws the learners alone (WarpParams::learners_only; the mesh rasteriser draws whole frames
// only), as a sparse layer over its own spans.
bool learners_alone(const WarpParams& prm) { return prm.learners_only && !prm.mesh; }
// Whether a warp looks for the columns that can land in the view: one that culls and draws a whole layer (the
// learners' layer is drawn over its spans, not over those columns).
bool finds_view_columns(const WarpParams& prm) { return culls(prm) && !learners_alone(prm); }

bool same_intrinsics(const CameraCalib& a, const CameraCalib& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.distortion == b.distortion;
}

// Median of the live depth of each learner label, for learner pixels without depth.
void learner_median_depths(const uint16_t* depth, const uint8_t* label, int W, int H, uint16_t med[256]) {
  std::vector<std::vector<uint16_t>> samples(256);
  for (int y = 0; y < H; y += 2) {
    const uint16_t* d = depth + size_t(y) * W;
    const uint8_t* l = label + size_t(y) * W;
    for (int x = 0; x < W; x += 2) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
      if (x + 16 <= W) {  // most of a row is the room: 16 labels at a time
        uint64_t a, b;
        std::memcpy(&a, l + x, 8), std::memcpy(&b, l + x + 8, 8);
        if (!((a | b) & 0x00ff00ff00ff00ffull)) {  // the even pixels (the ones sampled) in the low bytes
          x += 14;
          continue;
        }
      }
#endif
      if (l[x] && d[x]) samples[l[x]].push_back(d[x]);
    }
  }
  for (int k = 0; k < 256; ++k) {
    auto& s = samples[k];
    if (s.empty()) {
      med[k] = 0;
      continue;
    }
    std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
    med[k] = s[s.size() / 2];
  }
}

// The per-pixel loops below are written branch-free so the compiler
// vectorises them; the loader picks the AVX-512 or AVX2 clone where the CPU
// has it (simd.h).

// Layered depth of one row: learners keep their live depth, the room takes
// its static depth where known.
VCLASSROOM_SIMD_CLONES
void layer_row(int n, const uint16_t* live, const uint16_t* stat, const uint8_t* lab, uint16_t* out) {
  for (int i = 0; i < n; ++i) {
    const uint16_t s = stat[i], d = live[i];
    out[i] = ((lab[i] == 0) & (s != 0)) ? s : d;
  }
}

// Whether a row has learner pixels without depth (most rows have none).
VCLASSROOM_SIMD_CLONES
bool has_learner_hole(int n, const uint8_t* lab, const uint16_t* depth) {
  int any = 0;
  for (int i = 0; i < n; ++i) any |= (lab[i] != 0) & (depth[i] == 0);
  return any != 0;
}

// A row's learner pixels without depth given their learner's median depth (`med`, by label), without a branch
// per pixel (most of a row is the room, and which pixels are holes is a toss for the branch predictor).
void fill_learner_holes(int n, const uint8_t* __restrict lab, const uint16_t* __restrict med,
                        uint16_t* __restrict depth) {
  for (int i = 0; i < n; ++i) {
    const uint16_t d = depth[i], m = med[lab[i]];
    depth[i] = (lab[i] != 0) & (d == 0) ? m : d;
  }
}

// Depth that comes in steps (a sensor's quantised disparity, an 8-bit
// disparity map) turns a slanted surface into a staircase of flat runs. A
// step larger than the link tolerance (WarpParams::edge_ratio) looks like a
// depth edge: its far side would be dropped, a view that opens it would leave
// a crack, and the wall behind would show through. A pixel with such a step
// within kStepRadius along the line - but no jump beyond the step tolerance
// (step_ratio) on the way, and no change of label - is averaged with the
// neighbours up to there: the staircase becomes the ramp it was measured
// from. A real edge, a jump beyond the step tolerance, ends the average on
// both its sides and stays sharp, and depth without such steps (smooth or
// noisy) is left as it is.
constexpr int kStepRadius = 3;

struct StepTolerance {
  uint16_t link_q16;  // a jump beyond max(min_mm, this * depth) breaks the warp's links
  uint16_t step_q16;  // ... beyond max(min_mm, this * depth) is a real edge
  uint16_t min_mm;
};

// WarpParams' tolerances as the integer row passes take them: a ratio in
// 1/65536 steps (rounded up, so the tolerance is never narrower than asked)
// and a floor in whole mm.
inline uint16_t tolerance_ratio_q16(double ratio) {
  return uint16_t(std::clamp(std::ceil(ratio * 65536.0), 0.0, 65535.0));
}
inline uint16_t tolerance_min_mm(double min_mm) { return uint16_t(std::clamp(std::floor(min_mm), 0.0, 65535.0)); }

// WarpParams::edge_to_near's colour test: a far-side pixel moves with the
// object when at least this share of its colour is the object's (measured
// up to kObjectInside px into the object and kBackgroundOut px out into the
// background); colours closer than sqrt(kAlikeColours) cannot tell. 0.05
// keeps the rims Middlebury Art needs (offset 1: 32.69 dB; the test at 0.3:
// 31.98) and leaves the synthetic classroom's background alone (Table I
// 24.76 dB; every far-side pixel moved: 24.34); docs/vva.md.
constexpr float kMinObjectShare = 0.05f, kAlikeColours = 100.0f;
constexpr int kObjectInside = 3, kBackgroundOut = 2;

inline int relative_tolerance(int depth_mm, uint16_t ratio_q16, uint16_t min_mm) {
  const int rel = int((uint32_t(depth_mm) * ratio_q16) >> 16);
  return rel > min_mm ? rel : min_mm;
}

// What lies between pixels i and i + stride of a line.
constexpr uint8_t kSameSurface = 0, kStep = 1, kBreak = 2;  // kBreak: a real edge, a label change, no depth

VCLASSROOM_SIMD_CLONES
void step_codes(size_t n, ptrdiff_t stride, const uint16_t* __restrict d, const uint8_t* __restrict lab,
                StepTolerance tol, uint8_t* __restrict code) {
  for (size_t i = 0; i < n; ++i) {
    const int a = d[i], b = d[i + stride];
    const int jump = a > b ? a - b : b - a, nearer = a < b ? a : b;
    const bool broken = (a == 0) | (b == 0) | (lab[i] != lab[i + stride]) |
                        (jump > relative_tolerance(nearer, tol.step_q16, tol.min_mm));
    const bool step = jump > relative_tolerance(nearer, tol.link_q16, tol.min_mm);
    code[i] = broken ? kBreak : step ? kStep : kSameSurface;
  }
}

// Pixels i = 0..n-1 of a line, `stride` apart, all of whose kStepRadius
// neighbours on both sides exist; code[i] is step_codes' for the pair
// (i, i + stride).
VCLASSROOM_SIMD_CLONES
void smooth_steps(int n, ptrdiff_t stride, const uint16_t* __restrict d, const uint8_t* __restrict code,
                  uint16_t* __restrict out) {
  for (int i = 0; i < n; ++i) {
    const int c = d[i];
    int sum = c, count = 1;
    bool on_before = true, on_after = true, stepped = false;
    for (int k = 1; k <= kStepRadius; ++k) {
      const ptrdiff_t before = i - k * stride, after = i + k * stride;
      const uint8_t cb = code[before], ca = code[after - stride];
      // Every neighbour exists (see above): loaded whatever the selects decide, so the loop vectorises
      // (a load on one side of a condition kept it scalar).
      const int db = d[before], da = d[after];
      on_before = on_before & (cb != kBreak);
      on_after = on_after & (ca != kBreak);
      stepped = stepped | (on_before & (cb == kStep)) | (on_after & (ca == kStep));
      sum += (on_before ? db : 0) + (on_after ? da : 0);
      count += (on_before ? 1 : 0) + (on_after ? 1 : 0);
    }
    out[i] = stepped ? uint16_t(float(sum) / float(count) + 0.5f) : uint16_t(c);
  }
}

// The same for pixel `pos` of a line of `len` pixels, near its ends (the
// neighbours beyond them left out).
uint16_t smooth_steps_near_end(int pos, int len, ptrdiff_t stride, const uint16_t* d, const uint8_t* code) {
  const int c = d[pos * stride];
  int sum = c, count = 1;
  bool stepped = false;
  for (int dir : {-1, 1})
    for (int k = 1; k <= kStepRadius; ++k) {
      const int q = pos + dir * k;
      if (q < 0 || q >= len) break;
      const uint8_t between = code[(dir < 0 ? q : q - 1) * stride];
      if (between == kBreak) break;
      stepped = stepped || between == kStep;
      sum += d[q * stride];
      count += 1;
    }
  return stepped ? uint16_t(float(sum) / float(count) + 0.5f) : uint16_t(c);
}

// Steps are few: the lines are smoothed in chunks of this many pixels, and a
// chunk with no step within kStepRadius of it is copied.
constexpr int kStepChunk = 64;

// A step p1 -> p2 along a line is a depth edge when it is large and much
// larger than the steps beside it (a slanted surface has steps too, but even
// ones). code[i] = 1: the far side is i; 2: the far side is i + stride.
VCLASSROOM_SIMD_CLONES
void depth_edges(int n, const uint16_t* d, ptrdiff_t stride, uint16_t ratio_q16, uint16_t min_mm, uint8_t* code) {
  // In 16-bit lanes throughout (twice as many per vector as 32-bit ones):
  // differences are exact in unsigned 16 bits, 3 * side saturates, and the
  // relative threshold is a high-half multiply.
  for (int i = 0; i < n; ++i) {
    const uint16_t p0 = d[i - stride], p1 = d[i], p2 = d[i + stride], p3 = d[i + 2 * stride];
    const uint16_t step = uint16_t(p2 > p1 ? p2 - p1 : p1 - p2);
    const uint16_t s0 = p0 ? uint16_t(p1 > p0 ? p1 - p0 : p0 - p1) : uint16_t(0);
    const uint16_t s3 = p3 ? uint16_t(p3 > p2 ? p3 - p2 : p2 - p3) : uint16_t(0);
    const uint16_t side = s0 > s3 ? s0 : s3;
    const uint16_t side3 = uint16_t(side > 21845 ? 65535 : 3 * side);
    const uint16_t nearer = p1 < p2 ? p1 : p2;
    const uint16_t rel = uint16_t((uint32_t(nearer) * ratio_q16) >> 16);
    const uint16_t lim = rel > min_mm ? rel : min_mm;
    const bool edge = (p1 != 0) & (p2 != 0) & (step > lim) & (step > side3);
    code[i] = edge ? (p1 > p2 ? 1 : 2) : 0;
  }
}

// Marks, for the depth edges in `code` (depth_edges), the pixel k steps
// beyond the far side: code 1 at j drops j - k*stride, code 2 at j drops
// j + (k + 1)*stride. `count` pixels along the line, `stride` apart.
VCLASSROOM_SIMD_CLONES
void mark_far_side(int count, int k, ptrdiff_t stride, const uint8_t* __restrict code, uint8_t* __restrict drop) {
  const size_t n = size_t(count) * stride, near = size_t(k) * stride, far = size_t(k + 1) * stride;
  for (size_t i = 0; i + near < n; ++i) drop[i] |= code[i + near] == 1;
  for (size_t i = far; i < n; ++i) drop[i] |= code[i - far] == 2;
}

VCLASSROOM_SIMD_CLONES
void clear_dropped(size_t n, const uint8_t* __restrict drop, uint16_t* __restrict depth) {
  for (size_t i = 0; i < n; ++i) depth[i] = drop[i] ? 0 : depth[i];
}

struct Projection {
  float r[9], t[3];  // source camera -> virtual camera
  float fx, fy, cx, cy;
  float link_scale;  // virtual / source focal length
  float link_gap;    // px
};

// One point of project_points.
VCLASSROOM_SIMD_INLINE void project_point(size_t i, const uint16_t* zmm, const float* ray_x, const float* ray_y,
                                          const Projection& p, float* __restrict px, float* __restrict py,
                                          float* __restrict pz, float* __restrict plim, float* __restrict pw) {
  const float z = float(zmm[i]) * 0.001f;
  const float X = ray_x[i] * z, Y = ray_y[i] * z;
  const float qx = p.r[0] * X + p.r[1] * Y + p.r[2] * z + p.t[0];
  const float qy = p.r[3] * X + p.r[4] * Y + p.r[5] * z + p.t[1];
  const float qz = p.r[6] * X + p.r[7] * Y + p.r[8] * z + p.t[2];
  const bool valid = (zmm[i] != 0) & (qz >= kNear);
  const float dx = qx - p.t[0], dy = qy - p.t[1], dz = qz - p.t[2];  // from the source centre
  const float nq2 = qx * qx + qy * qy + qz * qz, nd2 = std::max(dx * dx + dy * dy + dz * dz, 1e-12f);
  // |q| |d|, and one division for both 1 / qz and 1 / (|q| |d|): division
  // and square root are what this loop waits on.
  const float qd = valid ? std::sqrt(nq2 * nd2) : 1.0f, vz = valid ? qz : 1.0f;
  const float r = 1.0f / (vz * qd);
  const float iz = qd * r, iqd = vz * r;
  px[i] = p.fx * qx * iz + p.cx;
  py[i] = p.fy * qy * iz + p.cy;
  pz[i] = valid ? qz : 0.0f;
  plim[i] = p.link_scale * z * iz + p.link_gap;
  const float c = (qx * dx + qy * dy + qz * dz) * iqd;
  const float c2 = c * c, c4 = c2 * c2, c8 = c4 * c4;
  const float nearer = std::min(1.0f, nq2 * iqd);  // |q| / |d|
  pw[i] = std::max(0.02f, c8) * nearer;
}

// Points in blocks of this many: a block is one loop the compiler unrolls into whole vectors, so a short run
// (a learner's span: tens of pixels) is not left to a scalar remainder of up to 31 points, as one loop over
// the run was (its vector step is 32 points wide with AVX-512).
constexpr size_t kProjectBlock = 16;

// Every source pixel into the virtual camera: position, depth (0 = not
// drawn), the longest a one-pixel mesh edge may grow before it counts as
// torn, and the camera's quality for the point: cos^8 of the angle between
// its ray and the virtual ray (10° -> 0.89, 30° -> 0.32), times how much
// nearer the virtual camera is.
VCLASSROOM_SIMD_CLONES
void project_points(size_t n, const uint16_t* zmm, const float* ray_x, const float* ray_y,
                    const Projection& projection, float* __restrict px, float* __restrict py, float* __restrict pz,
                    float* __restrict plim, float* __restrict pw) {
  const Projection p = projection;  // a local copy: the stores cannot change it
  size_t i0 = 0;
  for (; i0 + kProjectBlock <= n; i0 += kProjectBlock)
    for (size_t j = 0; j < kProjectBlock; ++j)
      project_point(i0 + j, zmm, ray_x, ray_y, p, px, py, pz, plim, pw);
  for (size_t i = i0; i < n; ++i) project_point(i, zmm, ray_x, ray_y, p, px, py, pz, plim, pw);
}

// flag on out[i] where pixels i and i + stride lie on the same surface: both
// drawn, same label, and either close in depth or not torn apart by the view
// (a slanted surface).
VCLASSROOM_SIMD_CLONES
void link_neighbours(size_t n, ptrdiff_t stride, const float* px, const float* py, const float* pz,
                     const float* plim, const uint8_t* lab, float ratio, float min_m, uint32_t flag, uint32_t* out) {
  for (size_t i = 0; i < n; ++i) {
    const float zi = pz[i], zj = pz[i + stride];
    const float dz = zi > zj ? zi - zj : zj - zi;
    const float close = std::max(min_m, ratio * std::min(zi, zj));
    const float dx = px[i] - px[i + stride], dy = py[i] - py[i + stride];
    const bool near_in_view = dx * dx + dy * dy <= plim[i] * plim[i];
    const bool same = (zi > 0) & (zj > 0) & (lab[i] == lab[i + stride]) & ((dz <= close) | near_in_view);
    out[i] |= same ? flag : 0;
  }
}

constexpr float kCell = 0.5f + 1e-3f;  // half a source pixel, and a hair to close cracks
constexpr float kEdge = 0.02f;          // how far a cell reaches past its centre towards a depth edge

// The cells of one source row, set up for the splat (see ViewWarper::warp).
// A cell whose projection covers at most 2x2 virtual pixels (the view does
// not magnify) is fully prepared here: which of the 2x2 candidates it covers
// and the source position of each, in remap fixed point. Others are marked
// kBigCell and handled one by one.
constexpr int32_t kBigCell = 1 << 12;  // above every candidate mask
// A cell side that borders its surface's neighbour (or the image border)
// reaches half a pixel; towards a depth edge only kEdge.
constexpr int32_t kOpenRight = 1, kOpenLeft = 2, kOpenDown = 4, kOpenUp = 8;
struct CellRow {
  int32_t* x0;  // first candidate column / row
  int32_t* y0;
  int32_t* x1;     // last column / row of the bounding box (big cells)
  int32_t* y1;
  int32_t* sides;  // which sides reach a full half pixel: kOpen* bits (big cells)
  // 32-bit like everything else here: one byte-wide array would make the
  // compiler process 32 pixels per step and spill most of its registers.
  int32_t* mask;    // bit k: candidate (x0 + (k & 1), y0 + (k >> 1)) covered; or kBigCell; 0: not drawn
  int32_t* weight;  // 1..255
  float* su;  // source position of candidate 0 (unclamped)
  float* sv;
  float* dsu_dx;  // its change per virtual pixel to the right / down
  float* dsv_dx;
  float* dsu_dy;
  float* dsv_dy;
};

struct CellGeometry {
  int W, H, VW, VH;
  float max_area;
};

// The virtual pixels a cell centred at (x, y) reaching hx, hy may cover,
// clipped to the view; `drawable` false when that leaves none.
struct CellBox {
  int xmin, xmax, ymin, ymax;
  bool drawable;
};

inline CellBox cell_box(const CellGeometry& g, float x, float y, float hx, float hy) {
  const float VWf = float(g.VW), VHf = float(g.VH);
  const bool in_view = (x + hx >= 0) & (y + hy >= 0) & (x - hx <= VWf) & (y - hy <= VHf);
  // Clamped before the integer conversion: off-view points can be far out.
  const float xl = std::clamp(x - hx, -2.0f, VWf + 2), xh = std::clamp(x + hx, -2.0f, VWf + 2);
  const float yl = std::clamp(y - hy, -2.0f, VHf + 2), yh = std::clamp(y + hy, -2.0f, VHf + 2);
  CellBox b;
  b.xmin = std::max(0, fast_ceil(xl));
  b.xmax = std::min(g.VW - 1, fast_floor(xh));
  b.ymin = std::max(0, fast_ceil(yl));
  b.ymax = std::min(g.VH - 1, fast_floor(yh));
  b.drawable = in_view & (b.xmin <= b.xmax) & (b.ymin <= b.ymax);
  return b;
}

// px..links point at the row's first pixel; the arrays are padded by a row
// and a pixel on both sides, so the neighbours of border pixels can be read.
VCLASSROOM_SIMD_CLONES
void prepare_cells(const CellGeometry& g, int v, int u_begin, int u_end, const float* __restrict px,
                   const float* __restrict py, const float* __restrict pz, const float* __restrict pw,
                   const uint32_t* __restrict links, const uint32_t* __restrict links_up, const CellRow& out) {
  const int W = g.W, H = g.H;
  const float max_area = g.max_area;
  const float fv = float(v);
  const bool has_up = v > 0, has_down_border = v + 1 >= H, top = v == 0;
  int32_t* __restrict ox0 = out.x0;
  int32_t* __restrict oy0 = out.y0;
  int32_t *__restrict ox1 = out.x1, *__restrict oy1 = out.y1, *__restrict osides = out.sides;
  int32_t* __restrict omask = out.mask;
  int32_t* __restrict ow = out.weight;
  float *__restrict osu = out.su, *__restrict osv = out.sv, *__restrict oa00 = out.dsu_dx,
        *__restrict oa10 = out.dsv_dx, *__restrict oa01 = out.dsu_dy, *__restrict oa11 = out.dsv_dy;
  // The outputs are distinct arrays (GCC does not take __restrict on locals
  // as proof).
#pragma GCC ivdep
  for (int u = u_begin; u < u_end; ++u) {
    const float zi = pz[u], x = px[u], y = py[u];
    const bool right = (links[u] & kRight) != 0, down = (links[u] & kDown) != 0;
    const bool left = (u > 0) & ((links[u - 1] & kRight) != 0);
    const bool up = has_up & ((links_up[u] & kDown) != 0);
    const float rxu = px[u + 1] - x, ryu = py[u + 1] - y, lxu = x - px[u - 1], lyu = y - py[u - 1];
    const float dxv = px[u + W] - x, dyv = py[u + W] - y, uxv = x - px[u - W], uyv = y - py[u - W];
    const bool hu = right | left, hv = down | up;
    float jxu = right ? rxu : lxu, jyu = right ? ryu : lyu;
    float jxv = down ? dxv : uxv, jyv = down ? dyv : uyv;
    // A one-pixel-wide strip: assume a square cell.
    jxu = hu ? jxu : jyv;
    jyu = hu ? jyu : -jxv;
    jxv = hv ? jxv : -jyu;
    jyv = hv ? jyv : jxu;
    const float det = jxu * jyv - jxv * jyu;
    const float area = std::fabs(det);
    const float hx = kCell * (std::fabs(jxu) + std::fabs(jxv)), hy = kCell * (std::fabs(jyu) + std::fabs(jyv));
    const CellBox box = cell_box(g, x, y, hx, hy);
    const int xmin = box.xmin, xmax = box.xmax, ymin = box.ymin, ymax = box.ymax;
    const bool drawn = (zi > 0) & (hu | hv) & (area >= 1e-6f) & (area <= max_area) & box.drawable;
    const bool small = (xmax - xmin <= 1) & (ymax - ymin <= 1);
    // Towards a depth edge the cell ends at the pixel centre, like the mesh:
    // the surface is not known to go on beyond it.
    const bool open_right = right | (u + 1 >= W), open_left = left | (u == 0);
    const bool open_down = down | has_down_border, open_up = up | top;
    const float umax = open_right ? kCell : kEdge, umin = open_left ? -kCell : -kEdge;
    const float vmax = open_down ? kCell : kEdge, vmin = open_up ? -kCell : -kEdge;
    const float idet = 1.0f / (drawn ? det : 1.0f);
    const float a00 = jyv * idet, a01 = -jxv * idet, a10 = -jyu * idet, a11 = jxu * idet;
    const float dx0 = float(xmin) - x, dy0 = float(ymin) - y;
    const bool has_x1 = xmax > xmin, has_y1 = ymax > ymin;
    const float fu = float(u);
    int mask = 0;
    for (int k = 0; k < 4; ++k) {
      const float dx = dx0 + float(k & 1), dy = dy0 + float(k >> 1);
      const float du = a00 * dx + a01 * dy, dv = a10 * dx + a11 * dy;
      const bool exists = ((k & 1) == 0 || has_x1) & ((k >> 1) == 0 || has_y1);
      const bool inside = exists & (du <= umax) & (du >= umin) & (dv <= vmax) & (dv >= vmin);
      mask |= inside ? (1 << k) : 0;
    }
    osu[u] = fu + a00 * dx0 + a01 * dy0;
    osv[u] = fv + a10 * dx0 + a11 * dy0;
    oa00[u] = a00;
    oa10[u] = a10;
    oa01[u] = a01;
    oa11[u] = a11;
    omask[u] = drawn ? (small ? mask : kBigCell) : 0;
    ox0[u] = xmin;
    oy0[u] = ymin;
    ox1[u] = xmax;
    oy1[u] = ymax;
    osides[u] = (open_right ? kOpenRight : 0) | (open_left ? kOpenLeft : 0) | (open_down ? kOpenDown : 0) |
                (open_up ? kOpenUp : 0);
    const float w = pw[u] / std::sqrt(std::max(area, 1.0f));
    ow[u] = weight_lane(w);
  }
}


// A 2x2 block's cell: a source pixel and a hair on every side of the block's centre.
constexpr float kBlock = 1.0f + 1e-3f;
// Which of the 3x3 candidates a block cell covers: bit k is
// (x0 + k % 3, y0 + k / 3).
constexpr int kBlockCandidates = 9;
constexpr float kBlockKx[kBlockCandidates] = {0, 1, 2, 0, 1, 2, 0, 1, 2};
constexpr float kBlockKy[kBlockCandidates] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
// Runs of pixels without a block cell are set up in whole chunks of this
// many pixels (a multiple of every vector width), so that prepare_cells never
// ends in its scalar remainder loop; runs in the same or adjacent chunks are
// set up as one. The block pixels this adds are skipped in the splat.
constexpr int kRunChunk = 16;
// A layer drawn over column spans projects and links this many columns either side of each: a cell reads
// its neighbours' projections and links, and a 2x2 block the pixels after it.
constexpr int kSpanMargin = 2;
// How much the step to the next pixel may differ from the step within the
// block (px in the view) for the block to be one cell.
constexpr float kBlockBend = 0.5f;

// The 2x2 blocks (u, u + 1) x (v, v + 1), u = 2j, of a pair of source rows
// (v even): a block whose four pixels are linked to each other and to all
// their neighbours outside (one surface, no edge, not at the image border) is
// one cell of twice the size, mapped by the mean of the block's differences
// around the mean of its four points; out.sides[j] says which blocks are
// (their four pixels then get no cell of their own). The rest as
// prepare_cells, with out.z the block's depth in mm. Blocks j_begin..j_end - 1
// of the row's `blocks` are set up.
VCLASSROOM_SIMD_CLONES
void prepare_blocks(const CellGeometry& g, int v, int j_begin, int j_end, int blocks, const float* __restrict px,
                    const float* __restrict py,
                    const float* __restrict pz, const float* __restrict pw, const uint32_t* __restrict links,
                    const uint32_t* __restrict links_down, const uint32_t* __restrict links_up,
                    const CellRow& out, int32_t* __restrict oz, float max_u, float max_v,
                    int32_t* __restrict ofixed) {
  const int W = g.W;
  const float max_area = g.max_area;
  const float fv = float(v) + 0.5f;
  int32_t* __restrict ox0 = out.x0;
  int32_t* __restrict oy0 = out.y0;
  int32_t *__restrict ox1 = out.x1, *__restrict oy1 = out.y1, *__restrict ocoarse = out.sides;
  int32_t* __restrict omask = out.mask;
  int32_t* __restrict ow = out.weight;
  float *__restrict osu = out.su, *__restrict osv = out.sv, *__restrict oa00 = out.dsu_dx,
        *__restrict oa10 = out.dsv_dx, *__restrict oa01 = out.dsu_dy, *__restrict oa11 = out.dsv_dy;
#pragma GCC ivdep
  for (int j = j_begin; j < j_end; ++j) {
    const int u = 2 * j;
    const uint32_t inside_links = links[u] & links[u + 1] & links_down[u] & links_down[u + 1];
    const uint32_t from_left = links[u - 1] & links_down[u - 1], from_up = links_up[u] & links_up[u + 1];
    const bool linked = ((inside_links & kRight) != 0) & ((inside_links & kDown) != 0) &
                        ((from_left & kRight) != 0) & ((from_up & kDown) != 0);
    const float x00 = px[u], x10 = px[u + 1], x01 = px[u + W], x11 = px[u + W + 1];
    const float y00 = py[u], y10 = py[u + 1], y01 = py[u + W], y11 = py[u + W + 1];
    const float x = 0.25f * ((x00 + x10) + (x01 + x11)), y = 0.25f * ((y00 + y10) + (y01 + y11));
    const float jxu = 0.5f * ((x10 - x00) + (x11 - x01)), jyu = 0.5f * ((y10 - y00) + (y11 - y01));
    const float jxv = 0.5f * ((x01 - x00) + (x11 - x10)), jyv = 0.5f * ((y01 - y00) + (y11 - y10));
    // Smooth in the view too: the fine cells of the block's right column and
    // lower row reach towards the next pixels with the differences to them
    // (across a gap the view opens within a surface); the block's cell only
    // where those equal its own.
    const float x20 = px[u + 2], x21 = px[u + W + 2], x02 = px[u + 2 * W], x12 = px[u + 2 * W + 1];
    const float y20 = py[u + 2], y21 = py[u + W + 2], y02 = py[u + 2 * W], y12 = py[u + 2 * W + 1];
    // (Shorter is harmless: the cells overlap and the z-buffer keeps one.)
    auto l1 = [](float dx, float dy) { return std::fabs(dx) + std::fabs(dy); };
    const bool smooth = (l1(x20 - x10, y20 - y10) <= l1(x10 - x00, y10 - y00) + kBlockBend) &
                        (l1(x21 - x11, y21 - y11) <= l1(x11 - x01, y11 - y01) + kBlockBend) &
                        (l1(x02 - x01, y02 - y01) <= l1(x01 - x00, y01 - y00) + kBlockBend) &
                        (l1(x12 - x11, y12 - y11) <= l1(x11 - x10, y11 - y10) + kBlockBend);
    const bool coarse = linked & smooth;
    const float z00 = pz[u], z10 = pz[u + 1], z01 = pz[u + W], z11 = pz[u + W + 1];
    // The four's mean (their nearest gives the same figures to 0.01 dB).
    const float z = 0.25f * ((z00 + z10) + (z01 + z11));
    const float det = jxu * jyv - jxv * jyu;
    const float area = std::fabs(det);
    const float hx = kBlock * (std::fabs(jxu) + std::fabs(jxv)), hy = kBlock * (std::fabs(jyu) + std::fabs(jyv));
    const CellBox box = cell_box(g, x, y, hx, hy);
    const int xmin = box.xmin, xmax = box.xmax, ymin = box.ymin, ymax = box.ymax;
    const bool drawn = coarse & (area >= 1e-6f) & (area <= max_area) & box.drawable;
    const bool small = (xmax - xmin <= 2) & (ymax - ymin <= 2);
    const float idet = 1.0f / (drawn ? det : 1.0f);
    const float a00 = jyv * idet, a01 = -jxv * idet, a10 = -jyu * idet, a11 = jxu * idet;
    const float dx0 = float(xmin) - x, dy0 = float(ymin) - y;
    const float du0 = a00 * dx0 + a01 * dy0, dv0 = a10 * dx0 + a11 * dy0;
    osu[j] = float(u) + 0.5f + du0;
    osv[j] = fv + dv0;
    oa00[j] = a00;
    oa10[j] = a10;
    oa01[j] = a01;
    oa11[j] = a11;
    omask[j] = drawn ? (small ? -1 : kBigCell) : 0;  // -1: the candidates below
    ocoarse[j] = coarse ? 1 : 0;
    ox0[j] = xmin;
    oy0[j] = ymin;
    ox1[j] = xmax;
    oy1[j] = ymax;
    oz[j] = depth_mm_lane(z);
    const float pwm = 0.25f * ((pw[u] + pw[u + 1]) + (pw[u + W] + pw[u + W + 1]));
    const float w = pwm / std::sqrt(std::max(area, 1.0f));
    ow[j] = weight_lane(w);
  }
  // Which candidates each cell covers, in a second pass (one pass needs more
  // vector registers than there are).
#pragma GCC ivdep
  for (int j = j_begin; j < j_end; ++j) {
    const float du0 = osu[j] - (float(2 * j) + 0.5f), dv0 = osv[j] - fv;
    const float a00 = oa00[j], a10 = oa10[j], a01 = oa01[j], a11 = oa11[j];
    const int nx = ox1[j] - ox0[j], ny = oy1[j] - oy0[j];
    // The pre-image of candidate (kx, ky): that of candidate 0 plus kx and ky
    // steps (2 a = a + a exactly).
    const float dux[3] = {0.0f, a00, a00 + a00}, dvx[3] = {0.0f, a10, a10 + a10};
    const float duy[3] = {0.0f, a01, a01 + a01}, dvy[3] = {0.0f, a11, a11 + a11};
    int mask = 0;
    for (int k = 0; k < kBlockCandidates; ++k) {
      const int kx = k % 3, ky = k / 3;
      const float du = (du0 + duy[ky]) + dux[kx], dv = (dv0 + dvy[ky]) + dvx[kx];
      const bool exists = (kx <= nx) & (ky <= ny);
      const bool inside = exists & (std::fabs(du) <= kBlock) & (std::fabs(dv) <= kBlock);
      mask |= inside ? (1 << k) : 0;
    }
    const int32_t m = omask[j];
    omask[j] = m == -1 ? mask : m;
  }
  // Every candidate's source position in fixed point, u of candidate k of
  // block j at ofixed[k * blocks + j], v kBlockCandidates * blocks further:
  // here all in vectors, where the splat would convert them one by one.
  for (int k = 0; k < kBlockCandidates; ++k) {
    const float kx = kBlockKx[k], ky = kBlockKy[k];
    int32_t* __restrict ofu = ofixed + size_t(k) * blocks;
    int32_t* __restrict ofv = ofu + size_t(kBlockCandidates) * blocks;
#pragma GCC ivdep
    for (int j = j_begin; j < j_end; ++j) {
      ofu[j] = to_fixed(osu[j] + oa00[j] * kx + oa01[j] * ky, max_u);
      ofv[j] = to_fixed(osv[j] + oa10[j] * kx + oa11[j] * ky, max_v);
    }
  }
}

// Holes keep the initial record: colour, weight and label 0, depth "none".
// (The caller empties the records again: a store of Samples in this loop
// would keep it from vectorising.)
VCLASSROOM_SIMD_CLONES
void unpack_samples(int n, Sample* __restrict s, uint8_t* __restrict rgb, uint16_t* __restrict depth,
                    uint8_t* __restrict label, uint8_t* __restrict weight) {
  for (int i = 0; i < n; ++i) {
    depth[i] = s[i].z == kNoSample ? 0 : s[i].z;
    rgb[3 * i] = s[i].rgb[0];
    rgb[3 * i + 1] = s[i].rgb[1];
    rgb[3 * i + 2] = s[i].rgb[2];
    label[i] = s[i].label;
    weight[i] = s[i].weight;
  }
}

// A see-through crack: a virtual pixel the camera left empty, or where it
// shows something farther, between two pixels of one surface - left and
// right, or above and below, within the tolerance of each other. Cells of a
// surface whose projected spacing shrinks from one pixel to the next meet a
// little short of each other, and a virtual pixel centre can fall in between;
// there the wall behind the surface would win the z-buffer. The rows above and
// below are given; code[i] = 1: a crack across the row, 2: across the column.
VCLASSROOM_SIMD_CLONES
void find_cracks(int n, const uint16_t* __restrict above, const uint16_t* __restrict row,
                 const uint16_t* __restrict below, uint16_t ratio_q16, uint16_t min_mm, uint8_t* __restrict code) {
  for (int i = 0; i < n; ++i) {
    const int c = row[i], l = row[i - 1], r = row[i + 1], a = above[i], b = below[i];
    const int lr_far = l > r ? l : r, ab_far = a > b ? a : b;
    const int lr_diff = l > r ? l - r : r - l, ab_diff = a > b ? a - b : b - a;
    const int lr_tol = relative_tolerance(lr_far, ratio_q16, min_mm);
    const int ab_tol = relative_tolerance(ab_far, ratio_q16, min_mm);
    const bool across_row = (l != 0) & (r != 0) & (lr_diff <= lr_tol) & ((c == 0) | (c > lr_far + lr_tol));
    const bool across_column = (a != 0) & (b != 0) & (ab_diff <= ab_tol) & ((c == 0) | (c > ab_far + ab_tol));
    code[i] = across_row ? 1 : across_column ? 2 : 0;
  }
}

// WarpParams::learners_only: what goes forward is the learners (label non-zero), the room's pixels beside a
// learner, so that the cracks between a learner and the room around it close as in the full warp, and the
// pixels without a static depth, which the room's meshes (room_mesh.h) cannot draw. A surface one pixel thin
// (no pixel quad of the mesh holds it) is left to the mesh of the camera nearest the view (its edge quads'
// parts): warped forward from every camera, each camera's cell a pixel off from the others' at the view, it
// stood in front of the room around it (Table I 25.038 against 25.133 without, near camera 0 26.534 against
// 26.790, vclassroom-eval-views --room-view, 2026-11-28).
//
// One row: its labels and those of the rows above and below (the row itself at the image's border).
VCLASSROOM_SIMD_CLONES
void forward_row(int n, const uint16_t* __restrict depth, const uint16_t* __restrict static_depth,
                 const uint8_t* __restrict label_above, const uint8_t* __restrict label,
                 const uint8_t* __restrict label_below, uint16_t* __restrict out) {
  for (int x = 1; x + 1 < n; ++x) {
    const bool learner_near = (label[x - 1] | label[x] | label[x + 1] | label_above[x] | label_below[x]) != 0;
    out[x] = learner_near || static_depth[x] == 0 ? depth[x] : 0;
  }
  for (const int x : {0, n - 1}) {  // the first and last pixel: a neighbour beyond the border is none
    if (x < 0) continue;
    const int left = x > 0 ? label[x - 1] : 0, right = x + 1 < n ? label[x + 1] : 0;
    const bool learner_near = (left | label[x] | right | label_above[x] | label_below[x]) != 0;
    out[x] = learner_near || static_depth[x] == 0 ? depth[x] : 0;
  }
}

void learner_depth_of(int W, int H, const uint16_t* depth, const uint8_t* label, const uint16_t* static_depth,
                      uint16_t* out) {
  if (!static_depth) {
    for (size_t i = 0, n = size_t(W) * H; i < n; ++i) out[i] = label[i] ? depth[i] : 0;
    return;
  }
  for (int y = 0; y < H; ++y) {
    const size_t o = size_t(y) * W;
    const uint8_t* label_above = y > 0 ? label + o - W : label + o;
    const uint8_t* label_below = y + 1 < H ? label + o + W : label + o;
    forward_row(W, depth + o, static_depth + o, label_above, label + o, label_below, out + o);
  }
}

VCLASSROOM_SIMD_CLONES
bool any_nonzero(size_t n, const uint16_t* d) {
  uint16_t any = 0;
  for (size_t i = 0; i < n; ++i) any |= d[i];
  return any != 0;
}

// Whether all n records are empty.
VCLASSROOM_SIMD_CLONES
bool all_empty(size_t n, const uint64_t* records) {
  uint64_t differ = 0;
  for (size_t i = 0; i < n; ++i) differ |= records[i] ^ kEmptyRecord;
  return differ == 0;
}

// The cracks of row y's pixels [cx0, cx1) (1 <= cx0, cx1 <= width - 1) closed: each pixel find_cracks marks
// takes the mean of the two pixels of the surface around it. `code`: scratch of the row's width.
void close_row_cracks(WarpedView* out, int y, int cx0, int cx1, uint16_t ratio_q16, uint16_t min_mm,
                      uint8_t* code) {
  const int W = out->depth.cols, H = out->depth.rows;
  uint16_t* const d = out->depth.ptr<uint16_t>(y);
  // The first and last rows have cracks across the row only: their own
  // row stands in for the missing one, which finds none across the column.
  const uint16_t* above = y > 0 ? out->depth.ptr<uint16_t>(y - 1) : d;
  const uint16_t* below = y + 1 < H ? out->depth.ptr<uint16_t>(y + 1) : d;
  find_cracks(cx1 - cx0, above + cx0, d + cx0, below + cx0, ratio_q16, min_mm, code + cx0);
  for (int x = cx0; x < cx1; ++x) {
    if (x + 8 < W) {  // most of a row holds no crack: 8 codes at a time
      uint64_t eight;
      std::memcpy(&eight, code + x, 8);
      if (!eight) {
        x += 7;
        continue;
      }
    }
    if (!code[x]) continue;
    const bool across_row = code[x] == 1;
    const int y0 = across_row ? y : y - 1, y1 = across_row ? y : y + 1;
    const int x0 = across_row ? x - 1 : x, x1 = across_row ? x + 1 : x;
    d[x] = uint16_t((out->depth.at<uint16_t>(y0, x0) + out->depth.at<uint16_t>(y1, x1) + 1) / 2);
    const cv::Vec3b c0 = out->color.at<cv::Vec3b>(y0, x0), c1 = out->color.at<cv::Vec3b>(y1, x1);
    cv::Vec3b& c = out->color.at<cv::Vec3b>(y, x);
    for (int ch = 0; ch < 3; ++ch) c[ch] = uint8_t((c0[ch] + c1[ch] + 1) / 2);
    out->weight.at<uint8_t>(y, x) = std::min(out->weight.at<uint8_t>(y0, x0), out->weight.at<uint8_t>(y1, x1));
    out->label.at<uint8_t>(y, x) = out->label.at<uint8_t>(y0, x0);
  }
}

// Closes the cracks find_cracks marks, row by row.
// `row_empty` (optional, per row): rows known to hold no depth; a row with its neighbours empty has no crack.
// `tiles` (optional): all depth lies in them, so every crack does too (it has a neighbour with depth in its
// own tile, the tiles being 2 px or more on a side).
void close_cracks(WarpedView* out, uint16_t ratio_q16, uint16_t min_mm, std::vector<uint8_t>* scratch,
                  const std::vector<uint8_t>* row_empty = nullptr, const SampleTiles* tiles = nullptr) {
  const int W = out->depth.cols, H = out->depth.rows;
  if (W < 3 || H < 3) return;
  scratch->assign(size_t(W), 0);
  uint8_t* const code = scratch->data();
  if (tiles) {
    for_each_tile_span(*tiles, H, [&](int y, int x0, int x1) {
      const int cx0 = std::max(1, x0), cx1 = std::min(W - 1, x1);
      if (cx0 < cx1) close_row_cracks(out, y, cx0, cx1, ratio_q16, min_mm, code);
    });
    return;
  }
  for (int y = 0; y < H; ++y) {
    if (row_empty && (*row_empty)[size_t(y)] && (y == 0 || (*row_empty)[size_t(y) - 1]) &&
        (y + 1 == H || (*row_empty)[size_t(y) + 1]))
      continue;
    close_row_cracks(out, y, 1, W - 1, ratio_q16, min_mm, code);
  }
}

}  // namespace

CameraCalib virtual_camera(const CameraCalib& base, const Eigen::Isometry3d& cam_to_rig, double fov_deg) {
  CameraCalib v = base;
  v.distortion = {0, 0, 0, 0, 0};
  v.depth_to_color.reset();
  v.cam_to_rig = cam_to_rig;
  if (std::isfinite(fov_deg) && fov_deg > 0 && fov_deg < 180) {
    v.fx = v.fy = 0.5 * v.width / std::tan(0.5 * fov_deg * M_PI / 180.0);
  }
  return v;
}

// A camera's rays (per pixel the normalised image point) and their boxes per tile (view_cull.h): one table per
// set of intrinsics, shared by every warper of that camera. A table per warper (one per camera and lecturer's
// view) kept a view's warps reading tables of 8 bytes a source pixel that the other views had pushed out of the
// cache.
struct ViewWarper::RayTable {
  CameraCalib intrinsics;
  std::vector<float> x, y, tile_boxes;
};

void ViewWarper::prepare_rays(const CameraCalib& src) {
  if (rays_ && same_intrinsics(rays_->intrinsics, src)) return;
  static std::mutex lock;
  static std::vector<std::weak_ptr<const RayTable>> tables;  // the tables in use
  auto in_use = [&]() -> std::shared_ptr<const RayTable> {
    tables.erase(std::remove_if(tables.begin(), tables.end(), [](const auto& t) { return t.expired(); }),
                 tables.end());
    for (const auto& t : tables) {
      std::shared_ptr<const RayTable> table = t.lock();
      if (table && same_intrinsics(table->intrinsics, src)) return table;
    }
    return nullptr;
  };
  {
    std::lock_guard<std::mutex> g(lock);
    rays_ = in_use();
    if (rays_) return;
  }
  // Made without the lock (a distorted camera's half a million rays), then shared unless another warper of
  // the camera made one meanwhile.
  auto table = std::make_shared<RayTable>();
  const size_t n = size_t(src.width) * src.height;
  table->intrinsics = src;
  table->x.resize(n);
  table->y.resize(n);
  for (int v = 0; v < src.height; ++v)
    for (int u = 0; u < src.width; ++u) {
      const Eigen::Vector2d r = src.has_distortion() ? src.normalized(u, v)
                                                     : Eigen::Vector2d((u - src.cx) / src.fx, (v - src.cy) / src.fy);
      table->x[size_t(v) * src.width + u] = float(r.x());
      table->y[size_t(v) * src.width + u] = float(r.y());
    }
  tile_ray_boxes(src.width, src.height, table->x.data(), table->y.data(), &table->tile_boxes);
  std::lock_guard<std::mutex> g(lock);
  rays_ = in_use();
  if (rays_) return;
  rays_ = table;
  tables.push_back(rays_);
}

void ViewWarper::smooth_stepped_depth(int W, int H, const WarpParams& prm) {
  const StepTolerance tol{tolerance_ratio_q16(prm.edge_ratio), tolerance_ratio_q16(prm.step_ratio),
                          tolerance_min_mm(prm.edge_min_mm)};
  const size_t n = size_t(W) * H;
  const int r = kStepRadius, chunks = (W + kStepChunk - 1) / kStepChunk;
  step_tmp_.resize(n);
  step_code_.resize(n);
  step_chunk_.resize(size_t(chunks) * H);
  uint16_t* const D = src_depth_.data();
  uint16_t* const T = step_tmp_.data();
  const uint8_t* const L = src_label_.data();
  uint8_t* const code = step_code_.data();
  uint8_t* const chunk_has_step = step_chunk_.data();
  auto has_step = [&](size_t from, size_t to) {
    return to > from && std::memchr(code + from, kStep, to - from) != nullptr;
  };
  // Along the rows, into T (a row's last pixel has no pair).
  step_codes(n - 1, 1, D, L, tol, code);
  for (int v = 0; v < H; ++v) code[size_t(v) * W + W - 1] = kBreak;
  for (int v = 0; v < H; ++v) {
    const size_t row = size_t(v) * W;
    for (int u0 = 0; u0 < W; u0 += kStepChunk) {
      const int u1 = std::min(W, u0 + kStepChunk);
      if (!has_step(row + size_t(std::max(0, u0 - r)), row + size_t(std::min(W - 1, u1 + r - 1)))) {
        std::memcpy(T + row + u0, D + row + u0, size_t(u1 - u0) * sizeof(uint16_t));
        continue;
      }
      const int inner0 = std::max(u0, r), inner1 = std::min(u1, W - r);
      if (inner1 > inner0) smooth_steps(inner1 - inner0, 1, D + row + inner0, code + row + inner0, T + row + inner0);
      for (int u = u0; u < u1; ++u)
        if (u < inner0 || u >= inner1) T[row + u] = smooth_steps_near_end(u, W, 1, D + row, code + row);
    }
  }
  // Along the columns, back into D; a chunk of a row is smoothed when the
  // rows within kStepRadius have a step there.
  const size_t last_row = n - size_t(W);
  step_codes(last_row, W, T, L, tol, code);
  std::fill(code + last_row, code + n, kBreak);
  for (int v = 0; v < H; ++v)
    for (int c = 0; c < chunks; ++c) {
      const size_t from = size_t(v) * W + size_t(c) * kStepChunk;
      chunk_has_step[size_t(v) * chunks + c] = has_step(from, from + std::min(kStepChunk, W - c * kStepChunk));
    }
  for (int v = 0; v < H; ++v) {
    const size_t row = size_t(v) * W;
    for (int c = 0; c < chunks; ++c) {
      const int u0 = c * kStepChunk, u1 = std::min(W, u0 + kStepChunk);
      bool stepped = false;
      for (int w = std::max(0, v - r); w <= std::min(H - 1, v + r - 1) && !stepped; ++w)
        stepped = chunk_has_step[size_t(w) * chunks + c] != 0;
      if (!stepped) {
        std::memcpy(D + row + u0, T + row + u0, size_t(u1 - u0) * sizeof(uint16_t));
        continue;
      }
      if (v >= r && v < H - r) {
        smooth_steps(u1 - u0, W, T + row + u0, code + row + u0, D + row + u0);
      } else {
        for (int u = u0; u < u1; ++u) D[row + u] = smooth_steps_near_end(v, H, W, T + u, code + u);
      }
    }
  }
}

namespace {

VCLASSROOM_SIMD_CLONES
void minus_one(size_t n, const uint16_t* __restrict d, uint16_t* __restrict out) {
  for (size_t i = 0; i < n; ++i) out[i] = uint16_t(d[i] - 1);
}

// flag[i] = 1 where pixel i has depth and lies beyond the edge tolerance
// behind nearest_minus_one[i] + 1 (the tolerance taken at nearest_minus_one[i]),
// unless it is the static layer's (label 0 where `static_depth`, when kWithStatic, has a depth): those rims
// stay. In 16-bit lanes, as depth_edges: the sum saturates (no depth around: never). A loop of its own for
// each case: with the optional layer tested inside, the loop compiled to scalar code with branches.
template <bool kWithStatic>
VCLASSROOM_SIMD_INLINE void far_of_nearest_loop(size_t n, const uint16_t* __restrict d,
                                                const uint16_t* __restrict nearest_minus_one,
                                                const uint8_t* __restrict label,
                                                const uint16_t* __restrict static_depth, uint16_t ratio_q16,
                                                uint16_t min_mm, uint8_t* __restrict flag) {
  for (size_t i = 0; i < n; ++i) {
    const uint16_t near = nearest_minus_one[i], z = d[i];
    const uint16_t rel = uint16_t((uint32_t(near) * ratio_q16) >> 16);
    const uint16_t lim = rel > min_mm ? rel : min_mm;
    const uint32_t sum = uint32_t(near) + lim;
    const uint16_t reach = uint16_t(sum < 65535u ? sum : 65535u);
    uint8_t far = uint8_t((z != 0) & (reach < uint16_t(z - 1)));
    if constexpr (kWithStatic) far &= uint8_t((label[i] != 0) | (static_depth[i] == 0));
    flag[i] = far;
  }
}

VCLASSROOM_SIMD_CLONES
void far_of_nearest(size_t n, const uint16_t* d, const uint16_t* nearest_minus_one, const uint8_t* label,
                    const uint16_t* static_depth, uint16_t ratio_q16, uint16_t min_mm, uint8_t* flag) {
  if (static_depth)
    far_of_nearest_loop<true>(n, d, nearest_minus_one, label, static_depth, ratio_q16, min_mm, flag);
  else
    far_of_nearest_loop<false>(n, d, nearest_minus_one, label, nullptr, ratio_q16, min_mm, flag);
}

// The share of the object's colour in the pixel's: its colour projected on
// the line from the background's colour to the object's (1 when the two are
// too alike to tell).
float object_share(const uint8_t* pixel, const uint8_t* object, const uint8_t* background) {
  float along = 0, length2 = 0;
  for (int c = 0; c < 3; ++c) {
    const float span = float(object[c]) - float(background[c]);
    along += (float(pixel[c]) - float(background[c])) * span;
    length2 += span * span;
  }
  return length2 > kAlikeColours ? along / length2 : 1.0f;
}

}  // namespace

void ViewWarper::give_edges_to_near_side(int W, int H, const WarpParams& prm, const cv::Mat& color,
                                         const cv::Mat& static_depth) {
  // The nearest depth around each pixel, less 1: a 3x3 erosion of depth - 1,
  // where "no depth" wraps round to the farthest value.
  const size_t n = size_t(W) * H;
  nearest_around_.create(H, W, CV_16UC1);
  minus_one(n, src_depth_.data(), nearest_around_.ptr<uint16_t>());
  cv::erode(nearest_around_, nearest_around_, cv::Mat(), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
            cv::Scalar(65535));
  const uint16_t ratio = tolerance_ratio_q16(prm.edge_ratio), min_mm = tolerance_min_mm(prm.edge_min_mm);
  // The candidates first (few: the rims of objects), then their new depth
  // and label, so that every pixel is judged on the depths as they came.
  claim_flags_.resize(n + 8);
  std::fill(claim_flags_.end() - 8, claim_flags_.end(), 0);
  // The static layer's depth is the room model's, whose edges come from geometry fitted over many frames, not
  // from a sensor a pixel off the colour: its rims stay (moving them cost 0.13 dB on Table I).
  // (prepare_here checked its type and size; a part of a larger image is taken row by row.)
  const bool by_rows = !static_depth.empty() && !static_depth.isContinuous();
  for (size_t first = 0, count = by_rows ? size_t(W) : n; first < n; first += count)
    far_of_nearest(count, src_depth_.data() + first, nearest_around_.ptr<uint16_t>() + first,
                   src_label_.data() + first,
                   static_depth.empty() ? nullptr : static_depth.ptr<uint16_t>(int(first / W)) + first % W, ratio,
                   min_mm, claim_flags_.data() + first);
  edge_claims_.clear();
  for (size_t i = 0; i < n; i += 8) {
    uint64_t eight;
    std::memcpy(&eight, &claim_flags_[i], 8);
    if (!eight) continue;
    for (size_t j = i; j < std::min(n, i + 8); ++j)
      if (claim_flags_[j]) edge_claims_.push_back(EdgeClaim{int(j), 0});
  }
  size_t kept = 0;
  for (const EdgeClaim& claim : edge_claims_) {
    const int u = claim.pixel % W, v = claim.pixel / W;
    const uint16_t near = uint16_t(nearest_around_.ptr<uint16_t>(v)[u] + 1);
    // The neighbour on the near side: a nearest one, one beside the pixel
    // rather than across a corner.
    int nu = u, nv = v;
    for (int vv = std::max(0, v - 1); vv <= std::min(H - 1, v + 1); ++vv)
      for (int uu = std::max(0, u - 1); uu <= std::min(W - 1, u + 1); ++uu)
        if (src_depth_[size_t(vv) * W + uu] == near && ((nu == u && nv == v) || uu == u || vv == v))
          nu = uu, nv = vv;
    // Only a pixel that shows some of the object: its colour against the
    // object's (up to kObjectInside px inside it, past its own rim) and the
    // background's (up to kBackgroundOut px out, past a blurred edge), each
    // as far as its surface goes. Where the depth edge lies outside the
    // colour edge (a sensor that fattens objects) the pixel shows background
    // and stays.
    const int du = nu - u, dv = nv - v, z = src_depth_[size_t(claim.pixel)];
    auto walk = [&](int steps, int su, int sv, int z0, int* wu, int* wv) {
      for (int k = 0; k < steps; ++k) {
        const int tu = *wu + su, tv = *wv + sv;
        if (tu < 0 || tv < 0 || tu >= W || tv >= H) return;
        const int zt = src_depth_[size_t(tv) * W + tu];
        if (!zt || std::abs(zt - z0) > relative_tolerance(std::min(zt, z0), ratio, min_mm)) return;
        *wu = tu, *wv = tv;
      }
    };
    int ou = nu, ov = nv, bu = u, bv = v;
    walk(kObjectInside - 1, du, dv, near, &ou, &ov);
    walk(kBackgroundOut, -du, -dv, z, &bu, &bv);
    // (No background beyond it, a pixel between two edges: it goes.)
    if ((bu != u || bv != v) &&
        object_share(color.ptr<uint8_t>(v) + 3 * u, color.ptr<uint8_t>(ov) + 3 * ou,
                     color.ptr<uint8_t>(bv) + 3 * bu) < kMinObjectShare)
      continue;
    edge_claims_[kept++] = EdgeClaim{claim.pixel, src_label_[size_t(nv) * W + nu]};
  }
  edge_claims_.resize(kept);
  for (const EdgeClaim& claim : edge_claims_) {
    const uint16_t nearest_minus_one = nearest_around_.ptr<uint16_t>(claim.pixel / W)[claim.pixel % W];
    src_depth_[size_t(claim.pixel)] = uint16_t(nearest_minus_one + 1);
    src_label_[size_t(claim.pixel)] = claim.label;
  }
}

void ViewWarper::warp(const CameraCalib& src, const WarpSource& in, const CameraCalib& virt, const WarpParams& prm,
                      WarpedView* out) {
  prepare_here(src, in, prm);
  warp_prepared_here(src, in, src_depth_.data(), src_label_.data(), tile_nearest_, tile_farthest_, virt, prm, out);
}

void ViewWarper::prepare(const CameraCalib& src, const WarpSource& in, const WarpParams& prm, PreparedSource* out) {
  prepare_here(src, in, prm);
  out->width = src.width;
  out->height = src.height;
  out->depth.swap(src_depth_);  // the old ones are scratch for the next frame
  out->label.swap(src_label_);
  out->tile_nearest.swap(tile_nearest_);
  out->tile_farthest.swap(tile_farthest_);
  if (prm.learners_only) {
    out->learner_depth.resize(out->depth.size());
    const bool whole = !in.static_depth.empty() && in.static_depth.isContinuous() &&
                       in.static_depth.total() == out->depth.size() && in.static_depth.type() == CV_16UC1;
    learner_depth_of(src.width, src.height, out->depth.data(), out->label.data(),
                     whole ? in.static_depth.ptr<uint16_t>() : nullptr, out->learner_depth.data());
    find_sparse_rows(src.width, src.height, out->learner_depth.data(), &out->learner_rows);
  } else {  // none of an earlier frame's, which this one may reuse
    out->learner_depth.clear();
    out->learner_rows = SparseRows();
  }
}

void ViewWarper::warp_prepared(const CameraCalib& src, const WarpSource& in, const PreparedSource& prepared,
                               const CameraCalib& virt, const WarpParams& prm, WarpedView* out) {
  const size_t n = size_t(src.width) * src.height;
  CV_Assert(prepared.width == src.width && prepared.height == src.height && prepared.depth.size() == n &&
            prepared.label.size() == n + 1);
  CV_Assert(in.color.type() == CV_8UC3 && in.color.cols == src.width && in.color.rows == src.height);
  CV_Assert(in.room_depth.empty() || (in.room_depth.type() == CV_16UC1 && in.room_depth.size() == in.color.size() &&
                                      in.room_color.type() == CV_8UC3 && in.room_color.size() == in.color.size()));
  prepare_rays(src);
  // The tiles' depth ranges as prepared, or found here when the frame was prepared without them.
  const std::vector<uint16_t>* nearest = &prepared.tile_nearest;
  const std::vector<uint16_t>* farthest = &prepared.tile_farthest;
  const TileGrid g = tile_grid(src.width, src.height);
  const size_t tiles = size_t(g.cols) * g.rows;
  if (finds_view_columns(prm) && (nearest->size() != tiles || farthest->size() != tiles)) {
    tile_depth_ranges(src.width, src.height, prepared.depth.data(), &tile_nearest_, &tile_farthest_);
    nearest = &tile_nearest_, farthest = &tile_farthest_;
  }
  prepared_learner_depth_ = prepared.learner_depth.size() == n ? prepared.learner_depth.data() : nullptr;
  prepared_learner_rows_ = prepared_learner_depth_ && prepared.learner_rows.fit(src.width, src.height)
                               ? &prepared.learner_rows
                               : nullptr;
  warp_prepared_here(src, in, prepared.depth.data(), prepared.label.data(), *nearest, *farthest, virt, prm, out);
  prepared_learner_depth_ = nullptr;
  prepared_learner_rows_ = nullptr;
}

void ViewWarper::prepare_here(const CameraCalib& src, const WarpSource& in, const WarpParams& prm) {
  CV_Assert(in.color.type() == CV_8UC3 && in.depth.type() == CV_16UC1);
  CV_Assert(in.color.cols == src.width && in.color.rows == src.height && in.depth.size() == in.color.size());
  CV_Assert(in.label.empty() || (in.label.type() == CV_8UC1 && in.label.size() == in.color.size()));
  CV_Assert(in.static_depth.empty() ||
            (in.static_depth.type() == CV_16UC1 && in.static_depth.size() == in.color.size()));
  CV_Assert(in.room_depth.empty() || (in.room_depth.type() == CV_16UC1 && in.room_depth.size() == in.color.size() &&
                                      in.room_color.type() == CV_8UC3 && in.room_color.size() == in.color.size()));
  const int W = src.width, H = src.height;
  const size_t n = size_t(W) * H;
  prepare_rays(src);
  src_depth_.resize(n);
  src_label_.resize(n + 1);  // + 1: read as the last pixel's right neighbour
  src_label_[n] = 0;

  // The layered depth of every source pixel: learners live, the room static.
  const bool has_label = !in.label.empty();
  const bool has_static = !in.static_depth.empty();
  for (int v = 0; v < H; ++v) {
    const uint16_t* d = in.depth.ptr<uint16_t>(v);
    uint16_t* od = &src_depth_[size_t(v) * W];
    uint8_t* ol = &src_label_[size_t(v) * W];
    if (has_label) std::memcpy(ol, in.label.ptr<uint8_t>(v), size_t(W));
    else std::memset(ol, 0, size_t(W));
    if (has_static) layer_row(W, d, in.static_depth.ptr<uint16_t>(v), ol, od);
    else std::memcpy(od, d, size_t(W) * sizeof(uint16_t));
  }
  if (has_label && prm.fill_learner_depth) {
    uint16_t med[256] = {0};
    learner_median_depths(src_depth_.data(), src_label_.data(), W, H, med);
    for (int v = 0; v < H; ++v) {
      uint16_t* od = &src_depth_[size_t(v) * W];
      const uint8_t* ol = &src_label_[size_t(v) * W];
      if (has_learner_hole(W, ol, od)) fill_learner_holes(W, ol, med, od);
    }
  }
  if (prm.step_ratio > 0) smooth_stepped_depth(W, H, prm);
  if (prm.edge_to_near) give_edges_to_near_side(W, H, prm, in.color, in.static_depth);
  if (prm.boundary_px > 0 && W >= 4 && H >= 4) {
    // Drop the far-side pixels next to a depth edge: their colour mixes both
    // surfaces and would draw a ghost contour where the background is revealed.
    edge_code_.assign(n, 0);
    drop_.assign(n, 0);
    const int b = prm.boundary_px;
    const uint16_t ratio = tolerance_ratio_q16(prm.edge_ratio);
    const uint16_t min_mm = tolerance_min_mm(prm.edge_min_mm);
    uint16_t* D = src_depth_.data();
    uint8_t* const code = edge_code_.data();
    uint8_t* const drop = drop_.data();
    // Along rows; the far side and the b - 1 pixels beyond it, within the
    // row. One pass over the image (a vector loop has no remainder to speak
    // of), then the steps whose four pixels straddle two rows cleared.
    depth_edges(int(n - 3), D + 1, 1, ratio, min_mm, code + 1);
    for (int v = 0; v < H; ++v) {
      const size_t row = size_t(v) * W;
      code[row] = code[row + W - 2] = code[row + W - 1] = 0;
      for (int k = 0; k < b && k < W; ++k) mark_far_side(W, k, 1, code + row, drop + row);
    }
    // Along columns.
    std::fill(edge_code_.begin(), edge_code_.end(), 0);
    depth_edges(int(size_t(W) * (H - 3)), D + W, W, ratio, min_mm, code + W);
    for (int k = 0; k < b && k < H; ++k) mark_far_side(int(n / W), k, W, code, drop);
    clear_dropped(n, drop, D);
  }
  if (culls(prm)) {
    tile_depth_ranges(W, H, src_depth_.data(), &tile_nearest_, &tile_farthest_);
  } else {
    tile_nearest_.clear();  // none: a warp that culls finds them itself
    tile_farthest_.clear();
  }
}

namespace {

// Where cells are drawn: the z-buffer, its row length, and the source's last column and row (positions are
// clamped to them).
struct SplatTarget {
  Sample* zbuf;
  ptrdiff_t vw;
  float max_u, max_v;
};

// A cell the view magnifies: every virtual pixel of its bounding box tested against the cell as prepared
// (centre (fu, fv), reaching umin..umax, vmin..vmax source px from it).
void splat_big_cell(const SplatTarget& t, const ColorSampler& color, const CellRow& c, int i, float fu, float fv,
                    float umin, float umax, float vmin, float vmax, uint16_t zmm, uint8_t label) {
  const float su0 = c.su[i], sv0 = c.sv[i];
  const float a00 = c.dsu_dx[i], a10 = c.dsv_dx[i], a01 = c.dsu_dy[i], a11 = c.dsv_dy[i];
  const int x0 = c.x0[i], y0 = c.y0[i];
  const uint8_t wq = uint8_t(c.weight[i]);
  for (int yi = y0; yi <= c.y1[i]; ++yi) {
    const float ky = float(yi - y0);
    Sample* row = t.zbuf + size_t(yi) * t.vw;
    for (int xi = x0; xi <= c.x1[i]; ++xi) {
      const float kx = float(xi - x0);
      const float su = su0 + a00 * kx + a01 * ky, sv = sv0 + a10 * kx + a11 * ky;
      const float du = su - fu, dv = sv - fv;
      if (du > umax || du < umin || dv > vmax || dv < vmin) continue;
      Sample& s = row[xi];
      if (zmm >= s.z) continue;
      store(s, zmm, to_fixed(su, t.max_u), to_fixed(sv, t.max_v), color, wq, label);
    }
  }
}

}  // namespace

// One warp in progress: the source projected into the virtual camera (padded by a row and a pixel on both
// sides, so border pixels read their neighbours without a test), the z-buffer, and the tolerances.
struct ViewWarper::Frame {
  int W, H, VW, VH;
  float *PX, *PY, *PZ, *PW, *PL;
  Sample* zbuf;
  Projection proj;
  float max_u, max_v;  // the last source column and row
  float er, emin;      // depth-edge tolerance: ratio, and minimum in metres
  float max_area2;     // a drawn triangle's or cell's largest area
};

// One layer drawn into the z-buffer (the prepared source, then the room behind the learners): its depth,
// labels and colour, the source rows [row_begin, row_end) holding its pixels, the camera's quality times
// weight_scale, and `sparse` when it covers a small part of its rows (only the runs of drawn pixels are set
// up, one cell at a time).
struct ViewWarper::Layer {
  const uint16_t* depth;
  const uint8_t* label;
  ColorSampler color;
  int row_begin, row_end;
  float weight_scale;
  bool sparse;
  // Per row of tiles (view_cull.h), the columns that can land in the view: the others are skipped. Null:
  // every column is drawn.
  const std::vector<std::pair<int, int>>* columns = nullptr;
  // A sparse layer's rows and spans (sparse: not null).
  const SparseRows* rows = nullptr;
};

// What the cell warp of one layer keeps for every row: the cell and block rows, and where a block cell's
// candidates lie.
struct ViewWarper::CellPass {
  CellGeometry geom;
  CellRow cells, blocks;
  int blocks_per_row;
  ptrdiff_t block_offset[kBlockCandidates];  // candidate k of a block cell, relative to its first
  const int32_t* no_blocks;                  // all zero: a row pair without block cells
  uint32_t* no_links;                        // the row above row 0
  bool coarse;
};

namespace {
// The z-buffer of every warper on a thread: each warp leaves it empty. Where one thread warps several cameras
// (the bench, the eval), the next one (another camera of the same view, whose learners land in the same places)
// finds its lines in the cache, where a buffer per warper had been out of it since that warper's last frame,
// and the thread keeps one buffer of 8 bytes per view pixel, not one per camera and view. (In the elements
// each viewwarp has a streaming thread of its own: one buffer a warp, as before.)
struct ThreadZBuffer {
  std::vector<uint64_t> records;
  bool empty = true;  // false from a warp's first write to the end of its unpack
};
ThreadZBuffer& thread_zbuffer() {
  static thread_local ThreadZBuffer zbuf;
  return zbuf;
}

// Likewise the source's projections (Frame::PX ..: per source pixel the projected position, the virtual depth
// (m; <= 0 invalid), the longest unbroken mesh edge (px), the vertex weight): a warp projects every pixel it
// reads first, so the warpers on a thread can share them, and the next warp finds the lines of the last one's
// learners in the cache.
struct ThreadProjections {
  std::vector<float> x, y, z, lim, weight;
};
ThreadProjections& thread_projections() {
  static thread_local ThreadProjections projections;
  return projections;
}
}  // namespace

void ViewWarper::warp_prepared_here(const CameraCalib& src, const WarpSource& in, const uint16_t* depth,
                                    const uint8_t* label, const std::vector<uint16_t>& tile_nearest,
                                    const std::vector<uint16_t>& tile_farthest, const CameraCalib& virt,
                                    const WarpParams& prm, WarpedView* out) {
  const int W = src.width, H = src.height;
  const int VW = virt.width, VH = virt.height;
  const size_t n = size_t(W) * H, vn = size_t(VW) * VH;
  const size_t pad = size_t(W) + 1;
  ThreadProjections& projected = thread_projections();
  for (auto* a : {&projected.x, &projected.y, &projected.z, &projected.lim, &projected.weight}) {
    a->resize(n + 2 * pad);
    std::fill_n(a->begin(), pad, 0.0f);
    std::fill_n(a->end() - ptrdiff_t(pad), pad, 0.0f);
  }
  // The z-buffer is left empty by the last warp's unpack: only a new size (or a warp that did not get to its
  // unpack) needs a fill, one pass less over 8 bytes per virtual pixel.
  ThreadZBuffer& zbuf = thread_zbuffer();
  if (zbuf.records.size() != vn || !zbuf.empty) zbuf.records.assign(vn, kEmptyRecord);
  zbuf.empty = false;
  track_tiles_ = false;  // set by draw_learner_layer alone (a warp that threw may have left it set)
  Frame f{W, H, VW, VH, projected.x.data() + pad, projected.y.data() + pad, projected.z.data() + pad,
          projected.weight.data() + pad, projected.lim.data() + pad, reinterpret_cast<Sample*>(zbuf.records.data()),
          {}, float(W - 1), float(H - 1), float(prm.edge_ratio), float(prm.edge_min_mm * 0.001), float(prm.max_stretch)};
  // Source -> virtual camera.
  const Eigen::Isometry3d T = virt.cam_to_rig.inverse() * src.cam_to_rig;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) f.proj.r[3 * r + c] = float(T.linear()(r, c));
    f.proj.t[r] = float(T.translation()(r));
  }
  f.proj.fx = float(virt.fx), f.proj.fy = float(virt.fy), f.proj.cx = float(virt.cx), f.proj.cy = float(virt.cy);
  f.proj.link_scale = float(0.5 * (virt.fx / src.fx + virt.fy / src.fy));
  f.proj.link_gap = float(prm.max_gap_px);

  const bool cull = finds_view_columns(prm);
  warped_share_ = 1.0;
  if (cull) {
    // A cell's affine map strays from the true projection of its pixel by far less than a pixel: 4 px of room.
    constexpr float kViewMarginPx = 4;
    columns_in_view(W, H, rays_->tile_boxes, tile_nearest, tile_farthest, frustum_between(src, virt), kNear,
                    kViewMarginPx, &view_columns_);
    size_t kept = 0;
    for (size_t ty = 0; ty < view_columns_.size(); ++ty)
      kept += size_t(view_columns_[ty].second - view_columns_[ty].first) *
              size_t(std::min(kTileSize, H - int(ty) * kTileSize));
    warped_share_ = double(kept) / double(n);
  }
  if (learners_alone(prm)) {
    draw_learner_layer(f, in, depth, label, prm);
  } else {
    splat_layer(f,
                Layer{depth, label, ColorSampler{in.color.data, in.color.step, W - 1, H - 1}, 0, H, 1.0f, false,
                      cull ? &view_columns_ : nullptr},
                prm);
    if (!in.room_depth.empty()) draw_room_layer(f, in, prm);
  }
  unpack_view(f, prm, out);
  zbuf.empty = true;
}

void ViewWarper::splat_layer(const Frame& f, const Layer& layer, const WarpParams& prm) {
  const int H = f.H;
  if (prm.mesh) {
    project_rows(f, layer, 0, H, 0, f.W);
    splat_mesh(f, layer, prm);
  } else {
    splat_cells(f, layer, prm);  // projects what it draws
  }
}

void ViewWarper::project_rows(const Frame& f, const Layer& layer, int r0, int r1, int c0, int c1) {
  const int W = f.W;
  const size_t first = size_t(r0) * W + size_t(c0);
  // Whole rows in one call: the loop's remainder once, not once per row. A part of a row is rounded up to whole
  // blocks of project_points (the pixels after it, in the row or the next, projected as they are: a pixel's
  // projection is its own), where the image goes on that far.
  const bool whole = c0 == 0 && c1 == W;
  const size_t blocks = (size_t(c1 - c0) + kProjectBlock - 1) / kProjectBlock * kProjectBlock;
  const size_t count = whole ? size_t(r1 - r0) * W
                             : (r1 == r0 + 1 && first + blocks <= size_t(f.H) * W ? blocks : size_t(c1 - c0));
  for (size_t at = first; at < size_t(r1) * W; at += whole ? count : size_t(W)) {
    project_points(count, layer.depth + at, rays_->x.data() + at, rays_->y.data() + at, f.proj, f.PX + at,
                   f.PY + at, f.PZ + at, f.PL + at, f.PW + at);
    if (layer.weight_scale != 1.0f)
      for (size_t i = at; i < at + count; ++i) f.PW[i] *= layer.weight_scale;
  }
}

// The reference: the two triangles of every 2x2 block, rasterised.
void ViewWarper::splat_mesh(const Frame& f, const Layer& layer, const WarpParams& prm) {
  const int W = f.W, H = f.H, VW = f.VW, VH = f.VH;
  const float *const PX = f.PX, *const PY = f.PY, *const PZ = f.PZ, *const PW = f.PW;
  const uint16_t* const layer_depth = layer.depth;
  const uint8_t* const layer_label = layer.label;
  // In double, as the mesh's tolerance has always been computed.
  const double er = prm.edge_ratio, emin = prm.edge_min_mm * 0.001;
  const float max_area2 = f.max_area2, max_u = f.max_u, max_v = f.max_v;
  const float gap = float(prm.max_gap_px);
  Sample* const zbuf = f.zbuf;
  const ColorSampler color = layer.color;
  auto consistent = [&](size_t a, size_t b, size_t c) {
    const float za = PZ[a], zb = PZ[b], zc = PZ[c];
    if (za <= 0 || zb <= 0 || zc <= 0) return false;
    if (layer_label[a] != layer_label[b] || layer_label[a] != layer_label[c]) return false;
    const float lo = std::min(za, std::min(zb, zc)), hi = std::max(za, std::max(zb, zc));
    if (hi - lo <= std::max(emin, er * lo)) return true;
    // Different depths but not torn apart by this view (a slanted surface):
    // no edge longer than its source length at the local scale + max_gap_px.
    const float scale = f.proj.link_scale * layer_depth[a] * 0.001f / za;
    auto edge_ok = [&](size_t i, size_t j) {
      const float su = float(int(i % W) - int(j % W)), sv = float(int(i / W) - int(j / W));
      const float lim = scale * std::sqrt(su * su + sv * sv) + gap;
      const float dx = PX[i] - PX[j], dy = PY[i] - PY[j];
      return dx * dx + dy * dy <= lim * lim;
    };
    return edge_ok(a, b) && edge_ok(b, c) && edge_ok(a, c);
  };
  auto raster = [&](size_t a, size_t b, size_t c, float ua, float va, float ub, float vb, float uc, float vc) {
    const float x0 = PX[a], y0 = PY[a], x1 = PX[b], y1 = PY[b], x2 = PX[c], y2 = PY[c];
    const float area2 = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    const float aa = std::fabs(area2);
    if (aa < 1e-12f || aa > max_area2) return;
    const int xmin = std::max(0, fast_ceil(std::min(x0, std::min(x1, x2))));
    const int xmax = std::min(VW - 1, fast_floor(std::max(x0, std::max(x1, x2))));
    const int ymin = std::max(0, fast_ceil(std::min(y0, std::min(y1, y2))));
    const int ymax = std::min(VH - 1, fast_floor(std::max(y0, std::max(y1, y2))));
    if (xmin > xmax || ymin > ymax) return;
    const float inv = 1.0f / area2;
    const float stretch = aa > 1.0f ? 1.0f / std::sqrt(aa) : 1.0f;
    const uint8_t wq = weight_byte((PW[a] + PW[b] + PW[c]) * (1.0f / 3.0f) * stretch);
    const uint8_t lab = layer_label[a];
    constexpr float eps = -0.02f;
    for (int y = ymin; y <= ymax; ++y) {
      const float fyv = float(y);
      for (int x = xmin; x <= xmax; ++x) {
        const float fxv = float(x);
        const float l1 = ((fxv - x0) * (y2 - y0) - (x2 - x0) * (fyv - y0)) * inv;
        const float l2 = ((x1 - x0) * (fyv - y0) - (fxv - x0) * (y1 - y0)) * inv;
        const float l0 = 1.0f - l1 - l2;
        if (l0 < eps || l1 < eps || l2 < eps) continue;
        const float z = l0 * PZ[a] + l1 * PZ[b] + l2 * PZ[c];
        Sample& s = zbuf[size_t(y) * VW + x];
        const uint16_t zmm = depth_mm(z);
        if (zmm >= s.z) continue;
        store(s, zmm, to_fixed(l0 * ua + l1 * ub + l2 * uc, max_u), to_fixed(l0 * va + l1 * vb + l2 * vc, max_v),
              color, wq, lab);
      }
    }
  };
  for (int v = 0; v + 1 < H; ++v) {
    const float fv = float(v), fv1 = fv + 1.0f;
    for (int u = 0; u + 1 < W; ++u) {
      const size_t a = size_t(v) * W + u, b = a + 1, c = a + W, d = c + 1;
      if (PZ[a] <= 0 && PZ[d] <= 0) continue;
      const float fu = float(u), fu1 = fu + 1.0f;
      const bool t1 = consistent(a, b, c), t2 = consistent(b, d, c);
      if (t1 && t2) {
        raster(a, b, c, fu, fv, fu1, fv, fu, fv1);
        raster(b, d, c, fu1, fv, fu1, fv1, fu, fv1);
        continue;
      }
      // The other diagonal may keep one surface whole.
      const bool t3 = consistent(a, b, d), t4 = consistent(a, d, c);
      if (t1) raster(a, b, c, fu, fv, fu1, fv, fu, fv1);
      if (t2) raster(b, d, c, fu1, fv, fu1, fv1, fu, fv1);
      if (t3) raster(a, b, d, fu, fv, fu1, fv, fu1, fv1);
      if (t4) raster(a, d, c, fu, fv, fu1, fv1, fu, fv1);
    }
  }
}

// Each source pixel's cell [u +- 0.5] x [v +- 0.5] mapped by the local affine map J (from the neighbours on
// the same surface) covers the virtual pixels whose pre-image lies inside it: the mesh's coverage without its
// per-triangle set-up. Pixels with no neighbour on their surface (flying pixels, speckle) are not drawn.
// Inside one surface a 2x2 block is drawn as one cell of twice the size (WarpParams::coarse_cells).
void ViewWarper::splat_cells(const Frame& f, const Layer& layer, const WarpParams& prm) {
  const int W = f.W, H = f.H;
  // Which neighbours lie on the same surface, a row at a time just before its cells are set up (three rows
  // kept: the rows are taken in pairs, and a cell also looks at the row above).
  links_.assign(4 * size_t(W + 2), 0);
  cell_x0_.resize(W);
  cell_y0_.resize(W);
  cell_x1_.resize(W);
  cell_y1_.resize(W);
  cell_sides_.resize(W);
  cell_mask_.resize(W);
  cell_weight_.resize(W);
  cell_pos_.resize(size_t(W) * 6);
  float* const pos = cell_pos_.data();
  const int NB = W / 2 + 1;
  for (auto* a : {&block_x0_, &block_y0_, &block_x1_, &block_y1_, &block_coarse_, &block_mask_, &block_weight_,
                  &block_z_})
    a->resize(NB);
  block_pos_.resize(size_t(NB) * 6);
  block_fixed_.resize(size_t(NB) * 2 * kBlockCandidates);
  float* const bpos = block_pos_.data();
  no_blocks_.assign(size_t(W / 2 + 1), 0);
  CellPass pass{CellGeometry{W, H, f.VW, f.VH, f.max_area2},
                CellRow{cell_x0_.data(), cell_y0_.data(), cell_x1_.data(), cell_y1_.data(), cell_sides_.data(),
                        cell_mask_.data(), cell_weight_.data(), pos, pos + W, pos + 2 * W, pos + 3 * W, pos + 4 * W,
                        pos + 5 * W},
                CellRow{block_x0_.data(), block_y0_.data(), block_x1_.data(), block_y1_.data(), block_coarse_.data(),
                        block_mask_.data(), block_weight_.data(), bpos, bpos + NB, bpos + 2 * NB, bpos + 3 * NB,
                        bpos + 4 * NB, bpos + 5 * NB},
                NB,
                {},
                no_blocks_.data(),
                links_.data() + 3 * size_t(W + 2) + 1,
                prm.coarse_cells && W >= 2 && !layer.sparse};
  for (int k = 0; k < kBlockCandidates; ++k) pass.block_offset[k] = ptrdiff_t(k / 3) * f.VW + k % 3;
  if (layer.sparse) {
    splat_sparse_pairs(f, layer, pass);
    return;
  }
  // Pairs of rows from an even one; the row above the first has no links.
  const int first_pair = std::max(0, layer.row_begin - 1) & ~1;
  const int end_pair = std::min(H, layer.row_end + 1);
  if (first_pair > 0) std::fill_n(links_row(W, first_pair - 1), W, 0u);
  if (layer.columns) splat_pairs_in_view(f, layer, pass, first_pair, end_pair);
  else splat_pairs(f, layer, pass, first_pair, end_pair);
}

// Whole rows: each row projected and linked once, the rows above kept from the pair before.
void ViewWarper::splat_pairs(const Frame& f, const Layer& layer, const CellPass& pass, int first_pair, int end_pair) {
  const int W = f.W, H = f.H;
  project_rows(f, layer, std::max(0, first_pair - 1), std::min(H, layer.row_end + 3), 0, W);
  for (int v = first_pair; v < end_pair; v += 2) {
    link_row(f, layer, v, 0, W);
    if (v + 1 < H) link_row(f, layer, v + 1, 0, W);
    splat_pair_columns(f, layer, pass, v, 0, W);
  }
}

// Rows v and v + 1 drawn over columns [c0, c1) (their links there made).
void ViewWarper::splat_pair_columns(const Frame& f, const Layer& layer, const CellPass& pass, int v, int c0, int c1) {
  const int W = f.W, H = f.H;
  if (!pass.coarse || v + 1 >= H) {
    splat_fine_cells(f, layer, pass, v, c0, c1, pass.no_blocks);
    if (v + 1 < H) splat_fine_cells(f, layer, pass, v + 1, c0, c1, pass.no_blocks);
    return;
  }
  splat_block_pair(f, layer, pass, v, c0 / 2, c1 == W ? W / 2 : c1 / 2);
}

// As splat_pairs, over the columns of each row of tiles that can land in the view (layer.columns): each row
// projected over every pair's columns that read it, each pair's rows linked over its columns, with
// kSpanMargin columns either side (what a cell reads); the row above a pair linked again where the pair
// before had other columns. The same records as splat_pairs: a cell skipped lands nowhere in the view.
void ViewWarper::splat_pairs_in_view(const Frame& f, const Layer& layer, const CellPass& pass, int first_pair,
                                     int end_pair) {
  const int W = f.W, H = f.H;
  // A pair's columns: its tile row's (pairs start on even rows and tiles are an even number of rows high).
  auto pair_columns = [&](int v) {
    if (v < first_pair || v >= end_pair) return std::pair<int, int>{0, 0};
    return (*layer.columns)[size_t(v / kTileSize)];
  };
  // Row r is read by the pairs from r - 2 to r + 1.
  for (int r = std::max(0, first_pair - 1); r < std::min(H, layer.row_end + 3); ++r) {
    int lo = W, hi = 0;
    for (int v = (r - 2) & ~1; v <= r + 1; v += 2) {
      const auto [a, b] = pair_columns(v);
      if (a < b) lo = std::min(lo, a), hi = std::max(hi, b);
    }
    if (lo < hi) project_rows(f, layer, r, r + 1, std::max(0, lo - kSpanMargin), std::min(W, hi + kSpanMargin));
  }
  std::pair<int, int> linked_above{0, 0};  // the columns row v - 1 was linked over
  for (int v = first_pair; v < end_pair; v += 2) {
    const auto [c0, c1] = pair_columns(v);
    if (c0 >= c1) {
      linked_above = {0, 0};
      continue;
    }
    const int lo = std::max(0, c0 - kSpanMargin), hi = std::min(W, c1 + kSpanMargin);
    if (v > first_pair && linked_above != std::pair<int, int>{lo, hi}) link_row(f, layer, v - 1, lo, hi);
    link_row(f, layer, v, lo, hi);
    if (v + 1 < H) link_row(f, layer, v + 1, lo, hi);
    linked_above = {lo, hi};
    splat_pair_columns(f, layer, pass, v, c0, c1);
  }
}

uint32_t* ViewWarper::links_row(int W, int v) { return links_.data() + size_t(v % 3) * (W + 2) + 1; }

// Links of row v's pixels c0..c1 - 1 (rows v and v + 1 projected there): to the right within the columns,
// downwards. The last column has no right neighbour: the image's, or one not projected.
void ViewWarper::link_row(const Frame& f, const Layer& layer, int v, int c0, int c1) {
  const int W = f.W;
  const size_t row = size_t(v) * W + size_t(c0);
  const size_t n = size_t(c1 - c0);
  uint32_t* out = links_row(W, v) + c0;
  std::fill_n(out, n, 0u);
  // The last pixel too (its "right neighbour" is the next row's first, or padding), then unlinked: a whole
  // number of vectors.
  link_neighbours(n, 1, f.PX + row, f.PY + row, f.PZ + row, f.PL + row, &layer.label[row], f.er, f.emin, kRight,
                  out);
  out[n - 1] &= ~kRight;
  if (v + 1 < f.H)
    link_neighbours(n, W, f.PX + row, f.PY + row, f.PZ + row, f.PL + row, &layer.label[row], f.er, f.emin, kDown,
                    out);
}

void find_sparse_rows(int W, int H, const uint16_t* depth, SparseRows* out) {
  out->row_begin = H, out->row_end = 0;
  for (int v = 0; v < H; ++v)
    if (any_nonzero(size_t(W), depth + size_t(v) * W)) {
      out->row_begin = std::min(out->row_begin, v);
      out->row_end = v + 1;
    }
  out->pair_first.clear();
  out->spans.clear();
  if (out->row_begin >= out->row_end) out->row_begin = out->row_end = 0;
  // The row above the first pair's first row has no pixels: a pair from there on reads all there is.
  out->first_pair = std::max(0, out->row_begin - 1) & ~1;
  out->end_pair = out->row_begin < out->row_end ? std::min(H, out->row_end + 1) : out->first_pair;
  for (int v = out->first_pair; v < out->end_pair; v += 2) {
    out->pair_first.push_back(out->spans.size());
    const uint16_t* d0 = depth + size_t(v) * W;
    const uint16_t* d1 = v + 1 < H ? d0 + W : d0;
    const size_t first = out->spans.size();
    for (int u = 0; u < W;) {
      if (!(d0[u] | d1[u])) {
        ++u;
        continue;
      }
      const int u0 = u;
      while (u < W && (d0[u] | d1[u])) ++u;
      // Joined where the columns either side that the cells read would overlap.
      if (out->spans.size() > first && u0 - out->spans.back().second <= 2 * kSpanMargin) out->spans.back().second = u;
      else out->spans.emplace_back(u0, u);
    }
  }
  out->pair_first.push_back(out->spans.size());
}

bool SparseRows::fit(int width, int height) const {
  return row_begin >= 0 && row_end <= height && first_pair >= 0 && !(first_pair & 1) && end_pair <= height &&
         end_pair >= first_pair && pair_first.size() == size_t((end_pair - first_pair + 1) / 2) + 1 &&
         spans_fit(pair_first, spans, width);
}

namespace {
// The spans [first, second) of one pair or of two (either may be empty), each grown by kSpanMargin columns either
// side within [0, width), overlapping ones joined: the columns a pair's cells read.
void grown_union(const std::pair<int, int>* a, size_t na, const std::pair<int, int>* b, size_t nb, int width,
                 std::vector<std::pair<int, int>>* out) {
  out->clear();
  size_t i = 0, j = 0;
  while (i < na || j < nb) {
    const bool take_a = j == nb || (i < na && a[i].first <= b[j].first);
    const std::pair<int, int> s = take_a ? a[i++] : b[j++];
    const int lo = std::max(0, s.first - kSpanMargin), hi = std::min(width, s.second + kSpanMargin);
    if (!out->empty() && lo <= out->back().second) out->back().second = std::max(out->back().second, hi);
    else out->emplace_back(lo, hi);
  }
}
}  // namespace

// A sparse layer's row pairs drawn over their column spans only (layer.rows), so that a layer drawn in parts
// costs what its parts hold: each row projected and linked once, when the first pair that reads it comes, over
// the columns of every pair that reads it (pair v reads the projections of rows v - 1 .. v + 2 and the links of
// rows v - 1 .. v + 1, kSpanMargin columns either side of its spans).
void ViewWarper::splat_sparse_pairs(const Frame& f, const Layer& layer, const CellPass& pass) {
  const int W = f.W, H = f.H;
  const SparseRows& rows = *layer.rows;
  const int first_pair = rows.first_pair, end_pair = rows.end_pair;
  // Pair v's spans (none for a pair past the last).
  auto spans_of = [&](int v) {
    if (v < first_pair || v >= end_pair) return std::pair<const std::pair<int, int>*, size_t>{nullptr, 0};
    const size_t p = size_t((v - first_pair) / 2);
    return std::pair<const std::pair<int, int>*, size_t>{rows.spans.data() + rows.pair_first[p],
                                                         rows.pair_first[p + 1] - rows.pair_first[p]};
  };
  auto project = [&](int r, const std::vector<std::pair<int, int>>& columns) {
    if (r >= 0 && r < H)
      for (const auto& [a, b] : columns) project_rows(f, layer, r, r + 1, a, b);
  };
  auto link = [&](int r, const std::vector<std::pair<int, int>>& columns) {
    if (r >= 0 && r < H)
      for (const auto& [a, b] : columns) link_row(f, layer, r, a, b);
  };
  for (int v = first_pair; v < end_pair; v += 2) {
    const auto [own, n_own] = spans_of(v);
    const auto [next, n_next] = spans_of(v + 2);
    grown_union(own, n_own, nullptr, 0, W, &own_columns_);
    if (v == first_pair) {  // rows v - 1 and v: read by this pair alone
      project(v - 1, own_columns_);
      project(v, own_columns_);
      link(v - 1, own_columns_);
    }
    // Rows v + 1 and v + 2: read by this pair and the next (row v + 1's links too).
    grown_union(own, n_own, next, n_next, W, &shared_columns_);
    project(v + 1, shared_columns_);
    project(v + 2, shared_columns_);
    link(v, own_columns_);
    link(v + 1, shared_columns_);
    if (n_own == 0) continue;
    for (int r = v; r < std::min(H, v + 2); ++r)
      for (size_t i = 0; i < n_own; ++i)
        splat_fine_cells(f, layer, pass, r, own[i].first, own[i].second, pass.no_blocks);
  }
}

// The cells of pixels u_begin..u_end - 1 of row v, set up and splatted; pixels of blocks drawn as one cell
// (skip[u / 2]) are skipped.
void ViewWarper::splat_fine_cells(const Frame& f, const Layer& layer, const CellPass& pass, int v, int u_begin,
                                  int u_end, const int32_t* skip) {
  const size_t row = size_t(v) * f.W;
  const CellRow& cells = pass.cells;
  prepare_cells(pass.geom, v, u_begin, u_end, f.PX + row, f.PY + row, f.PZ + row, f.PW + row, links_row(f.W, v),
                v > 0 ? links_row(f.W, v - 1) : pass.no_links, cells);
  // Everything a cell's writes need in locals: a byte store may alias anything reached through a pointer.
  const uint8_t* const lab = &layer.label[row];
  const float* const pz_row = f.PZ + row;
  const int32_t *const mask = cells.mask, *const x0 = cells.x0, *const y0 = cells.y0, *const wt = cells.weight,
                *const sides = cells.sides;
  const float *const su0 = cells.su, *const sv0 = cells.sv, *const a00 = cells.dsu_dx, *const a10 = cells.dsv_dx,
              *const a01 = cells.dsu_dy, *const a11 = cells.dsv_dy;
  Sample* const zb = f.zbuf;
  const ptrdiff_t vw = f.VW;
  const ColorSampler col = layer.color;
  const float mu = f.max_u, mv = f.max_v;
  if (track_tiles_) {  // a sparse layer's view: where its records can be (unpack_view reads only there)
    const int32_t *const x1 = cells.x1, *const y1 = cells.y1;
    uint8_t* const marks = tile_marks_.data();
    const int cols = tile_cols_;
    constexpr int kShift = SampleTiles::kShift;
    for (int u = u_begin; u < u_end; ++u) {
      const int32_t m = mask[u];
      if (!m || skip[u >> 1]) continue;
      if (m == kBigCell) {
        for (int ty = y0[u] >> kShift; ty <= y1[u] >> kShift; ++ty)
          std::fill(marks + ty * cols + (x0[u] >> kShift), marks + ty * cols + (x1[u] >> kShift) + 1, uint8_t(1));
        continue;
      }
      // The cell's 2x2 of candidates: usually in one tile.
      const int tx0 = x0[u] >> kShift, tx1 = (x0[u] + 1) >> kShift;
      const int r0 = (y0[u] >> kShift) * cols, r1 = ((y0[u] + 1) >> kShift) * cols;
      marks[r0 + tx0] = marks[r0 + tx1] = marks[r1 + tx0] = marks[r1 + tx1] = 1;
    }
  }
  for (int u = u_begin; u < u_end; ++u) {
    const int32_t m = mask[u];
    if (!m || skip[u >> 1]) continue;
    const uint16_t zmm = depth_mm(pz_row[u]);
    const uint8_t label = lab[u];
    if (m == kBigCell) {
      const int32_t s = sides[u];
      splat_big_cell(SplatTarget{zb, vw, mu, mv}, col, cells, u, float(u), float(v), s & kOpenLeft ? -kCell : -kEdge,
                     s & kOpenRight ? kCell : kEdge, s & kOpenUp ? -kCell : -kEdge, s & kOpenDown ? kCell : kEdge,
                     zmm, label);
      continue;
    }
    Sample* const first = zb + y0[u] * vw + x0[u];
    const float cu = su0[u], cv = sv0[u], cux = a00[u], cvx = a10[u], cuy = a01[u], cvy = a11[u];
    const uint8_t weight = uint8_t(wt[u]);
    // Usually one candidate: a loop over the set bits costs one predictable branch, where testing each bit
    // mispredicts.
    for (unsigned bits = m; bits; bits &= bits - 1) {
      const int k = __builtin_ctz(bits);
      Sample& s = first[(k >> 1) * vw + (k & 1)];
      if (zmm >= s.z) continue;
      const float kx = float(k & 1), ky = float(k >> 1);
      const float su = cu + cux * kx + cuy * ky;
      const float sv = cv + cvx * kx + cvy * ky;
      store(s, zmm, to_fixed(su, mu), to_fixed(sv, mv), col, weight, label);
    }
  }
}

// Rows v and v + 1 with their 2x2 blocks inside one surface drawn as one cell each, the other pixels as
// cells of their own; blocks j_begin..j_end - 1 (pixels 2 j_begin .. 2 j_end - 1, and the last column when
// W is odd and j_end is the last block).
void ViewWarper::splat_block_pair(const Frame& f, const Layer& layer, const CellPass& pass, int v, int j_begin,
                                  int j_end) {
  const int W = f.W;
  const size_t row = size_t(v) * W;
  const int nb = W / 2;
  const int u_begin = 2 * j_begin, u_end = j_end == nb ? W : 2 * j_end;
  const CellRow& blocks = pass.blocks;
  prepare_blocks(pass.geom, v, j_begin, j_end, nb, f.PX + row, f.PY + row, f.PZ + row, f.PW + row, links_row(W, v),
                 links_row(W, v + 1), v > 0 ? links_row(W, v - 1) : pass.no_links, blocks, block_z_.data(), f.max_u,
                 f.max_v, block_fixed_.data());
  // The pixels of the blocks that are not one cell, in runs.
  const int32_t* is_block = block_coarse_.data();
  // Each run widened to whole kRunChunk chunks (within the blocks drawn), runs that then touch joined; the
  // pixels of block cells inside them are skipped.
  block_coarse_[nb] = 0;  // the last column when W is odd
  fine_runs_.clear();
  auto add_fine_run = [&](int u0, int u1) {
    u0 = std::max(u_begin, u0 - u0 % kRunChunk);
    u1 = std::min(u_end, u1 + (kRunChunk - u1 % kRunChunk) % kRunChunk);
    if (!fine_runs_.empty() && u0 <= fine_runs_.back().second) fine_runs_.back().second = u1;
    else fine_runs_.emplace_back(u0, u1);
  };
  for (int j = j_begin; j < j_end;) {
    if (is_block[j]) {
      ++j;
      continue;
    }
    const int j0 = j;
    while (j < j_end && !is_block[j]) ++j;
    add_fine_run(2 * j0, j == nb ? W : 2 * j);
  }
  if ((W & 1) && j_end == nb && is_block[nb - 1]) add_fine_run(W - 1, W);
  for (int r = v; r <= v + 1; ++r)
    for (const auto& run : fine_runs_) splat_fine_cells(f, layer, pass, r, run.first, run.second, is_block);
  const uint8_t* const lab = &layer.label[row];
  const int32_t *const mask = blocks.mask, *const x0 = blocks.x0, *const y0 = blocks.y0, *const wt = blocks.weight,
                *const bz = block_z_.data();
  const int32_t* const fixed_u = block_fixed_.data();
  const int32_t* const fixed_v = fixed_u + size_t(kBlockCandidates) * nb;
  // Everything the writes need in locals: a byte store may alias anything reached through a pointer.
  Sample* const zbuf = f.zbuf;
  const ptrdiff_t vw = f.VW;
  const float mu = f.max_u, mv = f.max_v;
  const ColorSampler col = layer.color;
  ptrdiff_t block_offset[kBlockCandidates];
  std::copy(pass.block_offset, pass.block_offset + kBlockCandidates, block_offset);
  for (int j = j_begin; j < j_end; ++j) {
    const int32_t m = mask[j];
    if (!m) continue;
    const uint16_t zmm = uint16_t(bz[j]);
    const int u = 2 * j;
    const uint8_t label = lab[u];
    if (m == kBigCell) {
      splat_big_cell(SplatTarget{zbuf, vw, mu, mv}, col, blocks, j, float(u) + 0.5f, float(v) + 0.5f, -kBlock,
                     kBlock, -kBlock, kBlock, zmm, label);
      continue;
    }
    Sample* const first = zbuf + y0[j] * vw + x0[j];
    const uint8_t weight = uint8_t(wt[j]);
    for (unsigned bits = m; bits; bits &= bits - 1) {
      const int k = __builtin_ctz(bits);
      Sample& s = first[block_offset[k]];
      if (zmm >= s.z) continue;
      const size_t at = size_t(k) * nb + j;
      store(s, zmm, fixed_u[at], fixed_v[at], col, weight, label);
    }
  }
}

// The room behind the learners, remembered (BackgroundMemory), drawn behind everything the camera sees now:
// where the view looks past a learner, it shows the room seen there before instead of a hole. Its quality is
// halved, so a camera that sees that room now outweighs it. Drawn from the warper's own buffers (the
// prepared source, if it was drawn from them, is done).
void ViewWarper::draw_room_layer(const Frame& f, const WarpSource& in, const WarpParams& prm) {
  const int W = f.W, H = f.H;
  const size_t n = size_t(W) * H;
  src_depth_.resize(n);
  src_label_.assign(n + 1, 0);
  for (int v = 0; v < H; ++v)
    std::memcpy(&src_depth_[size_t(v) * W], in.room_depth.ptr<uint16_t>(v), size_t(W) * sizeof(uint16_t));
  find_sparse_rows(W, H, src_depth_.data(), &sparse_rows_);
  if (sparse_rows_.row_begin < sparse_rows_.row_end)
    splat_layer(f,
                Layer{src_depth_.data(), src_label_.data(),
                      ColorSampler{in.room_color.data, in.room_color.step, W - 1, H - 1}, sparse_rows_.row_begin,
                      sparse_rows_.row_end, kRoomLayerWeight, true, nullptr, &sparse_rows_},
                prm);
}

// WarpParams::learners_only: the learners and what the room's mesh does not draw (learner_depth_of), as a
// sparse layer over their spans.
void ViewWarper::draw_learner_layer(const Frame& f, const WarpSource& in, const uint16_t* depth,
                                    const uint8_t* label, const WarpParams& prm) {
  const int W = f.W, H = f.H;
  const size_t n = size_t(W) * H;
  const uint16_t* learners = prepared_learner_depth_;
  if (!learners) {
    learner_depth_.resize(n);
    const bool whole = !in.static_depth.empty() && in.static_depth.isContinuous() && in.static_depth.total() == n &&
                       in.static_depth.type() == CV_16UC1;
    learner_depth_of(W, H, depth, label, whole ? in.static_depth.ptr<uint16_t>() : nullptr, learner_depth_.data());
    learners = learner_depth_.data();
  }
  const SparseRows* rows = prepared_learner_rows_;
  if (!rows) {
    find_sparse_rows(W, H, learners, &sparse_rows_);
    rows = &sparse_rows_;
  }
  track_tiles_ = true;
  tile_cols_ = (f.VW >> SampleTiles::kShift) + 1;
  tile_marks_.assign(size_t(tile_cols_) * size_t((f.VH >> SampleTiles::kShift) + 1), 0);
  if (rows->row_begin < rows->row_end)
    splat_layer(f,
                Layer{learners, label, ColorSampler{in.color.data, in.color.step, W - 1, H - 1}, rows->row_begin,
                      rows->row_end, 1.0f, true, nullptr, rows},
                prm);
}

namespace {

// A sparse layer's planes (of the view's size) zeroed where its last tiles were, or everywhere for fresh planes
// or tiles that do not fit them.
void zero_last_tiles(bool fresh, int VW, int VH, WarpedView* out) {
  const SampleTiles& tiles = out->tiles;
  if (fresh || tiles.anywhere() || !tiles.fit(VW, VH)) {
    // Zeros by memset (cv::Mat::setTo copies a pattern block by block: a third slower).
    out->color = cv::Scalar::all(0), out->depth = cv::Scalar::all(0), out->label = cv::Scalar::all(0);
    out->weight = cv::Scalar::all(0);
    return;
  }
  for_each_tile_span(tiles, VH, [&](int y, int x0, int x1) {
    std::memset(out->color.ptr<uint8_t>(y) + 3 * x0, 0, size_t(x1 - x0) * 3);
    std::memset(out->depth.ptr<uint16_t>(y) + x0, 0, size_t(x1 - x0) * 2);
    std::memset(out->label.ptr<uint8_t>(y) + x0, 0, size_t(x1 - x0));
    std::memset(out->weight.ptr<uint8_t>(y) + x0, 0, size_t(x1 - x0));
  });
}

// The view's planes made of its size: whether any of them is new (not the planes out held).
bool make_view_planes(int VW, int VH, WarpedView* out) {
  const void* before[4] = {out->color.data, out->depth.data, out->label.data, out->weight.data};
  out->color.create(VH, VW, CV_8UC3);
  out->depth.create(VH, VW, CV_16UC1);
  out->label.create(VH, VW, CV_8UC1);
  out->weight.create(VH, VW, CV_8UC1);
  return before[0] != out->color.data || before[1] != out->depth.data || before[2] != out->label.data ||
         before[3] != out->weight.data;
}

}  // namespace

void ViewWarper::warp_nothing(const CameraCalib& virt, WarpedView* out) {
  warped_share_ = 0;
  const bool fresh = make_view_planes(virt.width, virt.height, out);
  zero_last_tiles(fresh, virt.width, virt.height, out);
  out->tiles.set_none(virt.height);
}

// unpack_view for a sparse layer whose records lie in the marked tiles: the planes zeroed where the last tiles
// were (everywhere for fresh planes), the records read and emptied in the new tiles only, the cracks looked
// for there only (a crack lies between two pixels with depth, one of them in its own tile).
void ViewWarper::unpack_tiles(const Frame& f, const WarpParams& prm, bool fresh, WarpedView* out) {
  const int VW = f.VW, VH = f.VH;
  SampleTiles& tiles = out->tiles;
  zero_last_tiles(fresh, VW, VH, out);
  tiles.set_marked(tile_marks_.data(), size_t(tile_cols_), VW, VH);
  for_each_tile_span(tiles, VH, [&](int y, int x0, int x1) {
    const int n = x1 - x0;
    unpack_samples(n, f.zbuf + size_t(y) * VW + x0, out->color.ptr<uint8_t>(y) + 3 * x0,
                   out->depth.ptr<uint16_t>(y) + x0, out->label.ptr<uint8_t>(y) + x0,
                   out->weight.ptr<uint8_t>(y) + x0);
    std::fill_n(reinterpret_cast<uint64_t*>(f.zbuf) + size_t(y) * VW + x0, size_t(n), kEmptyRecord);
  });
  if (prm.close_cracks)
    close_cracks(out, tolerance_ratio_q16(std::max(prm.step_ratio, prm.edge_ratio)),
                 tolerance_min_mm(prm.edge_min_mm), &crack_code_, nullptr, &tiles);
}

// The z-buffer into the view's planes, and the cracks closed.
void ViewWarper::unpack_view(const Frame& f, const WarpParams& prm, WarpedView* out) {
  const int VW = f.VW, VH = f.VH;
  const bool fresh = make_view_planes(VW, VH, out);
  // In bands of rows where the planes have no row padding (a vector loop
  // per row would spend a good part of its time in the row's remainder);
  // each band's records emptied for the next frame while they are in cache.
  const bool continuous = out->color.isContinuous() && out->depth.isContinuous() && out->label.isContinuous() &&
                          out->weight.isContinuous();
  if (track_tiles_) {  // a sparse layer: its records lie in the marked tiles, all else is empty
    track_tiles_ = false;
    unpack_tiles(f, prm, fresh, out);
    return;
  }
  out->tiles = SampleTiles();  // samples anywhere
  const int band = continuous ? 32 : 1;
  row_empty_.assign(size_t(VH), 0);
  for (int y = 0; y < VH; y += band) {
    const int rows = std::min(band, VH - y);
    const uint64_t* records = reinterpret_cast<const uint64_t*>(f.zbuf) + size_t(y) * VW;
    if (all_empty(size_t(rows) * VW, records)) {  // nothing drawn in these rows (a sparse layer's view)
      for (int r = y; r < y + rows; ++r) {
        std::memset(out->color.ptr<uint8_t>(r), 0, size_t(VW) * 3);
        std::memset(out->depth.ptr<uint16_t>(r), 0, size_t(VW) * 2);
        std::memset(out->label.ptr<uint8_t>(r), 0, size_t(VW));
        std::memset(out->weight.ptr<uint8_t>(r), 0, size_t(VW));
        row_empty_[size_t(r)] = 1;
      }
      continue;
    }
    unpack_samples(rows * VW, f.zbuf + size_t(y) * VW, out->color.ptr<uint8_t>(y), out->depth.ptr<uint16_t>(y),
                   out->label.ptr<uint8_t>(y), out->weight.ptr<uint8_t>(y));
    std::fill_n(reinterpret_cast<uint64_t*>(f.zbuf) + size_t(y) * VW, size_t(rows) * VW, kEmptyRecord);
  }
  if (prm.close_cracks) {
    close_cracks(out, tolerance_ratio_q16(std::max(prm.step_ratio, prm.edge_ratio)),
                 tolerance_min_mm(prm.edge_min_mm), &crack_code_, &row_empty_);
  }
}

WarpedView warp_view(const CameraCalib& source, const WarpSource& in, const CameraCalib& virt,
                     const WarpParams& params) {
  ViewWarper w;
  WarpedView out;
  w.warp(source, in, virt, params, &out);
  return out;
}

}  // namespace vclassroom
