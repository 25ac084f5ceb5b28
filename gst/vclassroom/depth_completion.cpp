#include "depth_completion.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

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
  std::vector<std::pair<cv::Point, uint16_t>> fills;
  for (const cv::Point& h : holes) {
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
    if (!near_inv) continue;
    const int nearest = maxd - near_inv;
    if (far - nearest <= agree_tol(nearest, p.agree_min_mm, p.agree_ratio))
      fills.emplace_back(h, static_cast<uint16_t>((nearest + far + 1) / 2));
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
void run_end_fill(const cv::Mat& src, const std::vector<cv::Point>& holes, const cv::Mat& color,
                  const GuidedCompletionParams& p, cv::Mat& dst, cv::Mat* ambiguous) {
  const int w = src.cols, h = src.rows;
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
    for (int xi = a; xi <= b; ++xi) {
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
      dst.at<uint16_t>(y, xi) = cv::saturate_cast<uint16_t>(sv / sw);
      if (ambiguous && sw < (1.0 - p.ambiguous_share) * sw_all) ambiguous->at<uint8_t>(y, xi) = 255;
    }
    i = j + 1;
  }
}

std::vector<cv::Point> hole_list(const cv::Mat& depth) {
  std::vector<cv::Point> holes;
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* r = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x)
      if (!r[x]) holes.emplace_back(x, y);
  }
  return holes;
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
  // Whole-image vector operations: this runs on every frame over every pixel.
  thread_local cv::Mat tol, sum, agree, take, tmp, guard;
  prior.convertTo(tol, CV_16U, p.tolerance_ratio);
  cv::max(tol, cv::Scalar(p.tolerance_min_mm), tol);
  // Agreeing live depth: the static room, measured better by the prior.
  cv::absdiff(live, prior, sum);
  cv::compare(sum, tol, agree, cv::CMP_LE);
  cv::compare(live, 0, tmp, cv::CMP_NE);
  agree &= tmp;
  cv::compare(prior, 0, tmp, cv::CMP_NE);
  agree &= tmp;
  // Holes: prior unless near a learner, not the room's colour, or not measured.
  cv::compare(live, 0, take, cv::CMP_EQ);
  take &= tmp;
  if (p.learner_guard_px > 0) {
    // Live depth clearly in front of the prior is a learner (or a new object).
    cv::add(live, tol, sum);  // saturates
    cv::Mat& front = tmp;
    cv::compare(sum, prior, front, cv::CMP_LT);
    cv::Mat nonzero;
    cv::compare(live, 0, nonzero, cv::CMP_NE);
    front &= nonzero;
    // Flying pixels along the room's own depth edges are also "in front" but
    // only a pixel or two wide: an opening (5x5) drops them and keeps bodies;
    // its dilation and the guard's compose into one dilation 5 + 2 guard wide.
    cv::erode(front, nonzero, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
    const int k = 5 + 2 * p.learner_guard_px;
    cv::dilate(nonzero, guard, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
    cv::bitwise_not(guard, guard);
    take &= guard;
  }
  if (p.measured_only && !sp.measured.empty()) take &= sp.measured;
  if (color_test) {
    const int ctol = p.color_tolerance;
    for (int y = 0; y < live.rows; ++y) {
      uint8_t* t = take.ptr<uint8_t>(y);
      const uint8_t* c = color.ptr<uint8_t>(y);
      const uint8_t* pc = prior_color.ptr<uint8_t>(y);
      for (int x = 0; x < live.cols; ++x)
        if (t[x] && (std::abs(c[3 * x] - pc[3 * x]) > ctol || std::abs(c[3 * x + 1] - pc[3 * x + 1]) > ctol ||
                     std::abs(c[3 * x + 2] - pc[3 * x + 2]) > ctol))
          t[x] = 0;
    }
  }
  take |= agree;
  if (!label.empty()) {
    cv::compare(label, 0, tmp, cv::CMP_EQ);
    take &= tmp;
  }
  live.copyTo(out);
  prior.copyTo(out, take);
}

void guided_completion(const cv::Mat& depth, const cv::Mat& color, const GuidedCompletionParams& p, cv::Mat& out,
                       cv::Mat* filled, cv::Mat* ambiguous) {
  CV_Assert(depth.type() == CV_16UC1);
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == depth.size()));
  // Per-frame work is proportional to the holes, not the image: the
  // morphological steps are evaluated at hole pixels only.
  const std::vector<cv::Point> all_holes = hole_list(depth);
  if (out.data != depth.data) depth.copyTo(out);
  if (ambiguous) {
    ambiguous->create(depth.size(), CV_8UC1);
    ambiguous->setTo(0);
  }
  std::vector<cv::Point> holes = all_holes;
  if (p.morphology && !holes.empty()) {
    static const std::vector<cv::Point> k_diamond = kernel_offsets(2, true), k5 = kernel_offsets(2, false),
                                        k7 = kernel_offsets(3, false);
    grow_agreeing(out, holes, k_diamond, 2, p);  // dilation with the diamond
    grow_agreeing(out, holes, k5, 2, p);         // closing of small holes
    grow_agreeing(out, holes, k7, 3, p);         // hole fill
  }
  if (p.hole_fill && !holes.empty()) {
    thread_local cv::Mat stage;
    out.copyTo(stage);
    run_end_fill(stage, holes, color, p, out, ambiguous);
  }
  if (p.median && !all_holes.empty()) {
    // 5x5 median of the filled image at each filled pixel (0s of unfilled holes excluded).
    std::vector<std::pair<cv::Point, uint16_t>> med;
    med.reserve(all_holes.size());
    uint16_t vals[25];
    const int r2 = p.median_size >= 5 ? 2 : 1;
    for (const cv::Point& h : all_holes) {
      if (!out.at<uint16_t>(h)) continue;
      int n = 0;
      for (int y = std::max(0, h.y - r2); y <= std::min(out.rows - 1, h.y + r2); ++y) {
        const uint16_t* r = out.ptr<uint16_t>(y);
        for (int x = std::max(0, h.x - r2); x <= std::min(out.cols - 1, h.x + r2); ++x)
          if (r[x]) vals[n++] = r[x];
      }
      std::nth_element(vals, vals + n / 2, vals + n);
      med.emplace_back(h, vals[n / 2]);
    }
    for (const auto& [pt, v] : med) out.at<uint16_t>(pt) = v;
  }
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

