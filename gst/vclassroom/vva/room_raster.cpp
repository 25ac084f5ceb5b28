#include <gst/vclassroom/vva/room_raster.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

constexpr int kSub = 4;                // sub-pixel bits of the screen coordinates
constexpr int kOne = 1 << kSub;
constexpr int32_t kLarge = 1024 << kSub;  // boxes below this on each side: 32-bit edge functions
constexpr float kFar = float(1 << 26);    // |screen coordinate| (1/16 px) beyond this: dropped as near
constexpr int kLanes = RoomRaster::kSlack;  // pixels per group of the row loop
constexpr int kTilePx = RoomRaster::kTilePx, kTileShift = 3;
static_assert(kTilePx == 1 << kTileShift, "tiles of 8 px");
int tile_cols(int pixels) { return (pixels + kTilePx - 1) / kTilePx; }  // tiles across (or down) that many

// GCC's vector extensions: 8 lanes, lowered to what each clone's target has (2 x SSE2, AVX2, AVX-512).
typedef int32_t VecI __attribute__((vector_size(4 * kLanes)));
typedef float VecF __attribute__((vector_size(4 * kLanes)));
constexpr VecI kIota = {0, 1, 2, 3, 4, 5, 6, 7};

// Vertices (rig frame) to the view's screen, 1/16 px, and 1/z (0 where dropped).
VCLASSROOM_SIMD_CLONES
void room_raster_project(size_t n, const float* x, const float* y, const float* z, const float* m, float fx, float fy,
                         float cx, float cy, float near, int32_t* sx, int32_t* sy, float* w) {
  const float fxs = fx * kOne, fys = fy * kOne, cxs = cx * kOne, cys = cy * kOne;
  for (size_t i = 0; i < n; ++i) {
    const float px = m[0] * x[i] + m[1] * y[i] + m[2] * z[i] + m[3];
    const float py = m[4] * x[i] + m[5] * y[i] + m[6] * z[i] + m[7];
    const float pz = m[8] * x[i] + m[9] * y[i] + m[10] * z[i] + m[11];
    const bool front = pz > near;
    const float iz = front ? 1.0f / pz : 0.0f;
    const float u = fxs * (px * iz) + cxs, v = fys * (py * iz) + cys;
    const bool ok = front && std::fabs(u) < kFar && std::fabs(v) < kFar;
    sx[i] = ok ? int32_t(std::floor(u + 0.5f)) : 0;
    sy[i] = ok ? int32_t(std::floor(v + 0.5f)) : 0;
    w[i] = ok ? iz : 0.0f;
  }
}


// One row of a triangle's box, n pixels, in whole groups of kLanes (the buffers' rows have kLanes pixels of
// slack at their end): a, b, c the biased edge functions at its first kLanes pixels, s0..s2 their steps per
// group, wi 1/z there and dwl its step.
template <bool kCount>
VCLASSROOM_SIMD_INLINE void raster_row(float* zr, uint8_t* cr, int n, VecI a, VecI b, VecI c, int32_t s0, int32_t s1,
                                       int32_t s2, VecF wi, float dwl) {
  VecI i = kIota;
  for (int i0 = 0; i0 < n; i0 += kLanes) {
    const VecI in = ((a | b | c) >= 0) & (i < n);
    VecF old;
    __builtin_memcpy(&old, zr + i0, sizeof old);
    const VecF nw = (in & (wi > old)) ? wi : old;
    __builtin_memcpy(zr + i0, &nw, sizeof nw);
    if (kCount)
      for (int j = 0; j < kLanes; ++j) cr[i0 + j] = uint8_t(cr[i0 + j] + (in[j] ? 1 : 0));
    a += s0, b += s1, c += s2, i += kLanes, wi += dwl;
  }
}

struct Edge {
  int64_t a, b, c;  // E(p) = a * p.x + b * p.y + c, 1/16 px units; >= 0 inside, a centre on the edge too
};

