#include <gst/vclassroom/vda/depth_completion.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/vda/depth_tolerance.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

// Per-row kernels of the per-frame stages: branch-free so that the compiler
// vectorises them. External linkage: GCC's target_clones needs it.
namespace detail {

// 255 where live depth is clearly in front of the prior (a learner).
VCLASSROOM_SIMD_CLONES
void prior_front_row(const uint16_t* live, const uint16_t* prior, int n, uint32_t tol_min, uint32_t rq16,
                     uint8_t* front) {
  for (int x = 0; x < n; ++x) {
    const uint32_t l = live[x], p = prior[x];
    const uint32_t t = depth_tolerance(p, tol_min, rq16);
    front[x] = (l != 0) & (l + t < p) ? 255 : 0;
  }
}

// 255 where the live colour differs from the empty room's by more than `tol`
// in some channel.
VCLASSROOM_SIMD_CLONES
void color_differs_row(const uint8_t* c, const uint8_t* pc, int n, int tol, uint8_t* bad) {
  for (int x = 0; x < n; ++x) {
    const int d0 = std::abs(c[3 * x] - pc[3 * x]), d1 = std::abs(c[3 * x + 1] - pc[3 * x + 1]),
              d2 = std::abs(c[3 * x + 2] - pc[3 * x + 2]);
    bad[x] = std::max(d0, std::max(d1, d2)) > tol ? 255 : 0;
  }
}

// The prior fill's choice per pixel. `keep_live`: 255 where a hole must not
// take the prior (near a learner, colour changed, not measured, labelled).
VCLASSROOM_SIMD_CLONES
void prior_select_row(const uint16_t* live, const uint16_t* prior, const uint8_t* keep_live, const uint8_t* label,
                      int n, uint32_t tol_min, uint32_t rq16, uint16_t* out) {
  for (int x = 0; x < n; ++x) {
    const uint32_t l = live[x], p = prior[x];
    const uint32_t t = depth_tolerance(p, tol_min, rq16);
    const uint32_t diff = l > p ? l - p : p - l;
    const bool agree = (l != 0) & (diff <= t);
    const bool hole = (l == 0) & (keep_live[x] == 0);
    const bool take = (p != 0) & (agree | hole) & (label[x] == 0);
    out[x] = take ? static_cast<uint16_t>(p) : static_cast<uint16_t>(l);
  }
}

}  // namespace detail

