#include <gst/vclassroom/vva/view_cull.h>

#include <algorithm>
#include <cmath>

#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

TileGrid tile_grid(int width, int height) {
  return TileGrid{(width + kTileSize - 1) / kTileSize, (height + kTileSize - 1) / kTileSize};
}

void tile_ray_boxes(int W, int H, const float* ray_x, const float* ray_y, std::vector<float>* boxes) {
  const TileGrid g = tile_grid(W, H);
  boxes->assign(size_t(g.cols) * g.rows * 4, 0.0f);
  for (int ty = 0; ty < g.rows; ++ty)
    for (int tx = 0; tx < g.cols; ++tx) {
      // The tile and a pixel around it: a cell reaches half a pixel beyond its centre.
      const int u0 = std::max(0, tx * kTileSize - 1), u1 = std::min(W, (tx + 1) * kTileSize + 1);
      const int v0 = std::max(0, ty * kTileSize - 1), v1 = std::min(H, (ty + 1) * kTileSize + 1);
      float xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
      for (int v = v0; v < v1; ++v) {
        const float* rx = ray_x + size_t(v) * W;
        const float* ry = ray_y + size_t(v) * W;
        for (int u = u0; u < u1; ++u) {
          xmin = std::min(xmin, rx[u]);
          xmax = std::max(xmax, rx[u]);
          ymin = std::min(ymin, ry[u]);
          ymax = std::max(ymax, ry[u]);
        }
      }
      float* b = &(*boxes)[(size_t(ty) * g.cols + tx) * 4];
      b[0] = xmin, b[1] = xmax, b[2] = ymin, b[3] = ymax;
    }
}

namespace {

// Column by column, the nearest (0: no depth, never the nearest) and farthest depth of one more row.
VCLASSROOM_SIMD_CLONES
void fold_depth_row(int n, const uint16_t* __restrict d, uint16_t* __restrict lo, uint16_t* __restrict hi) {
  for (int u = 0; u < n; ++u) {
    const uint16_t z = d[u];
    const uint16_t near = z ? z : uint16_t(0xffff);
    lo[u] = near < lo[u] ? near : lo[u];
    hi[u] = z > hi[u] ? z : hi[u];
  }
}

}  // namespace

void tile_depth_ranges(int W, int H, const uint16_t* depth, std::vector<uint16_t>* nearest,
                       std::vector<uint16_t>* farthest) {
  const TileGrid g = tile_grid(W, H);
  nearest->assign(size_t(g.cols) * g.rows, 0xffff);
  farthest->assign(size_t(g.cols) * g.rows, 0);
  // Per row of tiles, its rows and the ring's folded into one row of columns (a loop over whole rows the
  // compiler vectorises; this runs for every camera frame), then each tile's columns and ring read from it.
  std::vector<uint16_t> lo(static_cast<size_t>(W)), hi(static_cast<size_t>(W));
  for (int ty = 0; ty < g.rows; ++ty) {
    std::fill(lo.begin(), lo.end(), uint16_t(0xffff));
    std::fill(hi.begin(), hi.end(), uint16_t(0));
    const int v0 = std::max(0, ty * kTileSize - 1), v1 = std::min(H, (ty + 1) * kTileSize + 1);
    for (int v = v0; v < v1; ++v) fold_depth_row(W, depth + size_t(v) * W, lo.data(), hi.data());
    for (int tx = 0; tx < g.cols; ++tx) {
      const int u0 = std::max(0, tx * kTileSize - 1), u1 = std::min(W, (tx + 1) * kTileSize + 1);
      const size_t i = size_t(ty) * g.cols + size_t(tx);
      const uint16_t near = *std::min_element(lo.begin() + u0, lo.begin() + u1);
      const uint16_t far = *std::max_element(hi.begin() + u0, hi.begin() + u1);
      (*nearest)[i] = far ? near : 0;  // a tile without depth: 0 .. 0
      (*farthest)[i] = far;
    }
  }
}

ViewFrustum frustum_between(const CameraCalib& source, const CameraCalib& view) {
  const Eigen::Isometry3d T = view.cam_to_rig.inverse() * source.cam_to_rig;
  ViewFrustum f{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) f.r[3 * r + c] = float(T.linear()(r, c));
    f.t[r] = float(T.translation()(r));
  }
  f.fx = float(view.fx), f.fy = float(view.fy), f.cx = float(view.cx), f.cy = float(view.cy);
  f.width = view.width, f.height = view.height;
  return f;
}

namespace {

// Whether the points whose rays lie in `box` (x / z and y / z ranges) at depths z0..z1 (m) can land within
// `margin` px of the view: the convex hull of the eight corners of that frustum piece, projected.
bool lands_in_view(const float* box, float z0, float z1, const ViewFrustum& v, float near_m, float margin) {
  float xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  int behind = 0;
  for (int k = 0; k < 8; ++k) {
    const float z = k & 4 ? z1 : z0;
    const float X = box[k & 1] * z, Y = box[2 + ((k >> 1) & 1)] * z;
    const float qx = v.r[0] * X + v.r[1] * Y + v.r[2] * z + v.t[0];
    const float qy = v.r[3] * X + v.r[4] * Y + v.r[5] * z + v.t[1];
    const float qz = v.r[6] * X + v.r[7] * Y + v.r[8] * z + v.t[2];
    if (!(qz >= near_m)) {
      ++behind;
      continue;
    }
    const float x = v.fx * qx / qz + v.cx, y = v.fy * qy / qz + v.cy;
    xmin = std::min(xmin, x), xmax = std::max(xmax, x), ymin = std::min(ymin, y), ymax = std::max(ymax, y);
  }
  if (behind == 8) return false;  // wholly behind the lens: nothing of it is drawn
  if (behind) return true;        // partly: its projection is unbounded
  return xmax >= -margin && xmin <= float(v.width - 1) + margin && ymax >= -margin &&
         ymin <= float(v.height - 1) + margin;
}

}  // namespace

void columns_in_view(int W, int H, const std::vector<float>& boxes, const std::vector<uint16_t>& nearest,
                     const std::vector<uint16_t>& farthest, const ViewFrustum& view, float near_m, float margin_px,
                     std::vector<std::pair<int, int>>* columns) {
  const TileGrid g = tile_grid(W, H);
  columns->assign(size_t(g.rows), {0, 0});
  for (int ty = 0; ty < g.rows; ++ty) {
    const size_t row = size_t(ty) * g.cols;
    auto lands = [&](int tx) {
      const size_t i = row + size_t(tx);
      return nearest[i] != 0 && lands_in_view(&boxes[i * 4], float(nearest[i]) * 0.001f,
                                              float(farthest[i]) * 0.001f, view, near_m, margin_px);
    };
    int first = 0, last = g.cols - 1;
    while (first < g.cols && !lands(first)) ++first;
    if (first == g.cols) continue;
    while (last > first && !lands(last)) --last;
    (*columns)[size_t(ty)] = {first * kTileSize, std::min(W, (last + 1) * kTileSize)};
  }
}

}  // namespace vclassroom
