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

// One row of a triangle's box: e0..e2 the biased edge functions at its first pixel, s0..s2 their steps per
// pixel, w and dw 1/z there and its step.
template <bool kCount>
VCLASSROOM_SIMD_INLINE void raster_row(float* zr, uint8_t* cr, int n, int32_t e0, int32_t e1, int32_t e2, int32_t s0,
                                       int32_t s1, int32_t s2, float w, float dw) {
  for (int i = 0; i < n; ++i) {
    const int32_t a = e0 + s0 * i, b = e1 + s1 * i, c = e2 + s2 * i;
    const float wi = w + dw * float(i);
    const bool in = (a | b | c) >= 0;
    if (kCount) cr[i] = uint8_t(cr[i] + (in ? 1 : 0));
    const float old = zr[i];
    zr[i] = in && wi > old ? wi : old;
  }
}

struct Edge {
  int64_t a, b, c;  // E(p) = a * p.x + b * p.y + c, 1/16 px units; >= 0 inside (with the fill rule's bias)
  int64_t bias;     // 0 or -1: a centre exactly on the edge belongs to this triangle or the other
};

VCLASSROOM_SIMD_INLINE Edge edge(int64_t px, int64_t py, int64_t qx, int64_t qy) {
  Edge e;
  e.a = py - qy;
  e.b = qx - px;
  e.c = -(e.a * px + e.b * py);
  // The reverse edge has (-a, -b): exactly one of the two owns the centres on it.
  e.bias = (e.a > 0 || (e.a == 0 && e.b > 0)) ? 0 : -1;
  return e;
}

template <bool kCount>
VCLASSROOM_SIMD_INLINE void raster_triangles(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy,
                                             const float* wv, int W, int H, float* inv, uint8_t* cov,
                                             size_t cov_step, RoomRasterStats* st) {
  long near = 0, empty = 0, drawn = 0, large = 0, box = 0;
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t i0 = idx[3 * t], i1 = idx[3 * t + 1], i2 = idx[3 * t + 2];
    double w0 = wv[i0], w1 = wv[i1], w2 = wv[i2];
    if (!(w0 > 0 && w1 > 0 && w2 > 0)) {
      ++near;
      continue;
    }
    int32_t x0 = sx[i0], y0 = sy[i0], x1 = sx[i1], y1 = sy[i1], x2 = sx[i2], y2 = sy[i2];
    const int32_t minx = std::min(x0, std::min(x1, x2)), maxx = std::max(x0, std::max(x1, x2));
    const int32_t miny = std::min(y0, std::min(y1, y2)), maxy = std::max(y0, std::max(y1, y2));
    const int xs = std::max((minx + kOne - 1) >> kSub, 0), xe = std::min(maxx >> kSub, W - 1);
    const int ys = std::max((miny + kOne - 1) >> kSub, 0), ye = std::min(maxy >> kSub, H - 1);
    if (xs > xe || ys > ye) {
      ++empty;
      continue;
    }
    int64_t area = int64_t(x1 - x0) * (y2 - y0) - int64_t(y1 - y0) * (x2 - x0);
    if (area == 0) {
      ++empty;
      continue;
    }
    if (area < 0) {
      std::swap(x1, x2), std::swap(y1, y2), std::swap(w1, w2);
      area = -area;
    }
    ++drawn;
    box += long(xe - xs + 1) * (ye - ys + 1);
    // Edge k is opposite vertex k: its function is vertex k's barycentric weight times the area.
    const Edge e0 = edge(x1, y1, x2, y2), e1 = edge(x2, y2, x0, y0), e2 = edge(x0, y0, x1, y1);
    const double ia = 1.0 / double(area);
    const double ga = (double(e0.a) * w0 + double(e1.a) * w1 + double(e2.a) * w2) * ia * kOne;  // per pixel in x
    const double gb = (double(e0.b) * w0 + double(e1.b) * w1 + double(e2.b) * w2) * ia * kOne;  // per pixel in y
    const int64_t px = int64_t(xs) << kSub, py = int64_t(ys) << kSub;
    const int64_t f0 = e0.a * px + e0.b * py + e0.c, f1 = e1.a * px + e1.b * py + e1.c,
                  f2 = e2.a * px + e2.b * py + e2.c;
    const double wstart = (double(f0) * w0 + double(f1) * w1 + double(f2) * w2) * ia;
    const int n = xe - xs + 1;
    if (maxx - minx < kLarge && maxy - miny < kLarge) {
      // |E| <= 2 * box width * box height < 2^31 anywhere in the box.
      int32_t r0 = int32_t(f0 + e0.bias), r1 = int32_t(f1 + e1.bias), r2 = int32_t(f2 + e2.bias);
      const int32_t s0 = int32_t(e0.a << kSub), s1 = int32_t(e1.a << kSub), s2 = int32_t(e2.a << kSub);
      const int32_t t0 = int32_t(e0.b << kSub), t1 = int32_t(e1.b << kSub), t2 = int32_t(e2.b << kSub);
      for (int y = ys; y <= ye; ++y) {
        raster_row<kCount>(inv + size_t(y) * W + xs, kCount ? cov + size_t(y) * cov_step + xs : nullptr, n, r0, r1,
                           r2, s0, s1, s2, float(wstart + gb * (y - ys)), float(ga));
        r0 += t0, r1 += t1, r2 += t2;
      }
    } else {
      ++large;
      for (int y = ys; y <= ye; ++y) {
        float* zr = inv + size_t(y) * W;
        const double wr = wstart + gb * (y - ys);
        for (int x = xs; x <= xe; ++x) {
          const int64_t qx = int64_t(x) << kSub, qy = int64_t(y) << kSub;
          const bool in = e0.a * qx + e0.b * qy + e0.c + e0.bias >= 0 && e1.a * qx + e1.b * qy + e1.c + e1.bias >= 0 &&
                          e2.a * qx + e2.b * qy + e2.c + e2.bias >= 0;
          if (!in) continue;
          if (kCount) ++cov[size_t(y) * cov_step + x];
          const float wi = float(wr + ga * (x - xs));
          if (wi > zr[x]) zr[x] = wi;
        }
      }
    }
  }
  st->near += near, st->empty += empty, st->drawn += drawn, st->large += large, st->box_pixels += box;
}

