// The hole filling of a fused view (hole_fill.h): the push-pull pyramid over the holes' background
// borders, and the smoothing both methods share. The fill before issue 35 is in hole_fill_rays.cpp.
#include <gst/vclassroom/vva/hole_fill.h>
#include <gst/vclassroom/vva/hole_runs.h>
#include <gst/vclassroom/core/simd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

namespace {

// The pyramid is built only around the holes: the image is cut into square tiles of kTile px, and the tiles
// holding a hole and their 8 neighbours are "active". One tile is one cell at level kTileLevels; the levels
// below it are worked tile by tile, the levels above (a 960x540 view: 60x34 cells and fewer) whole.
constexpr int kTileLevels = 3;
constexpr int kTile = 1 << kTileLevels;
// The pyramid starts at cells of 2^kBaseLevel px: the sources are added into them directly, and the hole
// pixels are interpolated from them (bilinearly over 8x8 px). Near the border the ray ends give the detail.
// 8 px, one cell per tile, rather than 4 (issue 35's second round): the fill's time 10 % lower (its base
// level a quarter the size, one level less to push and pull), for 0.00-0.03 dB on Middlebury and Teddy
// (Art at offset 4 +0.01) and nothing on Table I; the pyramid's detail next to a hole is the ray ends' anyway.
constexpr int kBaseLevel = 3;
static_assert(kBaseLevel <= kTileLevels, "the levels up to the tiles' are worked tile by tile");

// A hole pixel's colour is the mean of its background ray ends (weighted by 1 / distance^kRayFalloff, below)
// and the pyramid's value, which counts as much as one ray end kPyramidDistance px away did at 1 / distance
// (issue 35's first round, below): next to the
// background the nearest pixels decide (a structure that meets the hole goes on into it for a few pixels;
// the 1-px smoothing after the fill keeps the edge soft), farther in the smooth 2-D surface does (no streak
// drawn from one row or column across a wide hole). 4 px was chosen among 1, 2, 4 and 10 on Middlebury Art
// and Aloe: within 0.15 dB of each other at every offset, 10 a little higher at the small offsets, but the
// nearer the pyramid counts the less a wide hole looks like its border's rows. 3 px since issue 35's fifth
// round (among 3, 3.5, 4 and 5 over every target of the issue): Art at offset 5 +0.009 dB, the one offset
// under the best published curve before (now +0.005 above it), at -0.02 / -0.01 / -0.04 at offsets 1-3 (still
// 0.07-0.72 above), Aloe within 0.01, Teddy 2 -> 6 the same, the room view's Table I +0.006, the flicker
// the same to 0.0002, the Redwood frames within 0.02 (docs/vva.md).
constexpr float kPyramidDistance = 3.0f;

// A background ray end counts 1 / distance^kRayFalloff. 0.75 rather than 1 (issue 35's second round): a far
// end still counts a little, so a hole pixel takes more of an average of its background border and less of
// the one nearest pixel (whose sensor noise or texture grain is a poor guess a few pixels in). Among 0.5,
// 0.75, 1, 1.5 and 2: 1.5 and 2 lost 0.05-0.2 dB everywhere; 0.75 gained Art 0.03-0.12 dB at every offset,
// Teddy 2 -> 6 0.04, 6 -> 2 0.12 and Table I 0.02, at -0.02 on Aloe at offsets 1-2; 0.5 lost 0.1 on Aloe.
constexpr double kRayFalloff = 0.75;
// The pyramid's weight, 1 / kPyramidDistance: with the falloff above, as much as a ray end 4.3 px away (the
// falloff was measured with the pyramid's weight kept, so it changes only how the ray ends share theirs).
constexpr float kPyramidWeight = 1.0f / kPyramidDistance;

// A base cell's sources are shared among the four cells nearest to each by its bilinear weights (issue 35's
// third round), and a cell holds a value only where they add up to kMinCellWeight or more. Before, each source
// went whole to the one 8x8 cell it lies in, and a cell held a value from a single source: when the hole's
// border moved by a pixel (the learners' motion, the sensor's noise), a source crossed a cell's edge or a cell
// came and went with one source, and the fill deep in the hole jumped with it (the pyramid's part of the
// fill's flicker). Now a source that moves a pixel moves its weights by 1/8, and a cell resting on one or two
// border pixels (their noise and grain) takes the coarser level's wider average instead. Among 0 (any weight),
// 0.25, 1, 1.5, 2, 3 and 4 over Art, Aloe and Teddy (Table I and the flicker for the best): 2 gave Art
// +0.02..0.09 dB at every offset, Aloe -0.01..+0.03, Teddy +0.05 / +0.08, Table I +0.04 (the pixels no source
// sees +0.15), the flicker with memory 8 0.750 -> 0.739 grey levels and with memory 0 1.61 -> 1.595; 0 and
// 0.25 lost 0.1-0.2 dB at Art's offsets 4-5 against 2, 1 and 1.5 0.09-0.16 at offset 5, 3 and 4 gained less at
// offsets 1-2 (the sweep with the far edge's cells needing the full weight; scaling it there, below, cost Art
// at offset 5 0.03 dB, but a hole the height of the image is now filled alike in every row).
constexpr float kMinCellWeight = 2.0f;

// The smoothing after each method (HoleFillParams::smooth_px -1): the pyramid's fill is smooth already, so
// 1 px next to the border (against 2 everywhere: Art at offset 1 +0.03 dB, the wider offsets within 0.01,
// Teddy 2 -> 6 +0.12; 0 px lost 0.02-0.04 everywhere); the rays' 2 px, as before issue 35.
constexpr int kPyramidSmoothPx = 1, kRaysSmoothPx = 2;
// Deeper in a hole the pyramid's smoothing widens (issue 35's fourth round): a pixel whose nearest known pixel
// along its row and column is d px away is smoothed over a box of radius d - 1 (the widest that reaches no
// farther than its border along them), between kPyramidSmoothPx and kPyramidSmoothMaxPx. There the fill is the
// ray ends' mean, each a single border pixel whose grain or noise runs on along its row or column as a faint
// streak, which a wider box averages out; next to the border the nearest pixels' detail is kept. 2 px against
// the 1 px everywhere: Art +0.01 at offsets 1-5 (24.18 at offset 5), Aloe +0.01-0.03, Teddy 2 -> 6 +0.02;
// 3 px gained Art at offset 5 0.005 dB more and Aloe 0.01-0.02 but cost the Redwood frames 0 <- 1 and
// 0 <- 2, 4 0.006 dB each (one target's hair for another's); a fixed radius from 3 or 4 px in instead of d - 1
// gave the same within 0.01.
constexpr int kPyramidSmoothMaxPx = 2;

// A pyramid cell: the mean colour and depth of the sources under it (or pulled from above); z == 0: none.
struct Cell {
  float r, g, b, z;
};

struct Level {
  int w = 0, h = 0;
  std::vector<Cell> cells;
  Cell* row(int y) { return cells.data() + size_t(y) * size_t(w); }
  const Cell* row(int y) const { return cells.data() + size_t(y) * size_t(w); }
};

// The mean of the samples among `n` that hold a value (z > 0); z stays 0 when none does. Every sample in the
// pyramid is some hole's background already (fill_along_rays_and_mark_sources): no depth test between levels
// (one that kept the far side of each block took a farther wall's colour into holes: -0.9 dB on Art).
inline Cell mean_of(const Cell* s, int n) {
  float r = 0, g = 0, b = 0, z = 0, count = 0;
  for (int i = 0; i < n; ++i) {  // branch-free: whether a sample holds a value is a coin toss near a hole
    const float v = s[i].z > 0 ? 1.0f : 0.0f;
    r += v * s[i].r, g += v * s[i].g, b += v * s[i].b, z += v * s[i].z, count += v;
  }
  const float inv = count > 0 ? 1.0f / count : 0.0f;
  return Cell{r * inv, g * inv, b * inv, z * inv};
}

// A buffer kept between calls, one per thread (and per type and `Id`). Through this function, not named in
// the loops: a thread_local's address in a shared library costs a call (__tls_get_addr), which the compiler
// makes again at every use rather than keep the address in a register (about 110 000 calls per 960x540 view,
// 1.2 M instructions, 11 % of the pyramid fill's); the address this returns is an ordinary value.
template <typename T, int Id>
[[gnu::noinline]] T& kept_between_calls() {
  static thread_local T kept;
  return kept;
}

// Holes a..b (inclusive) of row y.
struct HoleRun {
  int y, a, b;
};

// The first half of the fill, along rays. For each hole pixel the known pixels that end its run of holes
// along its row and its column (its left, right, upper and lower neighbour across the hole) are compared:
// those on its far side (within `keep` times the farthest of the four) are its background. Their mean,
// weighted by 1 / distance^kRayFalloff, goes into `color` at the hole pixel and the sum of the weights into
// `ray_weight` (one per hole pixel, in the order of the runs), the distance to the nearest known pixel along
// the four rays (255 at most) into `border_px`; and they are listed in `sources` (as
// y << 16 | x, each once: `source_mark`, CV_8UC1, zero on entry, marks them) as the pixels the pyramid may
// fill from. The tiles holding holes are marked in `hole_tile`, and the runs of holes listed in `runs`.
// The foreground that caused a hole ends its runs on the near side and never counts; nor does a surface
// farther back that does not border the hole (a far wall seen beside the object behind which the hole
// opened: a "farthest in the neighbourhood" rule took its colour, -0.5 dB on Art). Rows are skipped 16 and
// 4 depths at a time; a hole's column ends come from a per-column state (the known row above and below the
// column's current run of holes, found by walking down the run once), as in the rays method.
void fill_along_rays_and_mark_sources(const cv::Mat& depth, float keep, cv::Mat& color,
                                      std::vector<float>* ray_weight, std::vector<uint8_t>* border_px,
                                      cv::Mat& source_mark,
                                      std::vector<uint32_t>* sources, std::vector<uint8_t>* hole_tile,
                                      std::vector<HoleRun>* runs, const cv::Mat* left_to_caller) {
  const int W = depth.cols, H = depth.rows, tiles_x = (W + kTile - 1) / kTile;
  std::vector<int>& above = kept_between_calls<std::vector<int>, 0>();
  std::vector<int>& below = kept_between_calls<std::vector<int>, 1>();
  // A ray end's weight, for every distance in the image.
  std::vector<float>& inverse = kept_between_calls<std::vector<float>, 0>();
  above.assign(size_t(W), -1), below.assign(size_t(W), -1);
  if (inverse.size() < size_t(std::max(W, H) + 1)) {
    inverse.resize(size_t(std::max(W, H) + 1));
    for (size_t i = 1; i < inverse.size(); ++i) inverse[i] = float(1.0 / std::pow(double(i), kRayFalloff));
  }
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    uint8_t* tiles = hole_tile->data() + size_t(y / kTile) * size_t(tiles_x);
    auto mark = [&](int sy, int sx) {
      uint8_t& m = source_mark.ptr<uint8_t>(sy)[sx];
      if (!m) m = 1, sources->push_back(uint32_t(sy) << 16 | uint32_t(sx));
    };
    const uint8_t* left_out = left_to_caller ? left_to_caller->ptr<uint8_t>(y) : nullptr;
    int x = 0, a = 0, b = 0;
    while (next_hole_run(d, W, &x, &a, &b)) {  // holes a..b
      for (int t = a / kTile; t <= b / kTile; ++t) tiles[t] = 1;
      const int z_left = a > 0 ? d[a - 1] : 0, z_right = b + 1 < W ? d[b + 1] : 0;
      bool left_used = false, right_used = false;  // the run's own ends: marked once, after it
      int segment = a;  // the first pixel of the run's part filled here (runs lists only those parts)
      for (int h = a; h <= b; ++h) {
        find_known_rows(depth, y, h, above, below);
        const int z_up = above[h] >= 0 ? depth.ptr<uint16_t>(above[h])[h] : 0;
        const int z_down = below[h] < H ? depth.ptr<uint16_t>(below[h])[h] : 0;
        const int zmax = std::max(std::max(z_left, z_right), std::max(z_up, z_down));
        const float zlo = float(zmax) * keep;
        // Which ray ends lie behind: the pyramid's sources, whether this pixel is filled or left to the caller
        // (so the pyramid's cells, and the fill of the pixels near it, are the same either way).
        const bool behind_left = z_left && float(z_left) >= zlo, behind_right = z_right && float(z_right) >= zlo;
        const bool behind_up = z_up && float(z_up) >= zlo, behind_down = z_down && float(z_down) >= zlo;
        left_used |= behind_left, right_used |= behind_right;
        if (behind_up) mark(above[h], h);
        if (behind_down) mark(below[h], h);
        if (left_out && left_out[h]) {  // not filled; its tile holds a hole all the same
          if (segment < h) runs->push_back(HoleRun{y, segment, h - 1});
          segment = h + 1;
          continue;
        }
        float acc[3] = {0, 0, 0}, wsum = 0;
        auto take = [&](int dist, const uint8_t* c) {
          const float w = inverse[size_t(dist)];
          acc[0] += w * c[0], acc[1] += w * c[1], acc[2] += w * c[2], wsum += w;
        };
        if (behind_left) take(h - a + 1, color.ptr<uint8_t>(y) + 3 * (a - 1));
        if (behind_right) take(b + 1 - h, color.ptr<uint8_t>(y) + 3 * (b + 1));
        if (behind_up) take(y - above[h], color.ptr<uint8_t>(above[h]) + 3 * h);
        if (behind_down) take(below[h] - y, color.ptr<uint8_t>(below[h]) + 3 * h);
        ray_weight->push_back(wsum);
        int nearest = INT_MAX;  // the nearest known pixel along the four rays, whatever its depth
        if (z_left) nearest = std::min(nearest, h - a + 1);
        if (z_right) nearest = std::min(nearest, b + 1 - h);
        if (z_up) nearest = std::min(nearest, y - above[h]);
        if (z_down) nearest = std::min(nearest, below[h] - y);
        border_px->push_back(uint8_t(std::min(nearest, 255)));
        if (wsum > 0) {
          uint8_t* c = color.ptr<uint8_t>(y) + 3 * h;
          const float iw = 1.0f / wsum;
          for (int k = 0; k < 3; ++k) c[k] = uint8_t(acc[k] * iw + 0.5f);
        }
      }
      if (segment <= b) runs->push_back(HoleRun{y, segment, b});
      if (left_used) mark(y, a - 1);  // (once per run, not once per hole pixel of it)
      if (right_used) mark(y, b + 1);
    }
  }
}