namespace {

inline int agree_tol(int depth, int min_mm, double ratio) {
  return std::max(min_mm, static_cast<int>(ratio * depth));
}

cv::Mat diamond5() {
  return (cv::Mat_<uint8_t>(5, 5) << 0, 0, 1, 0, 0, 0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 0, 1, 1, 1, 0, 0, 0, 1, 0, 0);
}

// Ku et al.'s 5x5 diamond, and full squares, as lists of offsets.
std::vector<cv::Point> kernel_offsets(int radius, bool diamond) {
  std::vector<cv::Point> k;
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      if (!diamond || std::abs(dx) + std::abs(dy) <= radius) k.emplace_back(dx, dy);
  return k;
}

// One Ku-style step: the dilation of the inverted depth (max_depth - D, so
// the maximum is the nearest surface) and of the depth itself (the farthest),
// evaluated at the hole pixels only, which is all the step reads. A hole
// pixel is filled with the mid depth when the two agree and it is enclosed by
// valid depth on all four sides within the kernel's reach: a wider hole may
// hide a depth edge the kernel cannot see, and the colour-guided fill decides
// those better. Returns how many pixels it filled.
int grow_agreeing(cv::Mat& d, std::vector<cv::Point>& holes, const std::vector<cv::Point>& kernel, int reach,
                  const GuidedCompletionParams& p) {
  const int maxd = p.max_depth_mm;
  thread_local std::vector<std::pair<cv::Point, uint16_t>> fills;
  fills.clear();
  // Away from the border (most holes) the kernel is read through linear
  // offsets, without bounds checks.
  int radius = reach;
  for (const cv::Point& o : kernel) radius = std::max(radius, std::max(std::abs(o.x), std::abs(o.y)));
  const ptrdiff_t step = static_cast<ptrdiff_t>(d.step1());
  thread_local std::vector<ptrdiff_t> lin;
  lin.clear();
  for (const cv::Point& o : kernel) lin.push_back(o.y * step + o.x);
  // near_inv = maxd - the nearest valid depth around the hole (0: none), far =
  // the farthest: the hole takes their mean where they agree (one surface).
  auto fill_if_one_surface = [&](const cv::Point& h, int near_inv, int far) {
    if (!near_inv) return;
    const int nearest = maxd - near_inv;
    if (far - nearest <= agree_tol(nearest, p.agree_min_mm, p.agree_ratio))
      fills.emplace_back(h, static_cast<uint16_t>((nearest + far + 1) / 2));
  };
  for (const cv::Point& h : holes) {
    if (h.x >= radius && h.y >= radius && h.x + radius < d.cols && h.y + radius < d.rows) {
      const uint16_t* c = d.ptr<uint16_t>(h.y) + h.x;
      auto reached = [&](ptrdiff_t dir) {
        for (int s = 1; s <= reach; ++s)
          if (c[s * dir]) return true;
        return false;
      };
      if (!reached(-1) || !reached(1) || !reached(-step) || !reached(step)) continue;
      int near_inv = 0, far = 0;
      for (const ptrdiff_t o : lin) {
        const int v = c[o];
        if (!v) continue;
        near_inv = std::max(near_inv, std::max(1, maxd - v));
        far = std::max(far, v);
      }
      fill_if_one_surface(h, near_inv, far);
      continue;
    }
    bool enclosed = true;
    const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
    for (int k = 0; k < 4 && enclosed; ++k) {
      int s = 1;
      for (; s <= reach; ++s) {
        const int nx = h.x + s * dx[k], ny = h.y + s * dy[k];
        if (nx < 0 || ny < 0 || nx >= d.cols || ny >= d.rows) {
          s = reach + 1;
          break;
        }
        if (d.at<uint16_t>(ny, nx)) break;
      }
      enclosed = s <= reach;
    }
    if (!enclosed) continue;
    int near_inv = 0, far = 0;
    for (const cv::Point& o : kernel) {
      const int x = h.x + o.x, y = h.y + o.y;
      if (x < 0 || y < 0 || x >= d.cols || y >= d.rows) continue;
      const int v = d.at<uint16_t>(y, x);
      if (!v) continue;
      near_inv = std::max(near_inv, std::max(1, maxd - v));
      far = std::max(far, v);
    }
    fill_if_one_surface(h, near_inv, far);
  }
  // Applied after the pass, as a dilation reads only its input.
  for (const auto& [pt, v] : fills) d.at<uint16_t>(pt) = v;
  if (!fills.empty())
    holes.erase(std::remove_if(holes.begin(), holes.end(), [&](const cv::Point& h) { return d.at<uint16_t>(h) != 0; }),
                holes.end());
  return static_cast<int>(fills.size());
}

// Colour-guided fill of every hole pixel from the ends of its horizontal and
// vertical hole runs (see the header). `src` is read, `dst` written.
void run_end_fill(cv::Mat& src, const std::vector<cv::Point>& holes, const cv::Mat& color,
                  const GuidedCompletionParams& p, cv::Mat* ambiguous) {
  const int w = src.cols, h = src.rows;
  // Written after the pass: every fill reads the image as it was before it
  // (hole pixels still 0), without a copy of the whole image.
  thread_local std::vector<uint16_t> fills;
  fills.assign(holes.size(), 0);
  size_t hole_index = 0;
  const double inv_sigma2 = 1.0 / (p.color_sigma * p.color_sigma);
  const bool has_color = !color.empty();
  // exp(-d2 / sigma^2) for squared colour distances d2 in steps of 8 (0 beyond 6 sigma).
  const int lut_size = static_cast<int>(36.0 * p.color_sigma * p.color_sigma / 8.0) + 2;
  std::vector<float> color_lut(lut_size);
  for (int i = 0; i < lut_size; ++i) color_lut[i] = static_cast<float>(std::exp(-8.0 * i * inv_sigma2));
  // Nearest valid row above / below each hole pixel, by two passes over the
  // holes (row-major order visits the pixel above first).
  thread_local cv::Mat up, down;
  up.create(src.size(), CV_16SC1);
  down.create(src.size(), CV_16SC1);
  for (const cv::Point& q : holes)
    up.at<int16_t>(q) = q.y == 0 ? -1 : (src.at<uint16_t>(q.y - 1, q.x) ? q.y - 1 : up.at<int16_t>(q.y - 1, q.x));
  for (auto it = holes.rbegin(); it != holes.rend(); ++it) {
    const cv::Point& q = *it;
    down.at<int16_t>(q) =
        q.y == h - 1 ? -1 : (src.at<uint16_t>(q.y + 1, q.x) ? q.y + 1 : down.at<int16_t>(q.y + 1, q.x));
  }
  // Holes are in row-major order, so each horizontal run is a contiguous stretch.
  size_t i = 0;
  while (i < holes.size()) {
    size_t j = i;
    while (j + 1 < holes.size() && holes[j + 1].y == holes[i].y && holes[j + 1].x == holes[j].x + 1) ++j;
    const int y = holes[i].y, a = holes[i].x, b = holes[j].x;
    for (int xi = a; xi <= b; ++xi, ++hole_index) {
      // Candidates: 0 left, 1 right, 2 up, 3 down.
      int cx[4], cy[4], dist[4];
      bool ok[4];
      ok[0] = a > 0, cx[0] = a - 1, cy[0] = y, dist[0] = xi - a + 1;
      ok[1] = b + 1 < w, cx[1] = b + 1, cy[1] = y, dist[1] = b + 1 - xi;
      const int yu = up.at<int16_t>(y, xi), yd = down.at<int16_t>(y, xi);
      ok[2] = yu >= 0, cx[2] = xi, cy[2] = yu, dist[2] = y - yu;
      ok[3] = yd >= 0, cx[3] = xi, cy[3] = yd, dist[3] = yd - y;
      double z[4] = {0, 0, 0, 0}, wgt[4];
      const cv::Vec3b c0 = has_color ? color.at<cv::Vec3b>(y, xi) : cv::Vec3b();
      for (int k = 0; k < 4; ++k) {
        if (!ok[k]) {
          wgt[k] = 0;
          continue;
        }
        z[k] = src.at<uint16_t>(cy[k], cx[k]);
        double cw = 1.0;
        if (has_color) {
          const cv::Vec3b c = color.at<cv::Vec3b>(cy[k], cx[k]);
          const int dr = c[0] - c0[0], dg = c[1] - c0[1], db = c[2] - c0[2];
          const int bin = (dr * dr + dg * dg + db * db) >> 3;
          cw = bin < lut_size ? color_lut[bin] : 0.0;
        }
        wgt[k] = (cw + 1e-6) / dist[k];
      }
      // A run whose two ends lie on one surface: interpolate 1/Z (exact on a
      // plane). One surface: the ends agree, or one end's slope (1/Z is linear
      // along an image line on a plane) carried across the hole reaches the other.
      double v[4] = {z[0], z[1], z[2], z[3]};
      const int step_x[4] = {-1, 1, 0, 0}, step_y[4] = {0, 0, -1, 1};
      auto beyond = [&](int k) -> double {
        const int bx = cx[k] + step_x[k], by = cy[k] + step_y[k];
        if (bx < 0 || by < 0 || bx >= w || by >= h) return 0;
        return src.at<uint16_t>(by, bx);
      };
      auto reaches = [&](int from, int to) {
        const double zb = beyond(from);
        if (zb <= 0) return false;
        const double slope = 1.0 / z[from] - 1.0 / zb;  // per pixel, towards the hole
        const double inv = 1.0 / z[from] + slope * (dist[from] + dist[to]);
        if (inv <= 0) return false;
        return std::abs(1.0 / inv - z[to]) <= agree_tol(static_cast<int>(z[to]), p.agree_min_mm, p.agree_ratio);
      };
      for (int pair = 0; pair < 2; ++pair) {
        const int m = 2 * pair, n = m + 1;
        if (!ok[m] || !ok[n]) continue;
        const bool agree =
            std::abs(z[m] - z[n]) <= agree_tol(static_cast<int>(std::min(z[m], z[n])), p.agree_min_mm, p.agree_ratio);
        if (!agree && !reaches(m, n) && !reaches(n, m)) continue;
        const double inv = (dist[n] / z[m] + dist[m] / z[n]) / (dist[m] + dist[n]);
        v[m] = v[n] = 1.0 / inv;
      }
      int best = -1;
      for (int k = 0; k < 4; ++k)
        if (wgt[k] > 0 && (best < 0 || wgt[k] > wgt[best])) best = k;
      if (best < 0) continue;
      const double tol = agree_tol(static_cast<int>(v[best]), p.agree_min_mm, p.agree_ratio);
      double sw = 0, sv = 0, sw_all = 0;
      for (int k = 0; k < 4; ++k) {
        sw_all += wgt[k];
        if (wgt[k] > 0 && std::abs(v[k] - v[best]) <= tol) sw += wgt[k], sv += wgt[k] * v[k];
      }
      fills[hole_index] = cv::saturate_cast<uint16_t>(sv / sw);
      if (ambiguous && sw < (1.0 - p.ambiguous_share) * sw_all) ambiguous->at<uint8_t>(y, xi) = 255;
    }
    i = j + 1;
  }
  for (size_t k = 0; k < holes.size(); ++k)
    if (fills[k]) src.at<uint16_t>(holes[k]) = fills[k];
}

// The zero pixels of `depth`, row-major. Most pixels are not holes: four at a
// time are tested for a zero lane with one 64-bit word.
void hole_list(const cv::Mat& depth, std::vector<cv::Point>& holes) {
  holes.clear();
  const int w = depth.cols;
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* r = depth.ptr<uint16_t>(y);
    int x = 0;
    for (; x + 4 <= w; x += 4) {
      uint64_t v;
      std::memcpy(&v, r + x, sizeof v);
      if (!((v - 0x0001000100010001ull) & ~v & 0x8000800080008000ull)) continue;
      for (int k = 0; k < 4; ++k)
        if (!r[x + k]) holes.emplace_back(x + k, y);
    }
    for (; x < w; ++x)
      if (!r[x]) holes.emplace_back(x, y);
  }
}