void colorization_fill(cv::Mat& depth, const cv::Mat& color, const cv::Mat& unknown, const ColorizationParams& p) {
  CV_Assert(depth.type() == CV_16UC1 && unknown.type() == CV_8UC1 && unknown.size() == depth.size());
  CV_Assert(color.empty() || (color.type() == CV_8UC3 && color.size() == depth.size()));
  const int w = depth.cols, h = depth.rows;
  std::vector<cv::Point> pts;
  cv::findNonZero(unknown, pts);
  bool zero_unknown = false;
  for (const cv::Point& q : pts) zero_unknown |= depth.at<uint16_t>(q) == 0;
  if (pts.empty()) return;
  if (zero_unknown) {
    cv::Mat filled;
    nearest_fill(depth, filled);
    filled.copyTo(depth, unknown);
  }
  // Working values in a float image: known pixels are read, unknown ones relaxed.
  thread_local cv::Mat z;
  depth.convertTo(z, CV_32F);
  float* zp = z.ptr<float>();
  const size_t n = pts.size();
  const int off[8] = {-w - 1, -w, -w + 1, -1, 1, w - 1, w, w + 1};
  const int dxs[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
  const int dys[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
  thread_local std::vector<float> weights;
  weights.assign(n * 8, 0.0f);
  const double inv_c2 = 1.0 / (p.color_sigma * p.color_sigma);
  // exp(-d2 / sigma^2) for squared colour distances d2 in steps of 8 (0 beyond 6 sigma).
  const int lut_size = static_cast<int>(36.0 * p.color_sigma * p.color_sigma / 8.0) + 2;
  std::vector<float> color_lut(lut_size);
  for (int i = 0; i < lut_size; ++i) color_lut[i] = static_cast<float>(std::exp(-8.0 * i * inv_c2));
  std::vector<int> idx(n);
  for (size_t i = 0; i < n; ++i) {
    const int x = pts[i].x, y = pts[i].y;
    idx[i] = y * w + x;
    const float zr = zp[idx[i]];
    const double sd = std::max(1.0, p.depth_sigma_ratio * zr);
    const uint8_t* c0 = color.empty() ? nullptr : color.ptr<uint8_t>(y) + 3 * x;
    for (int k = 0; k < 8; ++k) {
      const int nx = x + dxs[k], ny = y + dys[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      const float zs = zp[idx[i] + off[k]];
      if (zs <= 0) continue;
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
      weights[i * 8 + k] = (dxs[k] && dys[k]) ? cw * 0.70710678f : cw;
    }
  }
  const float omega = static_cast<float>(p.relaxation);
  for (int it = 0; it < p.iterations; ++it)
    for (size_t i = 0; i < n; ++i) {
      const float* wk = &weights[i * 8];
      float* zr = zp + idx[i];
      float sw = 0, sv = 0;
      for (int k = 0; k < 8; ++k)  // weight 0: outside the image or no depth, not to be read
        if (wk[k] > 0) sw += wk[k], sv += wk[k] * zr[off[k]];
      if (sw > 1e-12f) *zr += omega * (sv / sw - *zr);
    }
  for (size_t i = 0; i < n; ++i) {
    const float v = zp[idx[i]];
    if (std::isfinite(v) && v >= 1.0f) depth.at<uint16_t>(pts[i]) = cv::saturate_cast<uint16_t>(v);
  }
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
  if (o.use_prior && !prior.empty())
    prior_fill(live, color, prior, label, o.prior, out);
  else
    live.copyTo(out);
  if (!o.image_guided && !o.colorization) return;
  cv::Mat unknown;
  if (o.image_guided) {
    // Kept across frames: a fresh 1 MB image each frame costs more than the stage's own work on small holes.
    thread_local cv::Mat guided;
    if (o.colorization) cv::compare(out, 0, unknown, cv::CMP_EQ);
    guided_completion(out, color, o.guided, guided, nullptr, nullptr);
    // What the image-guided stage could not fill is left to colorization too.
    if (o.colorization) unknown |= guided == 0;
    guided.copyTo(out);
  } else if (o.colorization) {
    cv::compare(out, 0, unknown, cv::CMP_EQ);
  }
  if (o.colorization) colorization_fill(out, color, unknown, o.colorize);
}

}  // namespace vclassroom
