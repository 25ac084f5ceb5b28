// The hole filling of a fused view (hole_fill.h): the depth-aware push-pull pyramid, and the smoothing both
// methods share. The fill before issue 35 is in hole_fill_rays.cpp.
#include <gst/vclassroom/vva/hole_fill.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

namespace {

// The pyramid is built only around the holes: the image is cut into square tiles of kTile px, and the tiles
// holding a hole and their 8 neighbours are "active". One tile is one cell at level kTileLevels; the levels
// below it are worked tile by tile, the levels above (a 960x540 view: 30x17 cells and fewer) whole.
constexpr int kTileLevels = 4;
constexpr int kTile = 1 << kTileLevels;

// A hole pixel's colour is the mean of its background ray ends (weighted by 1 / distance, as the rays
// method) and the pyramid's value, which counts as much as one ray end kPyramidDistance px away: next to the
// background the nearest pixels decide (a structure that meets the hole goes on into it for a few pixels;
// the 1-px smoothing after the fill keeps the edge soft), farther in the smooth 2-D surface does (no streak
// drawn from one row or column across a wide hole). 4 px was chosen among 2, 4 and 10 on Middlebury Art and
// Aloe; the three are within 0.1 dB at every offset (docs/vva.md).
constexpr float kPyramidDistance = 4.0f;
constexpr float kPyramidWeight = 1.0f / kPyramidDistance;

// The smoothing after each method (HoleFillParams::smooth_px -1): the pyramid's fill is smooth already, so
// 1 px (on Middlebury 1 px gave +0.1 to +0.2 dB over 2 at small offsets, the same at wide ones, and Teddy
// +0.2); the rays' 2 px, as before issue 35.
constexpr int kPyramidSmoothPx = 1, kRaysSmoothPx = 2;

// A pyramid cell: the mean colour and depth of the far-side samples under it; z == 0: none (yet).
struct Cell {
  float r, g, b, z;
};

struct Level {
  int w = 0, h = 0;
  std::vector<Cell> cells;
  Cell* row(int y) { return cells.data() + size_t(y) * size_t(w); }
  const Cell* row(int y) const { return cells.data() + size_t(y) * size_t(w); }
};

// Whether any of 4 depths packed in `v` is 0 (a hole).
inline bool any_zero_u16x4(uint64_t v) { return ((v - 0x0001000100010001ull) & ~v & 0x8000800080008000ull) != 0; }

// Marks the tiles holding at least one hole; false when there is none.
bool find_hole_tiles(const cv::Mat& depth, int tiles_x, std::vector<uint8_t>* hole_tile) {
  const int W = depth.cols, H = depth.rows;
  bool any = false;
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    uint8_t* tiles = hole_tile->data() + size_t(y / kTile) * size_t(tiles_x);
    for (int tx = 0; tx < tiles_x; ++tx) {
      if (tiles[tx]) continue;
      const int x0 = tx * kTile, x1 = std::min(W, x0 + kTile);
      int x = x0;
      for (; x + 4 <= x1; x += 4) {
        uint64_t v;
        std::memcpy(&v, d + x, 8);
        if (any_zero_u16x4(v)) break;
      }
      for (; x < x1; ++x)
        if (!d[x]) break;
      if (x < x1) tiles[tx] = 1, any = true;
    }
  }
  return any;
}

// The mean of the samples among `n` that hold a value (z > 0); z stays 0 when none does. Every sample in
// the pyramid is background already (fill_along_rays_and_mark_sources), so no depth test is needed between levels.
inline Cell mean_of(const Cell* s, int n) {
  Cell out{0, 0, 0, 0};
  float count = 0;
  for (int i = 0; i < n; ++i) {
    if (s[i].z <= 0) continue;
    out.r += s[i].r;
    out.g += s[i].g;
    out.b += s[i].b;
    out.z += s[i].z;
    count += 1;
  }
  if (count == 0) return out;
  const float inv = 1.0f / count;
  return Cell{out.r * inv, out.g * inv, out.b * inv, out.z * inv};
}