// A pixel's share of the two base cells nearest to it along one axis (push_sources).
struct Splat {
  int cell[2];
  float weight[2];
};

// The pyramid's state, kept between calls (a view's holes change little from frame to frame, the buffers'
// sizes not at all).
struct PyramidState {
  int tiles_x = 0, tiles_y = 0;
  std::vector<Level> levels;                 // levels[0] stands for the image, levels below the base are unused
  std::vector<uint8_t> hole_tile, active;    // per tile
  std::vector<uint32_t> sources;             // the pixels the fill takes colour from, as y << 16 | x
  std::vector<HoleRun> runs;                 // the holes
  std::vector<float> base_count;             // the base level: the sources' weight per cell while they are added
  std::vector<int> base_written;             // the base level: the cells given a value (emptied at the next call)
  std::vector<std::vector<uint8_t>> needed;  // above kTileLevels: per cell, whether it lies over an active tile
  std::vector<int> cell_x0, cell_y0;         // per column / row: the first of the two base cells it lies between
  std::vector<float> weight_x1, weight_y1;   // and the second one's bilinear weight
  std::vector<Splat> splat_x, splat_y;       // per column / row: the two base cells a source's weight goes to
  std::vector<float> support_x, support_y;   // per base cell column / row: the weight its pixels give it
  cv::Mat source_mark;                       // the sources marked (zero between calls)
  // Per hole pixel, in the order of the runs (the passes over the holes follow it, so these are read and
  // written in order rather than scattered over image-sized buffers):
  std::vector<float> ray_weight;             // the ray ends' summed weight
  std::vector<uint8_t> border_px;            // the nearest known pixel's distance along the rays
  std::vector<uint16_t> fill_depth;          // the depth of the background it was filled from (0: not filled)
};