// Median of nine values by a fixed exchange network (19 min/max, no branches).
inline uint16_t median9(uint16_t* p) {
  auto sort2 = [](uint16_t& a, uint16_t& b) {
    const uint16_t lo = std::min(a, b), hi = std::max(a, b);
    a = lo, b = hi;
  };
  sort2(p[1], p[2]), sort2(p[4], p[5]), sort2(p[7], p[8]);
  sort2(p[0], p[1]), sort2(p[3], p[4]), sort2(p[6], p[7]);
  sort2(p[1], p[2]), sort2(p[4], p[5]), sort2(p[7], p[8]);
  sort2(p[0], p[3]), sort2(p[5], p[8]), sort2(p[4], p[7]);
  sort2(p[3], p[6]), sort2(p[1], p[4]), sort2(p[2], p[5]);
  sort2(p[4], p[7]), sort2(p[4], p[2]), sort2(p[6], p[4]);
  sort2(p[4], p[2]);
  return p[4];
}

// Median of the image at each pixel of `pts` that has depth, over its 3x3 or
// 5x5 window (0s excluded, and with `color` given, pixels whose colour differs
// from the centre's by more than `max_color_distance`); all medians are taken
// before any is written.
void filled_median_at(cv::Mat& out, const std::vector<cv::Point>& pts, int size, const cv::Mat& color,
                      double max_color_distance) {
  if (pts.empty()) return;
  thread_local std::vector<uint16_t> med;
  med.assign(pts.size(), 0);
  uint16_t vals[25];
  const int r2 = size >= 5 ? 2 : 1;
  const bool by_color = !color.empty() && max_color_distance > 0;
  const int max_d2 = by_color ? static_cast<int>(std::min(1e9, max_color_distance * max_color_distance)) : 0;
  auto same_surface = [&](const cv::Point& c, int x, int y) {
    if (!by_color) return true;
    const uint8_t* p0 = color.ptr<uint8_t>(c.y) + 3 * c.x;
    const uint8_t* p1 = color.ptr<uint8_t>(y) + 3 * x;
    const int dr = p0[0] - p1[0], dg = p0[1] - p1[1], db = p0[2] - p1[2];
    return dr * dr + dg * dg + db * db <= max_d2;
  };
  for (size_t i = 0; i < pts.size(); ++i) {
    const cv::Point& h = pts[i];
    if (!out.at<uint16_t>(h)) continue;
    int n = 0;
    bool full = true;
    for (int y = std::max(0, h.y - r2); y <= std::min(out.rows - 1, h.y + r2); ++y) {
      const uint16_t* r = out.ptr<uint16_t>(y);
      for (int x = std::max(0, h.x - r2); x <= std::min(out.cols - 1, h.x + r2); ++x) {
        if (r[x] && same_surface(h, x, y))
          vals[n++] = r[x];
        else
          full = false;
      }
    }
    if (n == 9 && full)
      med[i] = median9(vals);
    else {
      std::nth_element(vals, vals + n / 2, vals + n);
      med[i] = vals[n / 2];
    }
  }
  for (size_t i = 0; i < pts.size(); ++i)
    if (med[i]) out.at<uint16_t>(pts[i]) = med[i];
}