// The first half of the fill, along rays. For each hole pixel the known pixels that end its run of holes
// along its row and its column (its left, right, upper and lower neighbour across the hole) are compared:
// those on its far side (within `keep` times the farthest of the four) are its background. Their mean,
// weighted by 1 / distance, goes into `color` at the hole pixel and the sum of the weights into
// `ray_weight`; and they are marked in `source` (CV_8UC1, zero on entry) as the pixels the pyramid may fill
// from. The foreground that caused a hole ends its runs on the near side and never counts; nor does a surface
// farther back that does not border the hole (a far wall seen beside the object behind which the hole
// opened: a "farthest in the neighbourhood" rule took its colour, -0.5 dB on Art). Rows are scanned four
// depths at a time; a hole's column ends come from a per-column state (the known row above and below the
// column's current run of holes, found by walking down the run once), as in the rays method.
void fill_along_rays_and_mark_sources(const cv::Mat& depth, float keep, cv::Mat& source, cv::Mat& color, cv::Mat& ray_weight) {
  const int W = depth.cols, H = depth.rows;
  static thread_local std::vector<int> above, below;
  above.assign(size_t(W), -1), below.assign(size_t(W), -1);
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    uint8_t* s = source.ptr<uint8_t>(y);
    int x = 0;
    while (x < W) {
      if (x + 4 <= W) {
        uint64_t v;
        std::memcpy(&v, d + x, 8);
        if (!any_zero_u16x4(v)) {
          x += 4;
          continue;
        }
      }
      if (d[x]) {
        ++x;
        continue;
      }
      const int a = x;
      while (x < W && !d[x]) ++x;
      const int b = x - 1;  // holes a..b
      const int z_left = a > 0 ? d[a - 1] : 0, z_right = b + 1 < W ? d[b + 1] : 0;
      for (int h = a; h <= b; ++h) {
        if (below[h] < y) {
          above[h] = y - 1;
          int yb = y + 1;
          while (yb < H && !depth.ptr<uint16_t>(yb)[h]) ++yb;
          below[h] = yb;
        }
        const int z_up = above[h] >= 0 ? depth.ptr<uint16_t>(above[h])[h] : 0;
        const int z_down = below[h] < H ? depth.ptr<uint16_t>(below[h])[h] : 0;
        const int zmax = std::max(std::max(z_left, z_right), std::max(z_up, z_down));
        const float zlo = float(zmax) * keep;
        float acc[3] = {0, 0, 0}, wsum = 0;
        auto take = [&](int dist, const uint8_t* c) {
          const float w = 1.0f / float(dist);
          acc[0] += w * c[0], acc[1] += w * c[1], acc[2] += w * c[2], wsum += w;
        };
        if (z_left && float(z_left) >= zlo) s[a - 1] = 1, take(h - a + 1, color.ptr<uint8_t>(y) + 3 * (a - 1));
        if (z_right && float(z_right) >= zlo) s[b + 1] = 1, take(b + 1 - h, color.ptr<uint8_t>(y) + 3 * (b + 1));
        if (z_up && float(z_up) >= zlo)
          source.ptr<uint8_t>(above[h])[h] = 1, take(y - above[h], color.ptr<uint8_t>(above[h]) + 3 * h);
        if (z_down && float(z_down) >= zlo)
          source.ptr<uint8_t>(below[h])[h] = 1, take(below[h] - y, color.ptr<uint8_t>(below[h]) + 3 * h);
        ray_weight.ptr<float>(y)[h] = wsum;
        if (wsum > 0) {
          uint8_t* c = color.ptr<uint8_t>(y) + 3 * h;
          for (int k = 0; k < 3; ++k) c[k] = uint8_t(acc[k] / wsum + 0.5f);
        }
      }
    }
  }
}

// Level 1 from the image, over the cells [x0, x1) x [y0, y1).
void push_from_image(const cv::Mat& color, const cv::Mat& depth, const cv::Mat& source, Level& up, int x0, int x1,
                     int y0, int y1) {
  const int W = color.cols, H = color.rows;
  for (int Y = y0; Y < y1; ++Y) {
    Cell* out = up.row(Y);
    for (int X = x0; X < x1; ++X) {
      Cell s[4];
      int n = 0;
      for (int j = 0; j < 2; ++j) {
        const int y = 2 * Y + j;
        if (y >= H) break;
        const uint16_t* d = depth.ptr<uint16_t>(y);
        const uint8_t* c = color.ptr<uint8_t>(y);
        const uint8_t* src = source.ptr<uint8_t>(y);
        for (int i = 0; i < 2; ++i) {
          const int x = 2 * X + i;
          if (x >= W) break;
          if (src[x]) s[n++] = Cell{float(c[3 * x]), float(c[3 * x + 1]), float(c[3 * x + 2]), float(d[x])};
        }
      }
      out[X] = mean_of(s, n);
    }
  }
}