// Each column's (or row's) two nearest base cells, centres at (x + 0.5) / 2^kBaseLevel - 0.5: the first
// one and the second one's bilinear weight (beyond the outer centres, all of it to the outer cell). And each
// cell's support: the bilinear weights all pixels of the column (row) give it as push_sources shares them,
// 2^kBaseLevel but at the image's edges (the half beyond the outer centres is lost) and less at the far
// edge of an image whose size is not a multiple of it (540 rows: the last cell's centre is the last row).
void base_cells_along(int n_px, int n_cells, std::vector<int>& first, std::vector<float>& second_weight,
                      std::vector<Splat>& splat, std::vector<float>& support) {
  first.resize(size_t(n_px)), second_weight.resize(size_t(n_px)), splat.resize(size_t(n_px));
  support.assign(size_t(n_cells), 0.0f);
  for (int x = 0; x < n_px; ++x) {
    const float f = (float(x) + 0.5f) / float(1 << kBaseLevel) - 0.5f;
    first[size_t(x)] = std::clamp(int(std::floor(f)), 0, std::max(0, n_cells - 2));
    second_weight[size_t(x)] = n_cells < 2 ? 0.f : std::clamp(f - float(first[size_t(x)]), 0.0f, 1.0f);
    // The splat: a cell beyond the edge gets weight 0 (and an index inside, never read with a weight).
    const int u = int(std::floor(f));
    const float w1 = f - float(u);
    Splat& sp = splat[size_t(x)];
    sp.cell[0] = std::max(u, 0), sp.weight[0] = u >= 0 ? 1 - w1 : 0.0f;
    sp.cell[1] = std::min(u + 1, n_cells - 1), sp.weight[1] = u + 1 < n_cells ? w1 : 0.0f;
    support[size_t(sp.cell[0])] += sp.weight[0], support[size_t(sp.cell[1])] += sp.weight[1];
  }
}

// The base level from the image: each source pixel shared among the four base cells nearest to it by its
// bilinear weights (the cells' centres are those fill_from_base interpolates between), then every cell it
// reached made a weighted mean. A cell that got less than kMinCellWeight in all holds no value: it is pulled
// from the coarser level like a cell without sources. `base` holds no value on entry (only the cells listed
// in `written` were ever given one, and they were emptied); the cells given one are listed there.
void push_sources(const cv::Mat& color, const cv::Mat& depth, PyramidState& st, Level& base) {
  std::vector<float>& weight = st.base_count;
  std::vector<int>& written = st.base_written;
  for (uint32_t i : st.sources) {
    const int x = int(i & 0xffff), y = int(i >> 16);
    const Splat& sx = st.splat_x[size_t(x)];
    const Splat& sy = st.splat_y[size_t(y)];
    const uint8_t* p = color.ptr<uint8_t>(y) + 3 * x;
    const float r = p[0], g = p[1], b = p[2], z = depth.ptr<uint16_t>(y)[x];
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) {
        const float w = sy.weight[j] * sx.weight[k];
        if (w <= 0) continue;  // beyond the image's edge: lost
        const int c = sy.cell[j] * base.w + sx.cell[k];
        if (weight[size_t(c)] == 0) written.push_back(c);
        Cell& cell = base.cells[size_t(c)];
        cell.r += w * r, cell.g += w * g, cell.b += w * b, cell.z += w * z;
        weight[size_t(c)] += w;
      }
  }
  constexpr float kFull = float((1 << kBaseLevel) * (1 << kBaseLevel));  // an inner cell's support
  for (int c : written) {
    Cell& cell = base.cells[size_t(c)];
    const float inv = 1.0f / weight[size_t(c)];
    // At the far edge a cell's support is smaller: so is the weight it needs.
    const float need = kMinCellWeight / kFull * st.support_x[size_t(c % base.w)] * st.support_y[size_t(c / base.w)];
    cell = weight[size_t(c)] >= need ? Cell{cell.r * inv, cell.g * inv, cell.b * inv, cell.z * inv} : Cell{0, 0, 0, 0};
  }
}