// The image-guided stage on `out` in place; `all_holes` are its zero pixels.
void guided_in_place(cv::Mat& out, const std::vector<cv::Point>& all_holes, const cv::Mat& color,
                     const GuidedCompletionParams& p, cv::Mat* ambiguous) {
  thread_local std::vector<cv::Point> holes, short_runs;
  holes = all_holes;
  if (p.morphology && !holes.empty()) {
    static const std::vector<cv::Point> k_diamond = kernel_offsets(2, true), k5 = kernel_offsets(2, false),
                                        k7 = kernel_offsets(3, false);
    // A hole is enclosed within the largest reach (3 px) on both sides of its
    // row only in a horizontal run of at most 5 holes, and the steps fill only
    // enclosed holes, so longer runs never change here: most holes are in them.
    const int max_run = 2 * 3 - 1;
    short_runs.clear();
    for (size_t i = 0; i < all_holes.size();) {
      size_t j = i;
      while (j + 1 < all_holes.size() && all_holes[j + 1].y == all_holes[i].y &&
             all_holes[j + 1].x == all_holes[j].x + 1)
        ++j;
      if (static_cast<int>(j - i + 1) <= max_run) short_runs.insert(short_runs.end(), &all_holes[i], &all_holes[j] + 1);
      i = j + 1;
    }
    int filled = 0;
    filled += grow_agreeing(out, short_runs, k_diamond, 2, p);  // dilation with the diamond
    filled += grow_agreeing(out, short_runs, k5, 2, p);         // closing of small holes
    filled += grow_agreeing(out, short_runs, k7, 3, p);         // hole fill
    if (filled)
      holes.erase(std::remove_if(holes.begin(), holes.end(), [&](const cv::Point& h) { return out.at<uint16_t>(h) != 0; }),
                  holes.end());
  }
  if (p.hole_fill && !holes.empty()) run_end_fill(out, holes, color, p, ambiguous);
  if (p.median) filled_median_at(out, all_holes, p.median_size, color, p.median_color_distance);
}

}  // namespace