// Level l + 1 from level l, over the cells [x0, x1) x [y0, y1). `child_known(x, y)` says whether a level-l
// cell was computed this time (the cells of tiles that are not active keep an older frame's values).
template <typename Known>
void push_level(const Level& down, Level& up, int x0, int x1, int y0, int y1, Known child_known) {
  for (int Y = y0; Y < y1; ++Y) {
    Cell* out = up.row(Y);
    for (int X = x0; X < x1; ++X) {
      Cell s[4];
      int n = 0;
      for (int j = 0; j < 2; ++j) {
        const int y = 2 * Y + j;
        if (y >= down.h) break;
        const Cell* in = down.row(y);
        for (int i = 0; i < 2; ++i) {
          const int x = 2 * X + i;
          if (x < down.w && child_known(x, y)) s[n++] = in[x];
        }
      }
      out[X] = mean_of(s, n);
    }
  }
}

// The two parents (and their bilinear weights) along one axis of cell `c` of a level whose next coarser
// level has `n` cells along that axis: cell centres at (c + 0.5) / 2 - 0.5 in the coarser level.
inline void parents_of(int c, int n, int* p0, int* p1, float* w0, float* w1) {
  if (c & 1) {
    *p0 = c >> 1, *p1 = std::min((c >> 1) + 1, n - 1), *w0 = 0.75f, *w1 = 0.25f;
  } else {
    *p0 = std::max((c >> 1) - 1, 0), *p1 = c >> 1, *w0 = 0.25f, *w1 = 0.75f;
  }
}

// The value of cell (x, y) from the next coarser level: the bilinear interpolation of those of its four
// parents that hold a value.
inline Cell pull_from(const Level& up, int x, int y) {
  int px0, px1, py0, py1;
  float wx0, wx1, wy0, wy1;
  parents_of(x, up.w, &px0, &px1, &wx0, &wx1);
  parents_of(y, up.h, &py0, &py1, &wy0, &wy1);
  const Cell p[4] = {up.row(py0)[px0], up.row(py0)[px1], up.row(py1)[px0], up.row(py1)[px1]};
  const float w[4] = {wx0 * wy0, wx1 * wy0, wx0 * wy1, wx1 * wy1};
  Cell out{0, 0, 0, 0};
  float wsum = 0;
  for (int i = 0; i < 4; ++i) {
    if (p[i].z <= 0) continue;
    out.r += w[i] * p[i].r;
    out.g += w[i] * p[i].g;
    out.b += w[i] * p[i].b;
    out.z += w[i] * p[i].z;
    wsum += w[i];
  }
  if (wsum == 0) return out;
  const float inv = 1.0f / wsum;
  return Cell{out.r * inv, out.g * inv, out.b * inv, out.z * inv};
}

// The pyramid's state, kept between calls (a view's holes change little from frame to frame, the buffers'
// sizes not at all).
struct PyramidState {
  std::vector<Level> levels;      // levels[0] stands for the image and holds nothing
  std::vector<uint8_t> hole_tile, active;  // per tile
  std::vector<std::vector<uint8_t>> needed;  // above kTileLevels: per cell, whether it lies over an active tile
  cv::Mat source;  // the pixels the fill may take colour from (fill_along_rays_and_mark_sources)
  cv::Mat ray_weight;
};

// The cells of level `l` (1 <= l <= kTileLevels) inside tile (tx, ty).
inline void tile_cells(const Level& lv, int l, int tx, int ty, int* x0, int* x1, int* y0, int* y1) {
  const int side = kTile >> l;
  *x0 = tx * side, *x1 = std::min(lv.w, *x0 + side);
  *y0 = ty * side, *y1 = std::min(lv.h, *y0 + side);
}

}  // namespace