VCLASSROOM_SIMD_INLINE Edge edge(int64_t px, int64_t py, int64_t qx, int64_t qy) {
  Edge e;
  e.a = py - qy;
  e.b = qx - px;
  e.c = -(e.a * px + e.b * py);
  return e;
}

// A triangle whose screen box is 1024 px or more on a side (rare: a large tile close to the view): 64-bit edge
// functions and a double plane, one pixel at a time. Vertices in order of positive area.
__attribute__((noinline)) void raster_large(int32_t x0, int32_t y0, int32_t x1, int32_t y1, int32_t x2, int32_t y2,
                                            double w0, double w1, double w2, int xs, int xe, int ys, int ye,
                                            float* inv, size_t stride, uint8_t* cov) {
  const int64_t area = int64_t(x1 - x0) * (y2 - y0) - int64_t(y1 - y0) * (x2 - x0);
  const Edge e0 = edge(x1, y1, x2, y2), e1 = edge(x2, y2, x0, y0), e2 = edge(x0, y0, x1, y1);
  const double ia = 1.0 / double(area);
  for (int y = ys; y <= ye; ++y) {
    float* zr = inv + size_t(y) * stride;
    for (int x = xs; x <= xe; ++x) {
      const int64_t qx = int64_t(x) << kSub, qy = int64_t(y) << kSub;
      const int64_t f0 = e0.a * qx + e0.b * qy + e0.c, f1 = e1.a * qx + e1.b * qy + e1.c,
                    f2 = e2.a * qx + e2.b * qy + e2.c;
      if (f0 < 0 || f1 < 0 || f2 < 0) continue;
      if (cov) ++cov[size_t(y) * stride + x];
      const float wi = float((double(f0) * w0 + double(f1) * w1 + double(f2) * w2) * ia);
      if (wi > zr[x]) zr[x] = wi;
    }
  }
}

// The set-up of a batch of triangles, one array per value, so that it runs in vector lanes across triangles.
constexpr int kBatch = 128;
struct alignas(32) Batch {
  int32_t x0[kBatch], y0[kBatch], x1[kBatch], y1[kBatch], x2[kBatch], y2[kBatch];
  float w0[kBatch], w1[kBatch], w2[kBatch];
  // Set up: kind (0 nothing to draw, 1 drawn here, 2 the 64-bit loop, 3 at the near plane), the box (first
  // pixel, width, rows), the biased edge functions at its first centre, their coefficients, the 1/z plane.
  int32_t kind[kBatch], xs[kBatch], ys[kBatch], n[kBatch], rows[kBatch];
  int32_t r0[kBatch], r1[kBatch], r2[kBatch], a0[kBatch], a1[kBatch], a2[kBatch], b0[kBatch], b1[kBatch], b2[kBatch];
  float ga[kBatch], gb[kBatch], ws[kBatch];
};

// Products in uint32_t (wrapping) where a lane's triangle may be one that is not drawn here; for the ones
// that are, every value is under 2^29 in magnitude (the box is under 2^14 sixteenths on a side, and so is any
// vertex's distance from a point of it).
VCLASSROOM_SIMD_INLINE int32_t wrap(uint32_t v) { return int32_t(v); }