void prior_fill(const cv::Mat& live, const cv::Mat& color, const StaticPrior& sp, const cv::Mat& label,
                const PriorFillParams& p, cv::Mat& out) {
  const cv::Mat& prior = sp.depth;
  const cv::Mat& prior_color = sp.color;
  CV_Assert(live.type() == CV_16UC1 && prior.type() == CV_16UC1 && live.size() == prior.size());
  const bool color_test = p.color_tolerance > 0 && !color.empty() && !prior_color.empty();
  CV_Assert(!color_test || (color.type() == CV_8UC3 && prior_color.type() == CV_8UC3 &&
                            color.size() == live.size() && prior_color.size() == live.size()));
  CV_Assert(sp.measured.empty() || (sp.measured.type() == CV_8UC1 && sp.measured.size() == live.size()));
  CV_Assert(label.empty() || (label.type() == CV_8UC1 && label.size() == live.size()));
  const int w = live.cols;
  const uint32_t tol_min = static_cast<uint32_t>(std::max(0, p.tolerance_min_mm));
  const uint32_t rq16 = detail::ratio_q16(p.tolerance_ratio);
  // Learners: live depth clearly in front of the prior. Flying pixels along the
  // room's own depth edges are also "in front" but only a pixel or two wide: an
  // opening (5x5) drops them and keeps bodies; its dilation and the guard's
  // compose into one dilation 5 + 2 guard wide. Only this needs whole-image
  // morphology; the rest is two fused row passes.
  thread_local cv::Mat front, eroded, guard;
  const bool use_guard = p.learner_guard_px > 0;
  if (use_guard) {
    front.create(live.size(), CV_8UC1);
    for (int y = 0; y < live.rows; ++y)
      detail::prior_front_row(live.ptr<uint16_t>(y), prior.ptr<uint16_t>(y), w, tol_min, rq16, front.ptr<uint8_t>(y));
    cv::erode(front, eroded, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
    const int k = 5 + 2 * p.learner_guard_px;
    cv::dilate(eroded, guard, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
  }
  const bool use_measured = p.measured_only && !sp.measured.empty();
  thread_local std::vector<uint8_t> keep, bad, zeros;
  keep.assign(w, 0);
  bad.assign(w, 0);
  zeros.assign(w, 0);
  out.create(live.size(), CV_16UC1);
  for (int y = 0; y < live.rows; ++y) {
    uint8_t* k = keep.data();
    if (color_test) detail::color_differs_row(color.ptr<uint8_t>(y), prior_color.ptr<uint8_t>(y), w,
                                              p.color_tolerance, bad.data());
    const uint8_t* g = use_guard ? guard.ptr<uint8_t>(y) : zeros.data();
    const uint8_t* m = use_measured ? sp.measured.ptr<uint8_t>(y) : nullptr;
    const uint8_t* cb = bad.data();
    if (m)
      for (int x = 0; x < w; ++x) k[x] = g[x] | cb[x] | static_cast<uint8_t>(~m[x]);
    else
      for (int x = 0; x < w; ++x) k[x] = g[x] | cb[x];
    detail::prior_select_row(live.ptr<uint16_t>(y), prior.ptr<uint16_t>(y), k,
                             label.empty() ? zeros.data() : label.ptr<uint8_t>(y), w, tol_min, rq16,
                             out.ptr<uint16_t>(y));
  }
}

void guided_completion(const cv::Mat& depth, const cv::Mat& color, const GuidedCompletionParams& p, cv::Mat& out,
                       cv::Mat* filled, cv::Mat* ambiguous) {
  CV_Assert(depth.type() == CV_16UC1);
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == depth.size()));
  // Per-frame work is proportional to the holes, not the image: the
  // morphological steps are evaluated at hole pixels only.
  std::vector<cv::Point> all_holes;
  hole_list(depth, all_holes);
  if (out.data != depth.data) depth.copyTo(out);
  if (ambiguous) {
    ambiguous->create(depth.size(), CV_8UC1);
    ambiguous->setTo(0);
  }
  guided_in_place(out, all_holes, color, p, ambiguous);
  if (filled) {
    filled->create(depth.size(), CV_8UC1);
    filled->setTo(0);
    for (const cv::Point& h : all_holes)
      if (out.at<uint16_t>(h)) filled->at<uint8_t>(h) = 255;
  }
}