// The push builds the levels up from the image until a level has a value over every active tile (a hole
// is never wider than the cells there); the pull then fills, level by level back down, every cell without a
// value from the next coarser one, and at level 0 every hole pixel. At both steps only the far side of the
// samples counts, so the foreground beside a hole (nearer than the hole's background by more than
// `background_ratio`) never reaches it, at whatever scale.
void fill_holes_by_pyramid(cv::Mat& color, const cv::Mat& depth, double background_ratio, cv::Mat& mask,
                           cv::Mat* filled_depth) {
  const int W = color.cols, H = color.rows;
  const int tiles_x = (W + kTile - 1) / kTile, tiles_y = (H + kTile - 1) / kTile;
  static thread_local PyramidState st;
  st.hole_tile.assign(size_t(tiles_x) * size_t(tiles_y), 0);
  if (!find_hole_tiles(depth, tiles_x, &st.hole_tile)) return;
  st.active.assign(st.hole_tile.size(), 0);
  for (int ty = 0; ty < tiles_y; ++ty)
    for (int tx = 0; tx < tiles_x; ++tx) {
      if (!st.hole_tile[size_t(ty) * tiles_x + tx]) continue;
      for (int y = std::max(0, ty - 1); y <= std::min(tiles_y - 1, ty + 1); ++y)
        for (int x = std::max(0, tx - 1); x <= std::min(tiles_x - 1, tx + 1); ++x) st.active[size_t(y) * tiles_x + x] = 1;
    }
  auto active_tile = [&](int tx, int ty) { return st.active[size_t(ty) * tiles_x + tx] != 0; };
  const float keep = float(1.0 - background_ratio);
  st.source.create(H, W, CV_8UC1);
  st.source.setTo(0);
  st.ray_weight.create(H, W, CV_32FC1);
  fill_along_rays_and_mark_sources(depth, keep, st.source, color, st.ray_weight);


  // Push. Levels 1..kTileLevels tile by tile, then whole levels until one has no empty cell over an active
  // tile, or is a single cell.
  std::vector<Level>& lv = st.levels;
  if (lv.empty()) lv.resize(1);
  lv[0].w = W, lv[0].h = H;
  int top = 0;
  for (int l = 1;; ++l) {
    if (int(lv.size()) <= l) lv.emplace_back();
    Level& up = lv[size_t(l)];
    up.w = (lv[size_t(l) - 1].w + 1) / 2, up.h = (lv[size_t(l) - 1].h + 1) / 2;
    up.cells.resize(size_t(up.w) * size_t(up.h));
    bool empty = false;
    if (l <= kTileLevels) {
      for (int ty = 0; ty < tiles_y; ++ty)
        for (int tx = 0; tx < tiles_x; ++tx) {
          if (!active_tile(tx, ty)) continue;
          int x0, x1, y0, y1;
          tile_cells(up, l, tx, ty, &x0, &x1, &y0, &y1);
          if (l == 1)
            push_from_image(color, depth, st.source, up, x0, x1, y0, y1);
          else
            push_level(lv[size_t(l) - 1], up, x0, x1, y0, y1, [](int, int) { return true; });
          for (int y = y0; y < y1 && !empty; ++y)
            for (int x = x0; x < x1; ++x) empty |= up.row(y)[x].z <= 0;
        }
    } else {
      const size_t n = size_t(l - kTileLevels);
      if (st.needed.size() < n) st.needed.resize(n);
      std::vector<uint8_t>& need = st.needed[n - 1];
      need.assign(up.cells.size(), 0);
      const int below_w = lv[size_t(l) - 1].w;
      const uint8_t* below_need = n >= 2 ? st.needed[n - 2].data() : st.active.data();
      // Level kTileLevels is the tile grid (its cells are the tiles, row length tiles_x == its width).
      auto child_known = [&](int x, int y) { return below_need[size_t(y) * below_w + x] != 0; };
      push_level(lv[size_t(l) - 1], up, 0, up.w, 0, up.h, child_known);
      for (int Y = 0; Y < up.h; ++Y)
        for (int X = 0; X < up.w; ++X) {
          bool any = false;
          for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
              const int x = 2 * X + i, y = 2 * Y + j;
              any |= x < below_w && y < lv[size_t(l) - 1].h && child_known(x, y);
            }
          need[size_t(Y) * up.w + X] = any;
          empty |= any && up.row(Y)[X].z <= 0;
        }
    }
    top = l;
    if (!empty || (up.w == 1 && up.h == 1)) break;
  }

  // Pull, from the level below the top down to level 1: each empty cell over an active tile from its parents.
  for (int l = top - 1; l >= 1; --l) {
    Level& here = lv[size_t(l)];
    const Level& up = lv[size_t(l) + 1];
    auto fill_cells = [&](int x0, int x1, int y0, int y1, const uint8_t* need) {
      for (int y = y0; y < y1; ++y) {
        Cell* c = here.row(y);
        for (int x = x0; x < x1; ++x)
          if (c[x].z <= 0 && (!need || need[size_t(y) * here.w + x])) c[x] = pull_from(up, x, y);
      }
    };
    if (l <= kTileLevels) {
      for (int ty = 0; ty < tiles_y; ++ty)
        for (int tx = 0; tx < tiles_x; ++tx) {
          if (!st.hole_tile[size_t(ty) * tiles_x + tx]) continue;  // only tiles with holes have empty cells
          int x0, x1, y0, y1;
          tile_cells(here, l, tx, ty, &x0, &x1, &y0, &y1);
          fill_cells(x0, x1, y0, y1, nullptr);
        }
    } else {
      fill_cells(0, here.w, 0, here.h, st.needed[size_t(l - kTileLevels) - 1].data());
    }
  }

  // Level 0: every hole pixel from level 1.
  const Level& one = lv[1];
  for (int ty = 0; ty < tiles_y; ++ty)
    for (int tx = 0; tx < tiles_x; ++tx) {
      if (!st.hole_tile[size_t(ty) * tiles_x + tx]) continue;
      const int x0 = tx * kTile, x1 = std::min(W, x0 + kTile), y1 = std::min(H, (ty + 1) * kTile);
      for (int y = ty * kTile; y < y1; ++y) {
        const uint16_t* d = depth.ptr<uint16_t>(y);
        uint8_t* c = color.ptr<uint8_t>(y);
        uint8_t* m = mask.ptr<uint8_t>(y);
        uint16_t* fd = filled_depth ? filled_depth->ptr<uint16_t>(y) : nullptr;
        for (int x = x0; x < x1; ++x) {
          if (d[x]) continue;
          const Cell v = pull_from(one, x, y);
          if (v.z <= 0) continue;  // nothing known anywhere near
          const float wr = st.ray_weight.ptr<float>(y)[x], inv = 1.0f / (wr + kPyramidWeight);
          c[3 * x] = uint8_t((wr * c[3 * x] + kPyramidWeight * v.r) * inv + 0.5f);
          c[3 * x + 1] = uint8_t((wr * c[3 * x + 1] + kPyramidWeight * v.g) * inv + 0.5f);
          c[3 * x + 2] = uint8_t((wr * c[3 * x + 2] + kPyramidWeight * v.b) * inv + 0.5f);
          m[x] = 255;
          if (fd) fd[x] = uint16_t(std::min(v.z + 0.5f, 65535.f));
        }
      }
    }
}