// Level l + 1 from level l, over the cells [x0, x1) x [y0, y1). `child_known(x, y)` says whether a level-l
// cell was computed this time (the cells of tiles that are not active keep an older frame's values).
template <typename Known>
void push_level(const Level& down, Level& up, int x0, int x1, int y0, int y1, Known child_known) {
  for (int Y = y0; Y < y1; ++Y) {
    Cell* out = up.row(Y);
    const int ya = 2 * Y, yb = std::min(2 * Y + 1, down.h - 1);  // a last odd row: its row counted twice
    const Cell* in0 = down.row(ya);
    const Cell* in1 = down.row(yb);
    for (int X = x0; X < x1; ++X) {
      const int xa = 2 * X, xb = std::min(2 * X + 1, down.w - 1);
      Cell s[4] = {in0[xa], in0[xb], in1[xa], in1[xb]};
      if (!child_known(xa, ya)) s[0].z = 0;  // (a child over a tile not active this time is not looked at)
      if (!child_known(xb, ya)) s[1].z = 0;
      if (!child_known(xa, yb)) s[2].z = 0;
      if (!child_known(xb, yb)) s[3].z = 0;
      out[X] = mean_of(s, 4);
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
  const Cell* r0 = up.row(py0);
  const Cell* r1 = up.row(py1);
  const Cell* p[4] = {r0 + px0, r0 + px1, r1 + px0, r1 + px1};
  const float w[4] = {wx0 * wy0, wx1 * wy0, wx0 * wy1, wx1 * wy1};
  float r = 0, g = 0, b = 0, z = 0, wsum = 0;
  for (int i = 0; i < 4; ++i) {  // branch-free, as mean_of
    const float wi = p[i]->z > 0 ? w[i] : 0.0f;
    r += wi * p[i]->r, g += wi * p[i]->g, b += wi * p[i]->b, z += wi * p[i]->z, wsum += wi;
  }
  const float inv = wsum > 0 ? 1.0f / wsum : 0.0f;
  return Cell{r * inv, g * inv, b * inv, z * inv};
}


// The cells of level `l` (kBaseLevel <= l <= kTileLevels) inside tile (tx, ty).
inline void tile_cells(const Level& lv, int l, int tx, int ty, int* x0, int* x1, int* y0, int* y1) {
  const int side = kTile >> l;
  *x0 = tx * side, *x1 = std::min(lv.w, *x0 + side);
  *y0 = ty * side, *y1 = std::min(lv.h, *y0 + side);
}

// The tiles holding holes and their 8 neighbours: the parents of a hole's cells lie within one tile of it.
void mark_active_tiles(PyramidState& st) {
  st.active.assign(st.hole_tile.size(), 0);
  for (int ty = 0; ty < st.tiles_y; ++ty)
    for (int tx = 0; tx < st.tiles_x; ++tx) {
      if (!st.hole_tile[size_t(ty) * st.tiles_x + tx]) continue;
      for (int y = std::max(0, ty - 1); y <= std::min(st.tiles_y - 1, ty + 1); ++y)
        for (int x = std::max(0, tx - 1); x <= std::min(st.tiles_x - 1, tx + 1); ++x)
          st.active[size_t(y) * st.tiles_x + x] = 1;
    }
}

// Level `l` (above kTileLevels) from the one below, all of it; notes which cells lie over an active tile.
// True when one of those holds no value yet.
bool push_whole_level(PyramidState& st, int l) {
  const Level& down = st.levels[size_t(l) - 1];
  Level& up = st.levels[size_t(l)];
  const size_t n = size_t(l - kTileLevels);
  if (st.needed.size() < n) st.needed.resize(n);
  std::vector<uint8_t>& need = st.needed[n - 1];
  need.assign(up.cells.size(), 0);
  // Level kTileLevels is the tile grid: its cells are the tiles (its width is tiles_x).
  const uint8_t* below_need = n >= 2 ? st.needed[n - 2].data() : st.active.data();
  auto child_known = [&](int x, int y) { return below_need[size_t(y) * down.w + x] != 0; };
  push_level(down, up, 0, up.w, 0, up.h, child_known);
  bool empty = false;
  for (int Y = 0; Y < up.h; ++Y)
    for (int X = 0; X < up.w; ++X) {
      const int xb = std::min(2 * X + 1, down.w - 1), yb = std::min(2 * Y + 1, down.h - 1);
      const bool any =
          child_known(2 * X, 2 * Y) || child_known(xb, 2 * Y) || child_known(2 * X, yb) || child_known(xb, yb);
      need[size_t(Y) * up.w + X] = any;
      empty |= any && up.row(Y)[X].z <= 0;
    }
  return empty;
}

// The push: the base level from the sources, then each coarser level from the one below (over the active
// tiles up to kTileLevels, whole above), until one has a value over every active tile or is a single cell.
// Returns that level.
int push_up(PyramidState& st, const cv::Mat& color, const cv::Mat& depth) {
  std::vector<Level>& lv = st.levels;
  if (lv.empty()) lv.resize(1);
  lv[0].w = depth.cols, lv[0].h = depth.rows;
  for (int l = 1;; ++l) {
    if (int(lv.size()) <= l) lv.emplace_back();
    Level& up = lv[size_t(l)];
    const int w = (lv[size_t(l) - 1].w + 1) / 2, h = (lv[size_t(l) - 1].h + 1) / 2;
    if (l == kBaseLevel && (w != up.w || h != up.h)) {  // a new size: the base level starts empty
      up.cells.assign(size_t(w) * size_t(h), Cell{0, 0, 0, 0});
      st.base_count.assign(up.cells.size(), 0);
      st.base_written.clear();
    }
    up.w = w, up.h = h;
    if (l < kBaseLevel) continue;  // not built: the sources go straight to the base level
    up.cells.resize(size_t(w) * size_t(h));
    bool empty = false;
    if (l == kBaseLevel) {
      for (int c : st.base_written) up.cells[size_t(c)] = Cell{0, 0, 0, 0}, st.base_count[size_t(c)] = 0;
      st.base_written.clear();
      // They depend on the sizes only: made again when those change, not for every view.
      if (st.cell_x0.size() != size_t(depth.cols) || st.support_x.size() != size_t(w))
        base_cells_along(depth.cols, w, st.cell_x0, st.weight_x1, st.splat_x, st.support_x);
      if (st.cell_y0.size() != size_t(depth.rows) || st.support_y.size() != size_t(h))
        base_cells_along(depth.rows, h, st.cell_y0, st.weight_y1, st.splat_y, st.support_y);
      push_sources(color, depth, st, up);
      empty = true;  // the sources alone: a hole's cells hold none
    } else if (l <= kTileLevels) {
      for (int ty = 0; ty < st.tiles_y; ++ty)
        for (int tx = 0; tx < st.tiles_x; ++tx) {
          if (!st.active[size_t(ty) * st.tiles_x + tx]) continue;
          int x0, x1, y0, y1;
          tile_cells(up, l, tx, ty, &x0, &x1, &y0, &y1);
          push_level(lv[size_t(l) - 1], up, x0, x1, y0, y1, [](int, int) { return true; });
          for (int y = y0; y < y1 && !empty; ++y)
            for (int x = x0; x < x1; ++x) empty |= up.row(y)[x].z <= 0;
        }
    } else {
      empty = push_whole_level(st, l);
    }
    if (!empty || (w == 1 && h == 1)) return l;
  }
}

// The pull, from the level below `top` down to the base level: each cell without a value over a tile with
// holes (above kTileLevels: over an active tile) from its parents.
void pull_down(PyramidState& st, int top) {
  for (int l = top - 1; l >= kBaseLevel; --l) {
    Level& here = st.levels[size_t(l)];
    const Level& up = st.levels[size_t(l) + 1];
    auto fill_cells = [&](int x0, int x1, int y0, int y1, const uint8_t* need) {
      for (int y = y0; y < y1; ++y) {
        Cell* c = here.row(y);
        for (int x = x0; x < x1; ++x)
          if (c[x].z <= 0 && (!need || need[size_t(y) * here.w + x])) {
            c[x] = pull_from(up, x, y);
            if (l == kBaseLevel) st.base_written.push_back(y * here.w + x);
          }
      }
    };
    if (l <= kTileLevels) {
      for (int ty = 0; ty < st.tiles_y; ++ty)
        for (int tx = 0; tx < st.tiles_x; ++tx) {
          // Elsewhere the empty cells stay empty: a hole's cells beyond its own tile count where they hold
          // sources, and are left out of its interpolation where they do not.
          if (!st.hole_tile[size_t(ty) * st.tiles_x + tx]) continue;
          int x0, x1, y0, y1;
          tile_cells(here, l, tx, ty, &x0, &x1, &y0, &y1);
          fill_cells(x0, x1, y0, y1, nullptr);
        }
    } else {
      fill_cells(0, here.w, 0, here.h, st.needed[size_t(l - kTileLevels) - 1].data());
    }
  }
}

// Every hole pixel: the pyramid's value there (the bilinear interpolation of the four nearest base cells
// that hold a value), with the ray ends' mean that `color` holds there, the pyramid counting as one more ray
// end kPyramidDistance px away.
void fill_from_base(PyramidState& st, cv::Mat& color, cv::Mat& mask, cv::Mat* filled_depth) {
  const Level& base = st.levels[kBaseLevel];
  // Each column's and row's base cells, as push_up made them for this size.
  CV_Assert(st.cell_x0.size() == size_t(color.cols) && st.cell_y0.size() == size_t(color.rows));
  st.fill_depth.resize(st.ray_weight.size());
  const float* ray_w = st.ray_weight.data();
  uint16_t* fd = st.fill_depth.data();
  for (const HoleRun& run : st.runs) {
    const int y = run.y;
    uint8_t* c = color.ptr<uint8_t>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    uint16_t* out_depth = filled_depth ? filled_depth->ptr<uint16_t>(y) : nullptr;
    const int cy = st.cell_y0[size_t(y)], cy1 = std::min(cy + 1, base.h - 1);
    const float wy1 = st.weight_y1[size_t(y)], wy0 = 1.0f - wy1;
    const Cell* r0 = base.row(cy);
    const Cell* r1 = base.row(cy1);
    for (int x = run.a; x <= run.b; ++x, ++ray_w, ++fd) {
      const int cx = st.cell_x0[size_t(x)], cx1 = std::min(cx + 1, base.w - 1);
      const float wx1 = st.weight_x1[size_t(x)], wx0 = 1.0f - wx1;
      const Cell* p[4] = {r0 + cx, r0 + cx1, r1 + cx, r1 + cx1};
      const float w[4] = {wx0 * wy0, wx1 * wy0, wx0 * wy1, wx1 * wy1};
      float r = 0, g = 0, b = 0, z = 0, wsum = 0;
      for (int i = 0; i < 4; ++i) {  // the cells that hold a value, branch-free as mean_of
        const float wi = p[i]->z > 0 ? w[i] : 0.0f;
        r += wi * p[i]->r, g += wi * p[i]->g, b += wi * p[i]->b, z += wi * p[i]->z, wsum += wi;
      }
      *fd = 0;
      if (wsum <= 0) continue;  // nothing known anywhere near
      const float wp = kPyramidWeight / wsum, inv = 1.0f / (*ray_w + kPyramidWeight);
      c[3 * x] = uint8_t((*ray_w * c[3 * x] + wp * r) * inv + 0.5f);
      c[3 * x + 1] = uint8_t((*ray_w * c[3 * x + 1] + wp * g) * inv + 0.5f);
      c[3 * x + 2] = uint8_t((*ray_w * c[3 * x + 2] + wp * b) * inv + 0.5f);
      m[x] = 255;
      *fd = uint16_t(std::min(z / wsum + 0.5f, 65535.f));
      if (out_depth) out_depth[x] = *fd;
    }
  }
}

// The pyramid's smoothing: each filled pixel becomes the mean of the (2r+1)^2 box around it, over the pixels
// there that are filled too or lie behind it (within `keep` of the depth it was filled from, or farther): the
// object that caused the hole is never blurred into it. r is `r_min`, or up to `r_max` deeper in the hole
// (kPyramidSmoothMaxPx). Every box reads the colours as the pyramid left them.
//
// A view that looks where no camera does is half holes (a lecturer looking level above cameras tilted down), and
// a box per filled pixel tested tap by tap was then the server's largest cost. So the rows the boxes read are
// first copied into planes padded by r_max on each side: a key per pixel (its depth; a filled hole
// kFilledKey, an unfilled one 0) and the three colours. A tap then counts where its key is at least the
// centre's bound, one compare, and a run's pixels are summed tap by tap in vectors (sum_taps).
constexpr uint16_t kFilledKey = 65535;  // at least any bound: a filled pixel always counts

template <typename Sum>
struct RunSums {
  std::vector<Sum> r, g, b, count;
  void resize(size_t n) { r.resize(n), g.resize(n), b.resize(n), count.resize(n); }
};

// The rows of the planes a run's boxes read, at the run's first pixel (null outside the image).
struct TapRows {
  const uint16_t* const* key;
  const uint8_t* const* red;
  const uint8_t* const* green;
  const uint8_t* const* blue;
};

struct SmoothPlanes {
  int rows = 0, stride = 0, pad = 0;
  std::vector<uint16_t> key;
  std::vector<uint8_t> red, green, blue;
  std::vector<std::pair<int, int>> spans;  // a row's columns to copy
  // Per run pixel (reused run to run): its bound and radius, and the sums (16-bit up to 7 px of radius).
  std::vector<uint16_t> bound, radius;
  RunSums<uint16_t> narrow;
  RunSums<uint32_t> wide;
};

// Columns x0..x1 of row v into the planes.
void copy_to_planes(SmoothPlanes& p, const cv::Mat& color, const cv::Mat& depth, const cv::Mat& mask, int v, int x0,
                    int x1) {
  const size_t at = size_t(v) * size_t(p.stride) + size_t(p.pad);
  const uint8_t* c = color.ptr<uint8_t>(v);
  const uint16_t* d = depth.ptr<uint16_t>(v);
  const uint8_t* m = mask.ptr<uint8_t>(v);
  uint16_t* key = p.key.data() + at;
  uint8_t *r = p.red.data() + at, *g = p.green.data() + at, *b = p.blue.data() + at;
  for (int u = x0; u <= x1; ++u) {
    key[u] = d[u] ? d[u] : m[u] ? kFilledKey : 0;
    r[u] = c[3 * u], g[u] = c[3 * u + 1], b[u] = c[3 * u + 2];
  }
}

// What the boxes of `runs` (sorted by row) read, into the planes: in each row the columns within R of a run
// within R rows, each once.
void copy_boxes_to_planes(SmoothPlanes& p, const std::vector<HoleRun>& runs, const cv::Mat& color,
                          const cv::Mat& depth, const cv::Mat& mask, int R) {
  const int W = color.cols, H = color.rows;
  std::vector<std::pair<int, int>>& spans = p.spans;
  size_t first = 0;  // the first run at or below row v - R
  for (int v = std::max(0, runs.front().y - R); v <= std::min(H - 1, runs.back().y + R); ++v) {
    while (first < runs.size() && runs[first].y < v - R) ++first;
    spans.clear();
    for (size_t i = first; i < runs.size() && runs[i].y <= v + R; ++i)
      spans.emplace_back(std::max(0, runs[i].a - R), std::min(W - 1, runs[i].b + R));
    std::sort(spans.begin(), spans.end());
    for (size_t i = 0; i < spans.size();) {
      int x0 = spans[i].first, x1 = spans[i].second;
      for (++i; i < spans.size() && spans[i].first <= x1 + 1; ++i) x1 = std::max(x1, spans[i].second);
      copy_to_planes(p, color, depth, mask, v, x0, x1);
    }
  }
}

// The sums of one run of n pixels: tap (du, dv) counts for pixel i when the key there is at least bound[i] and
// the tap lies within radius[i]. Sum is wide enough for (2R+1)^2 taps of 255.
template <typename Sum>
VCLASSROOM_SIMD_INLINE void sum_taps(int n, int R, const TapRows& rows, const uint16_t* __restrict bound,
                                     const uint16_t* __restrict radius,
                                     Sum* __restrict sr, Sum* __restrict sg, Sum* __restrict sb,
                                     Sum* __restrict count) {
  for (int i = 0; i < n; ++i) sr[i] = 0, sg[i] = 0, sb[i] = 0, count[i] = 0;
  for (int dv = -R; dv <= R; ++dv) {
    if (!rows.key[dv + R]) continue;
    for (int du = -R; du <= R; ++du) {
      const uint16_t reach = uint16_t(std::max(std::abs(dv), std::abs(du)));
      const uint16_t* __restrict k = rows.key[dv + R] + du;
      const uint8_t* __restrict r = rows.red[dv + R] + du;
      const uint8_t* __restrict g = rows.green[dv + R] + du;
      const uint8_t* __restrict b = rows.blue[dv + R] + du;
      for (int i = 0; i < n; ++i) {
        const Sum take = (k[i] >= bound[i]) & (radius[i] >= reach);
        const Sum all = Sum(0) - take;
        sr[i] += Sum(r[i]) & all, sg[i] += Sum(g[i]) & all, sb[i] += Sum(b[i]) & all, count[i] += take;
      }
    }
  }
}

VCLASSROOM_SIMD_CLONES
void sum_taps_16(int n, int R, const TapRows& rows, const uint16_t* bound, const uint16_t* radius, uint16_t* sr,
                 uint16_t* sg, uint16_t* sb, uint16_t* count) {
  sum_taps(n, R, rows, bound, radius, sr, sg, sb, count);
}

VCLASSROOM_SIMD_CLONES
void sum_taps_32(int n, int R, const TapRows& rows, const uint16_t* bound, const uint16_t* radius, uint32_t* sr,
                 uint32_t* sg, uint32_t* sb, uint32_t* count) {
  sum_taps(n, R, rows, bound, radius, sr, sg, sb, count);
}

// One run's new colours, written straight into `color` (the boxes read the planes, not `color`).
template <typename Sum>
void write_means(int n, const uint16_t* fd, const Sum* sr, const Sum* sg, const Sum* sb, const Sum* count,
                 uint8_t* c) {
  for (int i = 0; i < n; ++i) {
    if (!fd[i]) continue;  // not filled
    const float inv = 1.0f / float(count[i]);  // count >= 1: the pixel itself; a reciprocal, not three divisions
    c[3 * i] = uint8_t(float(sr[i]) * inv + 0.5f);
    c[3 * i + 1] = uint8_t(float(sg[i]) * inv + 0.5f);
    c[3 * i + 2] = uint8_t(float(sb[i]) * inv + 0.5f);
  }
}

// One run of n filled pixels (fill depth `fd`, 0 where not filled): its boxes summed by `sum_taps_n` (the 16-
// or 32-bit copy) into `sums`, the means written at `out`.
template <typename Sum, typename SumTaps>
void smooth_run(int n, int R, const TapRows& rows, const uint16_t* bound, const uint16_t* radius, const uint16_t* fd,
                RunSums<Sum>& sums, SumTaps sum_taps_n, uint8_t* out) {
  sums.resize(size_t(n));
  sum_taps_n(n, R, rows, bound, radius, sums.r.data(), sums.g.data(), sums.b.data(), sums.count.data());
  write_means(n, fd, sums.r.data(), sums.g.data(), sums.b.data(), sums.count.data(), out);
}

void smooth_behind(PyramidState& st, cv::Mat& color, const cv::Mat& depth, const cv::Mat& mask, float keep,
                   int r_min, int r_max) {
  if (r_max <= 0 || st.runs.empty()) return;
  const int W = color.cols, H = color.rows, R = r_max;
  SmoothPlanes& p = kept_between_calls<SmoothPlanes, 0>();
  if (p.rows != H || p.stride != W + 2 * R || p.pad != R) {  // a new layout: the padding 0 (never counted)
    p.rows = H, p.pad = R, p.stride = W + 2 * R;
    const size_t plane = size_t(H) * size_t(p.stride);
    p.key.assign(plane, 0), p.red.assign(plane, 0), p.green.assign(plane, 0), p.blue.assign(plane, 0);
  }
  copy_boxes_to_planes(p, st.runs, color, depth, mask, R);
  const bool wide = (2 * R + 1) * (2 * R + 1) * 255 > 65535;
  std::vector<const uint16_t*> key_rows(size_t(2 * R + 1));
  std::vector<const uint8_t*> red_rows(key_rows.size()), green_rows(key_rows.size()), blue_rows(key_rows.size());
  const TapRows rows{key_rows.data(), red_rows.data(), green_rows.data(), blue_rows.data()};  // set run by run
  const uint16_t* fd = st.fill_depth.data();
  const uint8_t* border = st.border_px.data();
  for (const HoleRun& run : st.runs) {
    const int n = run.b - run.a + 1;
    p.bound.resize(size_t(n)), p.radius.resize(size_t(n));
    for (int i = 0; i < n; ++i) {
      // A known depth d is behind when float(d) >= keep * fd, i.e. d >= bound (integers: no conversion per
      // tap); at least 1, so that an unfilled hole (key 0) never counts.
      p.bound[size_t(i)] = uint16_t(std::clamp(int(std::ceil(keep * float(fd[i]))), 1, int(kFilledKey)));
      p.radius[size_t(i)] = uint16_t(std::clamp(int(border[i]) - 1, r_min, r_max));
    }
    for (int dv = -R; dv <= R; ++dv) {
      const int v = run.y + dv;
      const bool inside = v >= 0 && v < H;
      const size_t at = size_t(v) * size_t(p.stride) + size_t(p.pad + run.a);
      key_rows[size_t(dv + R)] = inside ? p.key.data() + at : nullptr;
      red_rows[size_t(dv + R)] = inside ? p.red.data() + at : nullptr;
      green_rows[size_t(dv + R)] = inside ? p.green.data() + at : nullptr;
      blue_rows[size_t(dv + R)] = inside ? p.blue.data() + at : nullptr;
    }
    uint8_t* out = color.ptr<uint8_t>(run.y) + 3 * run.a;
    if (wide) smooth_run(n, R, rows, p.bound.data(), p.radius.data(), fd, p.wide, sum_taps_32, out);
    else smooth_run(n, R, rows, p.bound.data(), p.radius.data(), fd, p.narrow, sum_taps_16, out);
    fd += n, border += n;
  }
}

// A filled pixel that was filled the frame before too, from a background within kSteadyDepthRatio of the same
// depth, takes its old colour plus a share of the change: the change's largest channel over kSteadyPassLevels
// grey levels, at least kSteadyMinShare. The sensor's noise on a hole's border moves its fill by a few grey
// levels from frame to frame (the pyramid's cells and the ray ends follow it), which this damps; a real change
// (a learner stepping into the border, a light turned on) moves it by more and passes whole, or nearly, at
// once. Among thresholds of 8, 16 and 30 levels and least shares of 0.1 and 0.25, the flicker with memory 8
// went from 0.7390 to 0.7324 / 0.7304 / 0.7274 (0.1 against 0.25 at 16: 0.7301); freezing every steady
// pixel would give 0.7222, the most this can take away.
constexpr float kSteadyPassLevels = 16.0f, kSteadyMinShare = 0.25f, kSteadyDepthRatio = 0.03f;

// Blends the fill with `history` (as above), then makes `history` this frame's fill.
void keep_steady_fill(const PyramidState& st, cv::Mat& color, HoleFillHistory& history) {
  if (history.color.size() != color.size() || history.depth.size() != color.size()) {
    history.color.create(color.size(), CV_8UC3);
    history.depth = cv::Mat::zeros(color.size(), CV_16UC1);
    history.spans.clear();
  }
  const uint16_t* fd = st.fill_depth.data();
  for (const HoleRun& run : st.runs) {
    uint8_t* c = color.ptr<uint8_t>(run.y);
    const uint8_t* old = history.color.ptr<uint8_t>(run.y);
    const uint16_t* old_depth = history.depth.ptr<uint16_t>(run.y);
    for (int x = run.a; x <= run.b; ++x, ++fd) {
      if (!*fd || !old_depth[x] || float(std::abs(int(old_depth[x]) - int(*fd))) > kSteadyDepthRatio * float(*fd))
        continue;  // not filled now or before, or from another background
      uint8_t* p = c + 3 * x;
      const uint8_t* o = old + 3 * x;
      const int change = std::max({std::abs(p[0] - o[0]), std::abs(p[1] - o[1]), std::abs(p[2] - o[2])});
      const float share = std::clamp(float(change) / kSteadyPassLevels, kSteadyMinShare, 1.0f);
      for (int k = 0; k < 3; ++k) p[k] = uint8_t(float(o[k]) + share * float(p[k] - o[k]) + 0.5f);
    }
  }
  // The old runs cleared, then this frame's written (the colours where the depth is set are the valid ones).
  for (size_t i = 0; i + 2 < history.spans.size(); i += 3) {
    uint16_t* d = history.depth.ptr<uint16_t>(history.spans[i]);
    std::fill(d + history.spans[i + 1], d + history.spans[i + 2] + 1, uint16_t(0));
  }
  history.spans.clear();
  fd = st.fill_depth.data();
  for (const HoleRun& run : st.runs) {
    std::memcpy(history.color.ptr<uint8_t>(run.y) + 3 * run.a, color.ptr<uint8_t>(run.y) + 3 * run.a,
                size_t(run.b - run.a + 1) * 3);
    std::memcpy(history.depth.ptr<uint16_t>(run.y) + run.a, fd, size_t(run.b - run.a + 1) * sizeof(uint16_t));
    fd += run.b - run.a + 1;
    history.spans.insert(history.spans.end(), {run.y, run.a, run.b});
  }
}

}  // namespace

// First along rays: every hole pixel's background ray ends, their mean, and the sources they make. Then the
// push-pull over the sources alone, around the holes only, and every hole pixel from it and its rays.
// Nothing but a hole's background border is ever read, so the foreground beside a hole (nearer than the
// hole's background by more than `background_ratio`) never reaches it, at whatever scale; and the result
// depends on the image alone (no pose, no earlier frame), so a hole that stays put is filled alike, up to
// its border's noise, which `history` (when given) damps.
void fill_holes_by_pyramid(cv::Mat& color, const cv::Mat& depth, double background_ratio, int smooth_px,
                           cv::Mat& mask, cv::Mat* filled_depth, HoleFillHistory* history,
                           const cv::Mat* left_to_caller) {
  const int W = color.cols, H = color.rows;
  CV_Assert(W < 65536 && H < 65536);  // a source is listed as y << 16 | x
  PyramidState& st = kept_between_calls<PyramidState, 0>();
  st.tiles_x = (W + kTile - 1) / kTile, st.tiles_y = (H + kTile - 1) / kTile;
  st.hole_tile.assign(size_t(st.tiles_x) * size_t(st.tiles_y), 0);
  if (st.source_mark.size() != depth.size()) st.source_mark = cv::Mat::zeros(depth.size(), CV_8UC1);
  st.ray_weight.clear();
  st.border_px.clear();
  st.sources.clear();
  st.runs.clear();
  const float keep = float(1.0 - background_ratio);
  fill_along_rays_and_mark_sources(depth, keep, color, &st.ray_weight, &st.border_px, st.source_mark,
                                   &st.sources, &st.hole_tile, &st.runs, left_to_caller);
  for (uint32_t i : st.sources) st.source_mark.ptr<uint8_t>(int(i >> 16))[i & 0xffff] = 0;
  if (!st.runs.empty()) {
    mark_active_tiles(st);
    pull_down(st, push_up(st, color, depth));
    fill_from_base(st, color, mask, filled_depth);
    // smooth_px < 0: 1 px next to the border, wider deeper in (kPyramidSmoothMaxPx).
    const int r0 = smooth_px < 0 ? kPyramidSmoothPx : smooth_px, r1 = smooth_px < 0 ? kPyramidSmoothMaxPx : smooth_px;
    smooth_behind(st, color, depth, mask, keep, r0, r1);
  }
  if (history) keep_steady_fill(st, color, *history);  // also without holes: the last frame's are gone
}

// The box is summed at each filled pixel alone (holes are a few % of a view), with the image's border
// mirrored as cv::blur mirrors it (BORDER_REFLECT_101) and its rounding: the same pixels a blur of the whole
// image gives there. (A sum over (2r+1)^2 values divided by their count never ends in .5, so the integer
// rounding below cannot differ from OpenCV's.) The new colours are kept aside until all are made: each reads
// the unblurred fill around it.
void smooth_filled_pixels(cv::Mat& color, const cv::Mat& filled, int smooth_px) {
  if (smooth_px <= 0) return;
  const int W = color.cols, H = color.rows, r = smooth_px, n = (2 * r + 1) * (2 * r + 1);
  if (W <= r || H <= r) {  // too small to mirror: the plain way
    cv::Mat blurred;
    cv::blur(color, blurred, cv::Size(2 * r + 1, 2 * r + 1));
    blurred.copyTo(color, filled);
    return;
  }
  auto mirror = [](int i, int len) { return i < 0 ? -i : i >= len ? 2 * (len - 1) - i : i; };
  struct Smoothed {
    int y, x;
    uint8_t rgb[3];
  };
  static thread_local std::vector<Smoothed> out;
  static thread_local std::vector<const uint8_t*> rows;
  out.clear();
  rows.resize(size_t(2 * r + 1));
  for (int y = 0; y < H; ++y) {
    const uint8_t* m = filled.ptr<uint8_t>(y);
    bool rows_set = false;
    for (int x0 = 0; x0 < W; x0 += 8) {
      if (x0 + 8 <= W) {  // eight mask bytes at a time: most are 0
        uint64_t v;
        std::memcpy(&v, m + x0, 8);
        if (!v) continue;
      }
      if (!rows_set) {
        for (int k = -r; k <= r; ++k) rows[size_t(k + r)] = color.ptr<uint8_t>(mirror(y + k, H));
        rows_set = true;
      }
      for (int x = x0; x < std::min(W, x0 + 8); ++x) {
        if (!m[x]) continue;
        int sum[3] = {0, 0, 0};
        for (const uint8_t* row : rows)
          for (int k = -r; k <= r; ++k) {
            const uint8_t* p = row + 3 * mirror(x + k, W);
            sum[0] += p[0], sum[1] += p[1], sum[2] += p[2];
          }
        Smoothed s{y, x, {}};
        for (int c = 0; c < 3; ++c) s.rgb[c] = uint8_t((2 * sum[c] + n) / (2 * n));  // rounded to nearest
        out.push_back(s);
      }
    }
  }
  for (const Smoothed& s : out) std::memcpy(color.ptr<uint8_t>(s.y) + 3 * s.x, s.rgb, 3);
}

int hole_fill_reach(const HoleFillParams& params) {
  if (params.smooth_px >= 0) return params.smooth_px;
  return params.method == HoleFillMethod::Rays ? kRaysSmoothPx : std::max(kPyramidSmoothPx, kPyramidSmoothMaxPx);
}

void fill_holes(cv::Mat& color, const cv::Mat& depth, const HoleFillParams& params, cv::Mat& mask,
                cv::Mat* filled_depth, HoleFillHistory* history, const cv::Mat* left_to_caller) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && mask.type() == CV_8UC1 &&
            color.size() == depth.size() && mask.size() == color.size());
  CV_Assert(!left_to_caller || (left_to_caller->type() == CV_8UC1 && left_to_caller->size() == color.size()));
  if (params.method == HoleFillMethod::Rays) {
    HoleFillParams rays = params;
    if (rays.smooth_px < 0) rays.smooth_px = kRaysSmoothPx;
    fill_holes_along_rays(color, depth, rays, mask, filled_depth);
    return;
  }
  fill_holes_by_pyramid(color, depth, params.background_ratio, params.smooth_px, mask, filled_depth, history,
                        left_to_caller);
}

}  // namespace vclassroom