void nearest_fill(const cv::Mat& depth, cv::Mat& out) {
  CV_Assert(depth.type() == CV_16UC1);
  cv::Mat holes;
  cv::compare(depth, 0, holes, cv::CMP_EQ);
  const int n_holes = cv::countNonZero(holes);
  if (n_holes == 0 || n_holes == depth.rows * depth.cols) {
    depth.copyTo(out);
    return;
  }
  cv::Mat dist, labels;
  cv::distanceTransform(holes, dist, labels, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
  double max_label = 0;
  cv::minMaxLoc(labels, nullptr, &max_label);
  std::vector<uint16_t> lut(static_cast<size_t>(max_label) + 1, 0);
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const int* l = labels.ptr<int>(y);
    for (int x = 0; x < depth.cols; ++x)
      if (d[x]) lut[l[x]] = d[x];
  }
  out.create(depth.size(), CV_16UC1);
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const int* l = labels.ptr<int>(y);
    uint16_t* o = out.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x) o[x] = d[x] ? d[x] : lut[l[x]];
  }
}

namespace {

// Colorization over the unknown pixels `pts` (row-major). Each unknown pixel
// keeps its known neighbours' weighted sum as one constant and links to its
// unknown neighbours by index, so a sweep touches only the unknown pixels'
// own records, not the image.
void colorize_points(cv::Mat& depth, const cv::Mat& color, const std::vector<cv::Point>& pts,
                     const ColorizationParams& p) {
  const int w = depth.cols, h = depth.rows;
  const size_t n = pts.size();
  if (!n) return;
  bool zero_unknown = false;
  for (const cv::Point& q : pts) zero_unknown |= depth.at<uint16_t>(q) == 0;
  if (zero_unknown) {
    cv::Mat filled;
    nearest_fill(depth, filled);
    for (const cv::Point& q : pts) depth.at<uint16_t>(q) = filled.at<uint16_t>(q);
  }
  // Which pixels are unknown, and their index: written and cleared at `pts`
  // only, so per frame nothing of the size of the image is touched.
  thread_local cv::Mat index;
  if (index.size() != depth.size() || index.type() != CV_32SC1) {
    index.create(depth.size(), CV_32SC1);
    index.setTo(-1);
  }
  for (size_t i = 0; i < n; ++i) index.at<int>(pts[i]) = static_cast<int>(i);
  struct Node {
    float cst;          // sum of w * D over the known neighbours
    float omega_inv_sw; // relaxation / sum of all weights; 0 = no neighbour (left as it is)
    int link[8];        // unknown neighbours (unused: the pixel itself, weight 0)
    float wl[8];
  };
  thread_local std::vector<Node> nodes;
  thread_local std::vector<float> z;
  nodes.resize(n);
  z.resize(n);
  for (size_t i = 0; i < n; ++i) z[i] = depth.at<uint16_t>(pts[i]);
  const int dxs[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
  const int dys[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
  const double inv_c2 = 1.0 / (p.color_sigma * p.color_sigma);
  // exp(-d2 / sigma^2) for squared colour distances d2 in steps of 8 (0 beyond 6 sigma).
  const int lut_size = static_cast<int>(36.0 * p.color_sigma * p.color_sigma / 8.0) + 2;
  std::vector<float> color_lut(lut_size);
  for (int i = 0; i < lut_size; ++i) color_lut[i] = static_cast<float>(std::exp(-8.0 * i * inv_c2));
  const float omega = static_cast<float>(p.relaxation);
  for (size_t i = 0; i < n; ++i) {
    const int x = pts[i].x, y = pts[i].y;
    const float zr = z[i];
    const double sd = std::max(1.0, p.depth_sigma_ratio * zr);
    const uint8_t* c0 = color.empty() ? nullptr : color.ptr<uint8_t>(y) + 3 * x;
    Node& nd = nodes[i];
    float cst = 0, sw = 0;
    int nl = 0;
    for (int k = 0; k < 8; ++k) {
      const int nx = x + dxs[k], ny = y + dys[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      const float zs = depth.at<uint16_t>(ny, nx);
      if (zs <= 0) continue;  // no depth: not a neighbour
      float cw = 1.0f;
      if (c0) {
        const uint8_t* c1 = c0 + (dys[k] * static_cast<int>(color.step[0]) + 3 * dxs[k]);
        const int dr = c0[0] - c1[0], dg = c0[1] - c1[1], db = c0[2] - c1[2];
        const int bin = (dr * dr + dg * dg + db * db) >> 3;
        cw = bin < lut_size ? color_lut[bin] : 0.0f;
      }
      if (p.depth_sigma_ratio > 0) cw *= static_cast<float>(std::exp(-(zr - zs) * (zr - zs) / (sd * sd)));
      // A small floor keeps every unknown region tied to its surroundings,
      // so the relaxation stays anchored where colours differ all round.
      cw = std::max(cw, 1e-6f);
      if (dxs[k] && dys[k]) cw *= 0.70710678f;
      sw += cw;
      const int j = index.at<int>(ny, nx);
      if (j >= 0) {
        nd.link[nl] = j;
        nd.wl[nl++] = cw;
      } else {
        cst += cw * zs;
      }
    }
    for (; nl < 8; ++nl) nd.link[nl] = static_cast<int>(i), nd.wl[nl] = 0;
    nd.cst = cst;
    nd.omega_inv_sw = sw > 1e-12f ? omega / sw : 0.0f;
  }
  for (const cv::Point& q : pts) index.at<int>(q) = -1;
  // Successive over-relaxation in row-major order (Gauss-Seidel: each update
  // sees its neighbours' newest values).
  float* zp = z.data();
  for (int it = 0; it < p.iterations; ++it)
    for (size_t i = 0; i < n; ++i) {
      const Node& nd = nodes[i];
      float sv = nd.cst;
      for (int k = 0; k < 8; ++k) sv += nd.wl[k] * zp[nd.link[k]];
      zp[i] += nd.omega_inv_sw * sv - (nd.omega_inv_sw > 0 ? omega : 0.0f) * zp[i];
    }
  for (size_t i = 0; i < n; ++i) {
    const float v = zp[i];
    if (std::isfinite(v) && v >= 1.0f) depth.at<uint16_t>(pts[i]) = cv::saturate_cast<uint16_t>(v);
  }
}

}  // namespace

void filled_median(cv::Mat& depth, const cv::Mat& filled, int size, const cv::Mat& color,
                   double max_color_distance) {
  CV_Assert(depth.type() == CV_16UC1 && filled.type() == CV_8UC1 && filled.size() == depth.size());
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == depth.size()));
  std::vector<cv::Point> pts;
  cv::findNonZero(filled, pts);
  filled_median_at(depth, pts, size, color, max_color_distance);
}

void colorization_fill(cv::Mat& depth, const cv::Mat& color, const cv::Mat& unknown, const ColorizationParams& p) {
  CV_Assert(depth.type() == CV_16UC1 && unknown.type() == CV_8UC1 && unknown.size() == depth.size());
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == depth.size()));
  std::vector<cv::Point> pts;
  cv::findNonZero(unknown, pts);
  colorize_points(depth, color, pts, p);
}