VCLASSROOM_SIMD_INLINE void setup_batch(Batch& b, int m, int W, int H) {
  for (int j = 0; j < m; ++j) {
    const float w0 = b.w0[j], w1 = b.w1[j], w2 = b.w2[j];
    const int32_t x0 = b.x0[j], y0 = b.y0[j], x1 = b.x1[j], y1 = b.y1[j], x2 = b.x2[j], y2 = b.y2[j];
    const int32_t minx = std::min(x0, std::min(x1, x2)), maxx = std::max(x0, std::max(x1, x2));
    const int32_t miny = std::min(y0, std::min(y1, y2)), maxy = std::max(y0, std::max(y1, y2));
    const int32_t xs = std::max((minx + kOne - 1) >> kSub, 0), xe = std::min(maxx >> kSub, W - 1);
    const int32_t ys = std::max((miny + kOne - 1) >> kSub, 0), ye = std::min(maxy >> kSub, H - 1);
    const uint32_t ox = uint32_t(xs) << kSub, oy = uint32_t(ys) << kSub;
    // Relative to the box's first pixel centre.
    const uint32_t X0 = uint32_t(x0) - ox, Y0 = uint32_t(y0) - oy;
    uint32_t X1 = uint32_t(x1) - ox, Y1 = uint32_t(y1) - oy, X2 = uint32_t(x2) - ox, Y2 = uint32_t(y2) - oy;
    int32_t area = wrap((X1 - X0) * (Y2 - Y0) - (Y1 - Y0) * (X2 - X0));
    const bool neg = area < 0;
    const uint32_t tx = X1, ty = Y1;
    X1 = neg ? X2 : X1, Y1 = neg ? Y2 : Y1, X2 = neg ? tx : X2, Y2 = neg ? ty : Y2;
    const float v1 = neg ? w2 : w1, v2 = neg ? w1 : w2;
    area = neg ? wrap(0u - uint32_t(area)) : area;
    // Edge k is opposite vertex k, from P to Q: a = P.y - Q.y, b = Q.x - P.x, its value at the box's first
    // centre -(a P.x + b P.y); it is vertex k's barycentric weight times the area.
    const int32_t a0 = wrap(Y1 - Y2), b0 = wrap(X2 - X1), a1 = wrap(Y2 - Y0), b1 = wrap(X0 - X2), a2 = wrap(Y0 - Y1),
                  b2 = wrap(X1 - X0);
    const int32_t f0 = wrap(0u - (uint32_t(a0) * X1 + uint32_t(b0) * Y1)),
                  f1 = wrap(0u - (uint32_t(a1) * X2 + uint32_t(b1) * Y2)),
                  f2 = wrap(0u - (uint32_t(a2) * X0 + uint32_t(b2) * Y0));
    // A centre exactly on an edge (value 0) is inside: both triangles that share the edge draw it (at one
    // depth), and a mesh's own border, which a view from the mesh's camera sees through pixel centres, is drawn.
    b.r0[j] = f0, b.r1[j] = f1, b.r2[j] = f2;
    b.a0[j] = a0 * kOne, b.a1[j] = a1 * kOne, b.a2[j] = a2 * kOne;
    b.b0[j] = b0 * kOne, b.b1[j] = b1 * kOne, b.b2[j] = b2 * kOne;
    // 1/z = v2 + E0 (w0 - v2) / area + E1 (v1 - v2) / area (inf or NaN where area is 0: not drawn).
    const float ia = 1.0f / float(area), d0 = (w0 - v2) * ia, d1 = (v1 - v2) * ia;
    b.ga[j] = (float(a0) * d0 + float(a1) * d1) * kOne;
    b.gb[j] = (float(b0) * d0 + float(b1) * d1) * kOne;
    b.ws[j] = v2 + (float(f0) * d0 + float(f1) * d1);
    b.xs[j] = xs, b.ys[j] = ys, b.n[j] = xe - xs + 1, b.rows[j] = ye - ys + 1;
    const int32_t front = int32_t(w0 > 0) & int32_t(w1 > 0) & int32_t(w2 > 0),
                  some = int32_t(xs <= xe) & int32_t(ys <= ye),
                  small = int32_t(maxx - minx < kLarge) & int32_t(maxy - miny < kLarge), flat = int32_t(area == 0);
    const int32_t k1 = (small & (flat ^ 1)) | ((small ^ 1) << 1);  // 1 drawn here, 2 the 64-bit loop, 0 flat
    const int32_t k2 = some ? k1 : 0;
    b.kind[j] = front ? k2 : 3;
  }
}

