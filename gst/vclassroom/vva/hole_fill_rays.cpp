// The hole filling before issue 35 (HoleFillMethod::Rays), kept for comparison: the nearest known pixels
// along the row and the column, those on the far side weighted by 1/distance, a box blur, and optionally the
// background's texture mirrored in (docs/vva.md).
#include <gst/vclassroom/vva/hole_fill.h>
#include <gst/vclassroom/vva/hole_runs.h>

#include <algorithm>
#include <cstring>
#include <vector>

namespace vclassroom {

namespace {

// The fill's texture reaches this far (px) into a hole: a disocclusion's width. Farther, a mirror image
// has little to do with what is hidden, the fill fades out (fade_unseen) and the texture's work would grow
// with every unseen pixel of a view that looks out of the room.
constexpr int kTextureReach = 16;

// A hole pixel's texture source: the known background pixel its texture is taken from (the mirror image of
// the pixel across the hole's edge on its nearest background side), both as y * W + x.
struct TextureSource {
  int hole, source;
};

// The hole filling of fill_holes_from_background. Holes are few (a few % of
// a fused view), so the work is arranged to cost little elsewhere: rows are
// scanned four depths at a time for holes, a hole's left/right candidates are
// the ends of its run in the row, and its up/down candidates come from a
// per-column state (the known row above and below the column's current run
// of holes, found by walking down the run once). Candidates are always known
// pixels, which the filling never writes, so `color` is filled in place.
// With `texture`, notes each filled pixel's texture source; false when there was no hole.
bool fill_hole_pixels(cv::Mat& color, const cv::Mat& depth, double background_ratio, cv::Mat* new_depth,
                      cv::Mat& mask, bool texture, std::vector<TextureSource>* sources) {
  const int W = color.cols, H = color.rows;
  // Per column: the known row above the current run of holes (-1: none) and
  // the first known row below it (H: none); a run starts where below < y.
  std::vector<int> above(size_t(W), -1), below(size_t(W), -1);
  const float keep = float(1.0 - background_ratio);
  bool any_hole = false;
  struct Cand {
    int z = 0, dist = 0;
    const uint8_t* c = nullptr;
  };
  // k[0..3] below: the candidate to the left, right, above and below; the step from the hole towards each.
  constexpr int kStepX[4] = {-1, 1, 0, 0}, kStepY[4] = {0, 0, -1, 1};
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    uint8_t* c = color.ptr<uint8_t>(y);
    uint16_t* nd = new_depth ? new_depth->ptr<uint16_t>(y) : nullptr;
    uint8_t* m = mask.ptr<uint8_t>(y);
    int x = 0, a = 0, b = 0;
    while (next_hole_run(d, W, &x, &a, &b)) {  // holes a..b, known pixels (if any) at a - 1 and b + 1
      any_hole = true;
      for (int h = a; h <= b; ++h) {
        find_known_rows(depth, y, h, above, below);
        Cand k[4];
        if (a > 0) k[0] = Cand{d[a - 1], h - (a - 1), c + 3 * (a - 1)};
        if (b + 1 < W) k[1] = Cand{d[b + 1], b + 1 - h, c + 3 * (b + 1)};
        if (above[h] >= 0)
          k[2] = Cand{depth.ptr<uint16_t>(above[h])[h], y - above[h], color.ptr<uint8_t>(above[h]) + 3 * h};
        if (below[h] < H)
          k[3] = Cand{depth.ptr<uint16_t>(below[h])[h], below[h] - y, color.ptr<uint8_t>(below[h]) + 3 * h};
        int zmax = 0;
        for (const Cand& q : k) zmax = std::max(zmax, q.z);
        if (!zmax) continue;
        // Only the far (background) side counts, nearer candidates weighted more.
        const float zlo = float(zmax) * keep;
        float acc[3] = {0, 0, 0}, wsum = 0, zsum = 0;
        int nearest = -1;  // the nearest background candidate, for the texture
        for (int i = 0; i < 4; ++i) {
          const Cand& q = k[i];
          if (!q.z || q.z < zlo) continue;
          if (nearest < 0 || q.dist < k[nearest].dist) nearest = i;
          const float w = 1.0f / float(q.dist);
          acc[0] += w * q.c[0];
          acc[1] += w * q.c[1];
          acc[2] += w * q.c[2];
          zsum += w * q.z;
          wsum += w;
        }
        const float iw = 1.0f / wsum;
        c[3 * h] = uint8_t(acc[0] * iw + 0.5f);
        c[3 * h + 1] = uint8_t(acc[1] * iw + 0.5f);
        c[3 * h + 2] = uint8_t(acc[2] * iw + 0.5f);
        if (nd) nd[h] = uint16_t(zsum * iw + 0.5f);
        m[h] = 255;
        if (texture && nearest >= 0 && k[nearest].dist <= kTextureReach) {
          // The mirror image across the edge (as far beyond the edge as the hole pixel is before it), if it is
          // known and on the background side too.
          const int reach = 2 * k[nearest].dist - 1;
          const int sx = h + kStepX[nearest] * reach, sy = y + kStepY[nearest] * reach;
          if (sx >= 1 && sx + 1 < W && sy >= 1 && sy + 1 < H) {
            const uint16_t zs = depth.ptr<uint16_t>(sy)[sx];
            if (zs && float(zs) >= zlo) sources->push_back({y * W + h, sy * W + sx});
          }
        }
      }
    }
  }
  return any_hole;
}

// Each filled pixel gets its texture source's deviation from the source's 3x3 neighbourhood mean, times
// `texture`.
void add_texture(cv::Mat& color, const std::vector<TextureSource>& sources, float texture) {
  const int W = color.cols;
  const size_t step = color.step;
  for (const TextureSource& t : sources) {
    const uint8_t* src = color.data + size_t(t.source / W) * step + 3 * size_t(t.source % W);
    uint8_t* out = color.data + size_t(t.hole / W) * step + 3 * size_t(t.hole % W);
    for (int ch = 0; ch < 3; ++ch) {
      int sum = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) sum += src[ptrdiff_t(dy) * ptrdiff_t(step) + 3 * dx + ch];
      const float detail = float(src[ch]) - float(sum) / 9.f;
      out[ch] = cv::saturate_cast<uint8_t>(float(out[ch]) + texture * detail);
    }
  }
}

}  // namespace

void fill_holes_along_rays(cv::Mat& color, const cv::Mat& depth, const HoleFillParams& params, cv::Mat& mask,
                           cv::Mat* filled_depth) {
  static thread_local std::vector<TextureSource> sources;
  sources.clear();
  const float texture = float(params.texture);
  if (!fill_hole_pixels(color, depth, params.background_ratio, filled_depth, mask, texture > 0.f, &sources) ||
      params.smooth_px <= 0)
    return;
  smooth_filled_pixels(color, mask, params.smooth_px);
  if (texture > 0.f) add_texture(color, sources, texture);
}

}  // namespace vclassroom