void ku_fast_fill(const cv::Mat& depth_mm, const KuFastParams& p, cv::Mat& out) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  const float maxd = static_cast<float>(p.max_depth_m);
  cv::Mat d;
  depth_mm.convertTo(d, CV_32F, 0.001);
  auto invert = [&](cv::Mat& m) {
    for (int y = 0; y < m.rows; ++y) {
      float* r = m.ptr<float>(y);
      for (int x = 0; x < m.cols; ++x)
        if (r[x] > 0.1f) r[x] = maxd - r[x];
    }
  };
  auto fill_empty_from = [](cv::Mat& m, const cv::Mat& src) {
    for (int y = 0; y < m.rows; ++y) {
      float* r = m.ptr<float>(y);
      const float* s = src.ptr<float>(y);
      for (int x = 0; x < m.cols; ++x)
        if (r[x] < 0.1f) r[x] = s[x];
    }
  };
  invert(d);
  cv::dilate(d, d, diamond5());
  cv::morphologyEx(d, d, cv::MORPH_CLOSE, cv::Mat::ones(5, 5, CV_8U));
  cv::Mat dil;
  cv::dilate(d, dil, cv::Mat::ones(7, 7, CV_8U));
  fill_empty_from(d, dil);
  if (p.extrapolate) {
    for (int x = 0; x < d.cols; ++x) {
      int top = 0;
      while (top < d.rows && !(d.at<float>(top, x) > 0.1f)) ++top;
      // numpy's argmax of an all-false column is 0: nothing is extended there.
      if (top == d.rows) continue;
      const float v = d.at<float>(top, x);
      for (int y = 0; y < top; ++y) d.at<float>(y, x) = v;
    }
    cv::dilate(d, dil, cv::Mat::ones(31, 31, CV_8U));
    fill_empty_from(d, dil);
  }
  cv::medianBlur(d, d, 5);
  if (p.bilateral) {
    cv::Mat b;
    cv::bilateralFilter(d, b, 5, 1.5, 2.0);
    d = b;
  } else {
    cv::Mat b;
    cv::GaussianBlur(d, b, cv::Size(5, 5), 0);
    for (int y = 0; y < d.rows; ++y) {
      float* r = d.ptr<float>(y);
      const float* s = b.ptr<float>(y);
      for (int x = 0; x < d.cols; ++x)
        if (r[x] > 0.1f) r[x] = s[x];
    }
  }
  invert(d);
  out.create(depth_mm.size(), CV_16UC1);
  for (int y = 0; y < d.rows; ++y) {
    const float* r = d.ptr<float>(y);
    uint16_t* o = out.ptr<uint16_t>(y);
    for (int x = 0; x < d.cols; ++x) o[x] = r[x] > 0.1f ? cv::saturate_cast<uint16_t>(r[x] * 1000.0f) : 0;
  }
}