// Where a triangle may be skipped (RoomRaster::draw_where_empty): per tile of kTilePx, whether another raster
// left a pixel of it empty; null: draw everything.
struct TileMask {
  const uint8_t* empty = nullptr;
  int cols = 0;
  // Whether the box (first pixel, width, rows) touches a tile with an empty pixel.
  bool touches_empty(int xs, int ys, int n, int rows) const {
    const int tx0 = xs >> kTileShift, tx1 = (xs + n - 1) >> kTileShift;
    const int ty0 = ys >> kTileShift, ty1 = (ys + rows - 1) >> kTileShift;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx)
        if (empty[size_t(ty) * cols + tx]) return true;
    return false;
  }
};

template <bool kCount>
VCLASSROOM_SIMD_INLINE void raster_triangles(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy,
                                             const float* wv, int W, int H, float* inv, size_t stride, uint8_t* cov,
                                             const TileMask& mask, RoomRasterStats* st) {
  long near = 0, empty = 0, drawn = 0, large = 0, box = 0, skipped = 0;
  Batch b;
  for (size_t t0 = 0; t0 < nt; t0 += kBatch) {
    const int m = int(std::min<size_t>(kBatch, nt - t0));
    for (int j = 0; j < m; ++j) {
      const uint32_t* v = idx + 3 * (t0 + size_t(j));
      b.x0[j] = sx[v[0]], b.y0[j] = sy[v[0]], b.w0[j] = wv[v[0]];
      b.x1[j] = sx[v[1]], b.y1[j] = sy[v[1]], b.w1[j] = wv[v[1]];
      b.x2[j] = sx[v[2]], b.y2[j] = sy[v[2]], b.w2[j] = wv[v[2]];
    }
    setup_batch(b, m, W, H);
    for (int j = 0; j < m; ++j) {
      const int kind = b.kind[j];
      if (mask.empty && (kind == 1 || kind == 2) && !mask.touches_empty(b.xs[j], b.ys[j], b.n[j], b.rows[j])) {
        ++skipped;
        continue;
      }
      if (kind != 1) {
        if (kind == 3) {
          ++near;
        } else if (kind == 0) {
          ++empty;
        } else {
          const int32_t x0 = b.x0[j], y0 = b.y0[j], x1 = b.x1[j], y1 = b.y1[j], x2 = b.x2[j], y2 = b.y2[j];
          const int64_t area = int64_t(x1 - x0) * (y2 - y0) - int64_t(y1 - y0) * (x2 - x0);
          if (area == 0) {
            ++empty;
            continue;
          }
          ++large, ++drawn;
          const int xs = b.xs[j], ys = b.ys[j], xe = xs + b.n[j] - 1, ye = ys + b.rows[j] - 1;
          box += long(b.n[j]) * b.rows[j];
          if (area > 0)
            raster_large(x0, y0, x1, y1, x2, y2, b.w0[j], b.w1[j], b.w2[j], xs, xe, ys, ye, inv, stride,
                         kCount ? cov : nullptr);
          else
            raster_large(x0, y0, x2, y2, x1, y1, b.w0[j], b.w2[j], b.w1[j], xs, xe, ys, ye, inv, stride,
                         kCount ? cov : nullptr);
        }
        continue;
      }
      ++drawn;
      const int n = b.n[j], rows = b.rows[j];
      box += long(n) * rows;
      float* zr = inv + size_t(b.ys[j]) * stride + b.xs[j];
      uint8_t* cr = kCount ? cov + size_t(b.ys[j]) * stride + b.xs[j] : nullptr;
      const int32_t s0 = b.a0[j], s1 = b.a1[j], s2 = b.a2[j], t0r = b.b0[j], t1r = b.b1[j], t2r = b.b2[j];
      const float ga = b.ga[j], gb = b.gb[j];
      // Per row the first kLanes pixels: the row's start plus these.
      const VecI sa0 = s0 * kIota, sa1 = s1 * kIota, sa2 = s2 * kIota;
      const VecF sw = ga * __builtin_convertvector(kIota, VecF);
      int32_t e0 = b.r0[j], e1 = b.r1[j], e2 = b.r2[j];
      float wr = b.ws[j];
      if (!kCount && n <= kLanes) {  // one group a row (most triangles: a pixel or two): raster_row's, unrolled
        const VecI within = kIota < n;
        VecI a = e0 + sa0, bb = e1 + sa1, c = e2 + sa2;
        for (int y = 0; y < rows; ++y) {
          const VecI in = ((a | bb | c) >= 0) & within;
          const VecF wi = wr + sw;
          VecF old;
          __builtin_memcpy(&old, zr, sizeof old);
          const VecF nw = (in & (wi > old)) ? wi : old;
          __builtin_memcpy(zr, &nw, sizeof nw);
          a += t0r, bb += t1r, c += t2r, wr = b.ws[j] + gb * float(y + 1);
          zr += stride;
        }
        continue;
      }
      for (int y = 0; y < rows; ++y) {
        raster_row<kCount>(zr, cr, n, e0 + sa0, e1 + sa1, e2 + sa2, s0 * kLanes, s1 * kLanes, s2 * kLanes, wr + sw,
                           ga * kLanes);
        e0 += t0r, e1 += t1r, e2 += t2r, wr = b.ws[j] + gb * float(y + 1);
        zr += stride;
        if (kCount) cr += stride;
      }
    }
  }
  st->near += near, st->empty += empty, st->drawn += drawn, st->large += large, st->box_pixels += box;
  st->skipped += skipped;
}