VCLASSROOM_SIMD_CLONES
void room_raster_triangles(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy, const float* wv,
                           int W, int H, float* inv, RoomRasterStats* st) {
  raster_triangles<false>(idx, nt, sx, sy, wv, W, H, inv, nullptr, 0, st);
}

void room_raster_triangles_counted(const uint32_t* idx, size_t nt, const int32_t* sx, const int32_t* sy,
                                   const float* wv, int W, int H, float* inv, uint8_t* cov, size_t cov_step,
                                   RoomRasterStats* st) {
  raster_triangles<true>(idx, nt, sx, sy, wv, W, H, inv, cov, cov_step, st);
}

VCLASSROOM_SIMD_CLONES
void room_raster_depth(size_t n, const float* inv, uint16_t* out) {
  for (size_t i = 0; i < n; ++i) {
    const float v = inv[i];
    const float d = std::min(1000.0f / std::max(v, 1e-6f) + 0.5f, 65535.0f);
    out[i] = v > 0 ? uint16_t(d) : uint16_t(0);
  }
}

// The slanted pixel quads (RoomMesh::slanted) whose edges the view does not stretch beyond their length at
// the camera plus a pixel (the warp's link across a step: max_gap_px), as triangles to draw.
void keep_untorn(const RoomMesh& mesh, const int32_t* sx, const int32_t* sy, const float* w, float fx,
                 std::vector<uint32_t>* kept) {
  kept->clear();
  const size_t nt = mesh.slanted.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t i[3] = {mesh.slanted[3 * t], mesh.slanted[3 * t + 1], mesh.slanted[3 * t + 2]};
    const float w_near = std::max(w[i[0]], std::max(w[i[1]], w[i[2]]));
    if (!(w[i[0]] > 0 && w[i[1]] > 0 && w[i[2]] > 0)) continue;
    // A pixel of the camera there, in the view (1/16 px), its diagonal, plus one pixel.
    const float limit = (fx * mesh.slanted_pixel_m[t] * w_near * 1.4143f + 1.0f) * float(kOne);
    bool torn = false;
    for (int k = 0; k < 3 && !torn; ++k) {
      const float dx = float(sx[i[k]] - sx[i[(k + 1) % 3]]), dy = float(sy[i[k]] - sy[i[(k + 1) % 3]]);
      torn = dx * dx + dy * dy > limit * limit;
    }
    if (!torn) kept->insert(kept->end(), i, i + 3);
  }
}

}  // namespace

void RoomRaster::begin(const CameraCalib& view, double near_m) {
  width_ = view.width, height_ = view.height;
  const Eigen::Isometry3d T = view.cam_to_rig.inverse();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m_[4 * r + c] = float(T.linear()(r, c));
    m_[4 * r + 3] = float(T.translation()(r));
  }
  fx_ = float(view.fx), fy_ = float(view.fy), cx_ = float(view.cx), cy_ = float(view.cy), near_ = float(near_m);
  inv_.create(height_, width_, CV_32FC1);
  inv_.setTo(0);
  stats = {};
}

void RoomRaster::draw(const RoomMesh& mesh, cv::Mat* coverage) {
  const size_t n = mesh.vertices();
  sx_.resize(n), sy_.resize(n), w_.resize(n);
  room_raster_project(n, mesh.x.data(), mesh.y.data(), mesh.z.data(), m_, fx_, fy_, cx_, cy_, near_, sx_.data(),
                      sy_.data(), w_.data());
  stats.triangles += long(mesh.triangles());
  CV_Assert(inv_.isContinuous());
  if (coverage) {
    CV_Assert(coverage->type() == CV_8UC1 && coverage->cols == width_ && coverage->rows == height_);
    room_raster_triangles_counted(mesh.index.data(), mesh.triangles(), sx_.data(), sy_.data(), w_.data(), width_,
                                  height_, inv_.ptr<float>(), coverage->ptr<uint8_t>(), coverage->step1(), &stats);
  } else {
    room_raster_triangles(mesh.index.data(), mesh.triangles(), sx_.data(), sy_.data(), w_.data(), width_, height_,
                          inv_.ptr<float>(), &stats);
  }
  if (!mesh.slanted.empty() && !coverage) {
    keep_untorn(mesh, sx_.data(), sy_.data(), w_.data(), fx_, &kept_);
    stats.triangles += long(kept_.size() / 3);
    room_raster_triangles(kept_.data(), kept_.size() / 3, sx_.data(), sy_.data(), w_.data(), width_, height_,
                          inv_.ptr<float>(), &stats);
  }
}

void RoomRaster::depth(cv::Mat* out) const {
  out->create(height_, width_, CV_16UC1);
  CV_Assert(out->isContinuous());
  room_raster_depth(inv_.total(), inv_.ptr<float>(), out->ptr<uint16_t>());
}

}  // namespace vclassroom