void depth_complete(const cv::Mat& live, const cv::Mat& color, const StaticPrior& prior, const cv::Mat& label,
                    const DepthCompleteOptions& o, cv::Mat& out) {
  CV_Assert(live.type() == CV_16UC1);
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == live.size()));
  if (o.use_prior && !prior.empty())
    prior_fill(live, color, prior, label, o.prior, out);
  else
    live.copyTo(out);
  if (!o.image_guided && !o.colorization) return;
  // Both later stages work on the holes left after the prior, in place: one
  // scan of the image finds them, and nothing else of its size is copied.
  thread_local std::vector<cv::Point> holes;
  hole_list(out, holes);
  if (holes.empty()) return;
  // The image-guided stage's median runs last, after colorization: before it,
  // the relaxation spreads the pixels the median moved into their
  // neighbourhood, and on the knocked-out Middlebury views that costs more
  // than the median gains (docs/vda.md).
  GuidedCompletionParams guided = o.guided;
  guided.median = false;
  if (o.image_guided) guided_in_place(out, holes, color, guided, nullptr);
  // What the image-guided stage filled is refined by colorization, and what it
  // could not fill is left to it too: the unknowns are all of the holes.
  if (o.colorization) colorize_points(out, color, holes, o.colorize);
  if (o.image_guided && o.guided.median)
    filled_median_at(out, holes, o.guided.median_size, color, o.guided.median_color_distance);
}

}  // namespace vclassroom