VCLASSROOM_SIMD_CLONES
void room_raster_triangles(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy, const float* wv,
                           int W, int H, float* inv, size_t stride, const TileMask& mask, RoomRasterStats* st) {
  raster_triangles<false>(idx, nt, sx, sy, wv, W, H, inv, stride, nullptr, mask, st);
}

VCLASSROOM_SIMD_CLONES
void room_raster_triangles_counted(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy,
                                   const float* wv, int W, int H, float* inv, size_t stride, uint8_t* cov,
                                   RoomRasterStats* st) {
  raster_triangles<true>(idx, nt, sx, sy, wv, W, H, inv, stride, cov, TileMask{}, st);
}

// One row of RoomRaster::empty_tiles: a tile's 8 pixels at a time.
VCLASSROOM_SIMD_CLONES
void mark_empty_tiles(int n, const uint16_t* __restrict r, uint8_t* __restrict tiles) {
  const int whole = n / kTilePx;
  for (int t = 0; t < whole; ++t) {
    int empty = 0;
    for (int i = 0; i < kTilePx; ++i) empty |= int(r[t * kTilePx + i] == 0);
    tiles[t] |= uint8_t(empty);
  }
  for (int x = whole * kTilePx; x < n; ++x) tiles[x >> kTileShift] |= uint8_t(r[x] == 0);
}

VCLASSROOM_SIMD_CLONES
void room_raster_depth(size_t n, const float* inv, uint16_t* out) {
  for (size_t i = 0; i < n; ++i) {
    const float v = inv[i];
    const float d = std::min(1000.0f / std::max(v, 1e-6f) + 0.5f, 65535.0f);
    out[i] = v > 0 ? uint16_t(d) : uint16_t(0);
  }
}

}  // namespace

void RoomRaster::set_view(const CameraCalib& view, double near_m) {
  width_ = view.width, height_ = view.height;
  const Eigen::Isometry3d T = view.cam_to_rig.inverse();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m_[4 * r + c] = float(T.linear()(r, c));
    m_[4 * r + 3] = float(T.translation()(r));
  }
  fx_ = float(view.fx), fy_ = float(view.fy), cx_ = float(view.cx), cy_ = float(view.cy), near_ = float(near_m);
  stats = {};
}

void RoomRaster::begin(const CameraCalib& view, double near_m) {
  set_view(view, near_m);
  buf_.create(height_, width_ + kSlack, CV_32FC1);
  buf_ = cv::Scalar::all(0);
  inv_ = buf_.colRange(0, width_);
}

