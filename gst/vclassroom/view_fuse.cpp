#include "view_fuse.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

void fuse_views(const std::vector<const WarpedView*>& views_in, const FuseParams& prm, FusedView* out) {
  std::vector<const WarpedView*> views;
  for (const WarpedView* v : views_in)
    if (v && !v->color.empty()) views.push_back(v);
  CV_Assert(!views.empty());
  const cv::Size size = views[0]->color.size();
  for (const WarpedView* v : views) CV_Assert(v->color.size() == size && v->depth.size() == size);
  out->color.create(size, CV_8UC3);
  out->depth.create(size, CV_16UC1);
  out->label.create(size, CV_8UC1);
  const size_t k = views.size();
  float wlut[256];
  for (int i = 0; i < 256; ++i) wlut[i] = float(std::pow(i / 255.0, prm.weight_power));
  const float tol_ratio = float(prm.depth_tol_ratio), tol_mm = float(prm.depth_tol_mm);
  struct Row {
    const cv::Vec3b* c;
    const uint16_t* d;
    const uint8_t* l;
    const uint8_t* w;
  };
  std::vector<Row> rows(k);
  for (int y = 0; y < size.height; ++y) {
    for (size_t c = 0; c < k; ++c)
      rows[c] = Row{views[c]->color.ptr<cv::Vec3b>(y), views[c]->depth.ptr<uint16_t>(y),
                    views[c]->label.empty() ? nullptr : views[c]->label.ptr<uint8_t>(y), views[c]->weight.ptr<uint8_t>(y)};
    cv::Vec3b* oc = out->color.ptr<cv::Vec3b>(y);
    uint16_t* od = out->depth.ptr<uint16_t>(y);
    uint8_t* ol = out->label.ptr<uint8_t>(y);
    for (int x = 0; x < size.width; ++x) {
      int zmin = 65536;
      for (size_t c = 0; c < k; ++c) {
        const int z = rows[c].d[x];
        if (z && rows[c].w[x] && z < zmin) zmin = z;
      }
      if (zmin == 65536) {
        oc[x] = cv::Vec3b(0, 0, 0);
        od[x] = 0;
        ol[x] = 0;
        continue;
      }
      const float limit = zmin + std::max(tol_mm, tol_ratio * zmin);
      float acc[3] = {0, 0, 0}, wsum = 0, zsum = 0, wbest = -1;
      uint8_t lab = 0;
      for (size_t c = 0; c < k; ++c) {
        const int z = rows[c].d[x];
        const uint8_t wq = rows[c].w[x];
        if (!z || !wq || z > limit) continue;
        const float w = wlut[wq] + 1e-6f;
        const cv::Vec3b p = rows[c].c[x];
        acc[0] += w * p[0];
        acc[1] += w * p[1];
        acc[2] += w * p[2];
        zsum += w * z;
        wsum += w;
        if (w > wbest) {
          wbest = w;
          lab = rows[c].l ? rows[c].l[x] : 0;
        }
      }
      const float iw = 1.0f / wsum;
      oc[x] = cv::Vec3b(uint8_t(acc[0] * iw + 0.5f), uint8_t(acc[1] * iw + 0.5f), uint8_t(acc[2] * iw + 0.5f));
      od[x] = uint16_t(zsum * iw + 0.5f);
      ol[x] = lab;
    }
  }
  if (prm.fill_holes) {
    cv::Mat depth = out->depth.clone();
    fill_holes_from_background(out->color, depth, prm.background_ratio, prm.fill_smooth_px, &out->filled);
  } else {
    out->filled = cv::Mat::zeros(size, CV_8UC1);
  }
}

void fill_holes_from_background(cv::Mat& color, cv::Mat& depth, double background_ratio, int smooth_px,
                                cv::Mat* filled) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && color.size() == depth.size());
  const int W = color.cols, H = color.rows;
  cv::Mat mask = cv::Mat::zeros(H, W, CV_8UC1);
  if (filled) *filled = mask;  // shares the data
  // The nearest known pixel in each of 4 directions: its depth and distance.
  struct Cand {
    uint16_t z;
    uint16_t dist;
    cv::Vec3b c;
  };
  // Scratch kept per thread: a 960x540 frame needs 16 MB, too much to allocate each frame.
  static thread_local std::vector<Cand> cand;
  cand.resize(size_t(W) * H * 4);
  auto at = [&](int x, int y, int dir) -> Cand& { return cand[(size_t(y) * W + x) * 4 + dir]; };
  bool any_hole = false;
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    Cand last{0, 0, {}};
    for (int x = 0; x < W; ++x) {
      if (d[x]) last = Cand{d[x], 0, c[x]};
      else {
        any_hole = true;
        if (last.z) ++last.dist;
        at(x, y, 0) = last;
      }
    }
    last = Cand{0, 0, {}};
    for (int x = W - 1; x >= 0; --x) {
      if (d[x]) last = Cand{d[x], 0, c[x]};
      else {
        if (last.z) ++last.dist;
        at(x, y, 1) = last;
      }
    }
  }
  if (!any_hole) return;
  // Columns, walked row by row (cache friendly): one running candidate per column.
  static thread_local std::vector<Cand> col;
  col.assign(size_t(W), Cand{0, 0, {}});
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    for (int x = 0; x < W; ++x) {
      if (d[x]) col[x] = Cand{d[x], 0, c[x]};
      else {
        if (col[x].z) ++col[x].dist;
        at(x, y, 2) = col[x];
      }
    }
  }
  col.assign(size_t(W), Cand{0, 0, {}});
  for (int y = H - 1; y >= 0; --y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    for (int x = 0; x < W; ++x) {
      if (d[x]) col[x] = Cand{d[x], 0, c[x]};
      else {
        if (col[x].z) ++col[x].dist;
        at(x, y, 3) = col[x];
      }
    }
  }
  cv::Mat new_depth = depth.clone();
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    uint16_t* nd = new_depth.ptr<uint16_t>(y);
    for (int x = 0; x < W; ++x) {
      if (d[x]) continue;
      int zmax = 0;
      for (int dir = 0; dir < 4; ++dir) zmax = std::max<int>(zmax, at(x, y, dir).z);
      if (!zmax) continue;
      const float zlo = float(zmax) * float(1.0 - background_ratio);
      float acc[3] = {0, 0, 0}, wsum = 0, zsum = 0;
      for (int dir = 0; dir < 4; ++dir) {
        const Cand& k = at(x, y, dir);
        if (!k.z || k.z < zlo) continue;
        const float w = 1.0f / float(k.dist);
        acc[0] += w * k.c[0];
        acc[1] += w * k.c[1];
        acc[2] += w * k.c[2];
        zsum += w * k.z;
        wsum += w;
      }
      const float iw = 1.0f / wsum;
      c[x] = cv::Vec3b(uint8_t(acc[0] * iw + 0.5f), uint8_t(acc[1] * iw + 0.5f), uint8_t(acc[2] * iw + 0.5f));
      nd[x] = uint16_t(zsum * iw + 0.5f);
      mask.ptr<uint8_t>(y)[x] = 255;
    }
  }
  depth = new_depth;
  if (smooth_px > 0) {
    cv::Mat blurred;
    cv::blur(color, blurred, cv::Size(2 * smooth_px + 1, 2 * smooth_px + 1));
    blurred.copyTo(color, mask);
  }
}

}  // namespace vclassroom