void smooth_filled_pixels(cv::Mat& color, const cv::Mat& filled, int smooth_px) {
  if (smooth_px <= 0) return;
  // Blur rects: runs of tiles holding filled pixels per band of rows. cv::blur on a view of the image reads
  // the pixels around it from the whole image, so each rect comes out as the same part of a blur of the whole
  // image; all are blurred before any is written back, as the blur reads the unblurred fill.
  constexpr int kTileW = 64, kTileH = 16;
  const int W = color.cols, H = color.rows;
  const int tiles_x = (W + kTileW - 1) / kTileW, tiles_y = (H + kTileH - 1) / kTileH;
  std::vector<uint8_t> tile_used(size_t(tiles_x) * size_t(tiles_y), 0);
  for (int y = 0; y < H; ++y) {
    const uint8_t* m = filled.ptr<uint8_t>(y);
    uint8_t* used = tile_used.data() + size_t(y / kTileH) * size_t(tiles_x);
    for (int tx = 0; tx < tiles_x; ++tx) {
      if (used[tx]) continue;
      const int x1 = std::min(W, (tx + 1) * kTileW);
      for (int x = tx * kTileW; x < x1; ++x)
        if (m[x]) {
          used[tx] = 1;
          break;
        }
    }
  }
  static thread_local cv::Mat blurred;
  blurred.create(H, W, CV_8UC3);
  std::vector<cv::Rect> rects;
  for (int ty = 0; ty < tiles_y; ++ty)
    for (int tx = 0; tx < tiles_x; ++tx) {
      if (!tile_used[size_t(ty) * tiles_x + tx]) continue;
      const int tx0 = tx;
      while (tx + 1 < tiles_x && tile_used[size_t(ty) * tiles_x + tx + 1]) ++tx;
      const int x0 = tx0 * kTileW, y0 = ty * kTileH;
      rects.emplace_back(x0, y0, std::min(W, (tx + 1) * kTileW) - x0, std::min(H, y0 + kTileH) - y0);
    }
  const cv::Size box(2 * smooth_px + 1, 2 * smooth_px + 1);
  for (const cv::Rect& r : rects) {
    cv::Mat dst = blurred(r);
    cv::blur(color(r), dst, box);
  }
  for (const cv::Rect& r : rects) blurred(r).copyTo(color(r), filled(r));
}

void fill_holes(cv::Mat& color, const cv::Mat& depth, const HoleFillParams& params, cv::Mat& mask,
                cv::Mat* filled_depth) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && mask.type() == CV_8UC1 &&
            color.size() == depth.size() && mask.size() == color.size());
  if (params.method == HoleFillMethod::Rays) {
    HoleFillParams rays = params;
    if (rays.smooth_px < 0) rays.smooth_px = kRaysSmoothPx;
    fill_holes_along_rays(color, depth, rays, mask, filled_depth);
    return;
  }
  fill_holes_by_pyramid(color, depth, params.background_ratio, mask, filled_depth);
  smooth_filled_pixels(color, mask, params.smooth_px < 0 ? kPyramidSmoothPx : params.smooth_px);
}

}  // namespace vclassroom