void RoomRaster::begin_in_tiles(const CameraCalib& view, const SampleTiles& tiles, double near_m) {
  set_view(view, near_m);
  if (buf_.rows != height_ || buf_.cols != width_ + kSlack || buf_.type() != CV_32FC1) {
    buf_.create(height_, width_ + kSlack, CV_32FC1);
    buf_ = cv::Scalar::all(0);
  } else {
    CV_Assert(tiles.fit(width_, height_));
    for_each_tile_span(tiles, height_, [&](int y, int x0, int x1) {
      std::fill(buf_.ptr<float>(y) + x0, buf_.ptr<float>(y) + x1, 0.0f);
    });
  }
  inv_ = buf_.colRange(0, width_);
}

void RoomRaster::draw(const RoomMesh& mesh, cv::Mat* coverage) { draw_masked(mesh, true, coverage, {}); }

void RoomRaster::draw_leaves(const RoomMesh& mesh) { draw_masked(mesh, false, nullptr, {}); }

void RoomRaster::draw_where_empty(const RoomMesh& mesh, const std::vector<uint8_t>& empty_tiles) {
  CV_Assert(empty_tiles.size() == size_t(tile_cols(width_)) * tile_cols(height_));
  draw_masked(mesh, false, nullptr, empty_tiles);
}

void RoomRaster::empty_tiles(const cv::Mat& depth, std::vector<uint8_t>* out) {
  CV_Assert(depth.type() == CV_16UC1);
  const int cols = tile_cols(depth.cols);
  out->assign(size_t(cols) * tile_cols(depth.rows), 0);
  for (int y = 0; y < depth.rows; ++y)
    mark_empty_tiles(depth.cols, depth.ptr<uint16_t>(y), out->data() + size_t(y >> kTileShift) * cols);
}

void RoomRaster::draw_masked(const RoomMesh& mesh, bool edges, cv::Mat* coverage,
                             const std::vector<uint8_t>& empty_tiles) {
  const size_t n = edges ? mesh.vertices() : std::min(mesh.edge_vertex_begin, mesh.vertices());
  const size_t triangles = edges ? mesh.triangles() : std::min(mesh.edge_begin, mesh.triangles());
  sx_.resize(n), sy_.resize(n), w_.resize(n);
  room_raster_project(n, mesh.x.data(), mesh.y.data(), mesh.z.data(), m_, fx_, fy_, cx_, cy_, near_, sx_.data(),
                      sy_.data(), w_.data());
  stats.triangles += long(triangles);
  const size_t stride = buf_.step1();
  if (coverage) {
    CV_Assert(coverage->type() == CV_8UC1 && coverage->cols == width_ && coverage->rows == height_);
    cv::Mat cov(height_, int(stride), CV_8UC1, cv::Scalar(0));
    room_raster_triangles_counted(mesh.index.data(), triangles, sx_.data(), sy_.data(), w_.data(), width_,
                                  height_, buf_.ptr<float>(), stride, cov.ptr<uint8_t>(), &stats);
    *coverage += cov.colRange(0, width_);
  } else {
    const TileMask mask{empty_tiles.empty() ? nullptr : empty_tiles.data(), tile_cols(width_)};
    room_raster_triangles(mesh.index.data(), triangles, sx_.data(), sy_.data(), w_.data(), width_, height_,
                          buf_.ptr<float>(), stride, mask, &stats);
  }
}

void RoomRaster::depth(cv::Mat* out) const {
  out->create(height_, width_, CV_16UC1);
  for (int y = 0; y < height_; ++y) room_raster_depth(size_t(width_), inv_.ptr<float>(y), out->ptr<uint16_t>(y));
}

void RoomRaster::depth_in_tiles(cv::Mat* out, const SampleTiles& tiles) const {
  CV_Assert(tiles.fit(width_, height_));
  if (out->rows != height_ || out->cols != width_ || out->type() != CV_16UC1)
    *out = cv::Mat::zeros(height_, width_, CV_16UC1);
  for_each_tile_span(tiles, height_, [&](int y, int x0, int x1) {
    room_raster_depth(size_t(x1 - x0), inv_.ptr<float>(y) + x0, out->ptr<uint16_t>(y) + x0);
  });
}

}  // namespace vclassroom
