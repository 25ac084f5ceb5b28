#include "view_warp.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNear = 0.05f;  // metres: nearer points are behind the virtual lens

// floor/ceil without a libm call (x86-64 baseline has no SSE4.1 round).
inline int fast_floor(float x) {
  const int i = int(x);
  return i > x ? i - 1 : i;
}
inline int fast_ceil(float x) {
  const int i = int(x);
  return i < x ? i + 1 : i;
}

bool same_intrinsics(const CameraCalib& a, const CameraCalib& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.distortion == b.distortion;
}

// Median of the live depth of each learner label, for learner pixels without depth.
void learner_median_depths(const cv::Mat& depth, const cv::Mat& label, uint16_t med[256]) {
  std::vector<std::vector<uint16_t>> samples(256);
  for (int y = 0; y < depth.rows; y += 2) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const uint8_t* l = label.ptr<uint8_t>(y);
    for (int x = 0; x < depth.cols; x += 2)
      if (l[x] && d[x]) samples[l[x]].push_back(d[x]);
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

void ViewWarper::prepare_rays(const CameraCalib& src) {
  if (have_rays_ && same_intrinsics(rays_for_, src)) return;
  const size_t n = size_t(src.width) * src.height;
  ray_x_.resize(n);
  ray_y_.resize(n);
  for (int v = 0; v < src.height; ++v)
    for (int u = 0; u < src.width; ++u) {
      const Eigen::Vector2d r = src.has_distortion() ? src.normalized(u, v)
                                                     : Eigen::Vector2d((u - src.cx) / src.fx, (v - src.cy) / src.fy);
      ray_x_[size_t(v) * src.width + u] = float(r.x());
      ray_y_[size_t(v) * src.width + u] = float(r.y());
    }
  rays_for_ = src;
  have_rays_ = true;
}

void ViewWarper::warp(const CameraCalib& src, const WarpSource& in, const CameraCalib& virt, const WarpParams& prm,
                      WarpedView* out) {
  CV_Assert(in.color.type() == CV_8UC3 && in.depth.type() == CV_16UC1);
  CV_Assert(in.color.cols == src.width && in.color.rows == src.height && in.depth.size() == in.color.size());
  const int W = src.width, H = src.height;
  const int VW = virt.width, VH = virt.height;
  const size_t n = size_t(W) * H, vn = size_t(VW) * VH;
  prepare_rays(src);
  px_.resize(n);
  py_.resize(n);
  pz_.resize(n);
  pw_.resize(n);
  src_depth_.resize(n);
  src_label_.resize(n);
  zbuf_.assign(vn, kInf);
  su_.resize(vn);
  sv_.resize(vn);
  wbuf_.resize(vn);
  lbuf_.resize(vn);

  // The layered depth of every source pixel: learners live, the room static.
  const bool has_label = !in.label.empty();
  const bool has_static = !in.static_depth.empty();
  uint16_t med[256] = {0};
  if (has_label && prm.fill_learner_depth) learner_median_depths(in.depth, in.label, med);
  for (int v = 0; v < H; ++v) {
    const uint16_t* d = in.depth.ptr<uint16_t>(v);
    const uint16_t* s = has_static ? in.static_depth.ptr<uint16_t>(v) : nullptr;
    const uint8_t* l = has_label ? in.label.ptr<uint8_t>(v) : nullptr;
    uint16_t* od = &src_depth_[size_t(v) * W];
    uint8_t* ol = &src_label_[size_t(v) * W];
    for (int u = 0; u < W; ++u) {
      const uint8_t lab = l ? l[u] : 0;
      uint16_t z = d[u];
      if (lab) {
        if (!z) z = med[lab];
      } else if (s && s[u]) {
        z = s[u];
      }
      od[u] = z;
      ol[u] = lab;
    }
  }
  if (prm.boundary_px > 0) {
    // Drop the far-side pixels next to a depth edge: their colour mixes both
    // surfaces and would draw a ghost contour where the background is revealed.
    // A step is an edge when it is large and much larger than the steps beside
    // it (a slanted surface has steps too, but even ones).
    std::vector<uint8_t> drop(n, 0);
    const int b = prm.boundary_px;
    auto is_edge = [&](int p0, int p1, int p2, int p3) {  // depths along a line; step p1 -> p2
      if (!p1 || !p2) return false;
      const int step = std::abs(p2 - p1);
      if (step <= std::max(prm.edge_min_mm, prm.edge_ratio * std::min(p1, p2))) return false;
      const int side = std::max(p0 ? std::abs(p1 - p0) : 0, p3 ? std::abs(p3 - p2) : 0);
      return step > 3 * side;
    };
    const uint16_t* D = src_depth_.data();
    for (int v = 0; v < H; ++v)
      for (int u = 1; u + 2 < W; ++u) {
        const size_t i = size_t(v) * W + u;
        if (!is_edge(D[i - 1], D[i], D[i + 1], D[i + 2])) continue;
        const int dir = D[i] > D[i + 1] ? -1 : 1;  // towards the far side
        const int start = dir < 0 ? u : u + 1;
        for (int k = 0; k < b; ++k) {
          const int x = start + dir * k;
          if (x >= 0 && x < W) drop[size_t(v) * W + x] = 1;
        }
      }
    for (int v = 1; v + 2 < H; ++v)
      for (int u = 0; u < W; ++u) {
        const size_t i = size_t(v) * W + u;
        if (!is_edge(D[i - W], D[i], D[i + W], D[i + 2 * W])) continue;
        const int dir = D[i] > D[i + W] ? -1 : 1;
        const int start = dir < 0 ? v : v + 1;
        for (int k = 0; k < b; ++k) {
          const int y = start + dir * k;
          if (y >= 0 && y < H) drop[size_t(y) * W + u] = 1;
        }
      }
    for (size_t i = 0; i < n; ++i)
      if (drop[i]) src_depth_[i] = 0;
  }

  // Source -> virtual camera.
  const Eigen::Isometry3d T = virt.cam_to_rig.inverse() * src.cam_to_rig;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float fx = float(virt.fx), fy = float(virt.fy), cx = float(virt.cx), cy = float(virt.cy);
  const float tn = t.norm();
  for (size_t i = 0; i < n; ++i) {
    const uint16_t zmm = src_depth_[i];
    if (!zmm) {
      pz_[i] = 0;
      continue;
    }
    const float z = zmm * 0.001f;
    const float X = ray_x_[i] * z, Y = ray_y_[i] * z;
    const float qx = R(0, 0) * X + R(0, 1) * Y + R(0, 2) * z + t.x();
    const float qy = R(1, 0) * X + R(1, 1) * Y + R(1, 2) * z + t.y();
    const float qz = R(2, 0) * X + R(2, 1) * Y + R(2, 2) * z + t.z();
    if (qz < kNear) {
      pz_[i] = 0;
      continue;
    }
    const float iz = 1.0f / qz;
    px_[i] = fx * qx * iz + cx;
    py_[i] = fy * qy * iz + cy;
    pz_[i] = qz;
    // Quality of this camera for the point: the angle between its ray and the
    // virtual ray, and how much farther it is than the virtual camera.
    float w = 1.0f;
    // The weight varies slowly across the image: compute it every 4th pixel.
    if (tn > 1e-6f && (i & 3) && i > 0 && pz_[i - 1] > 0) {
      w = pw_[i - 1];
    } else if (tn > 1e-6f) {
      const float dvx = qx - t.x(), dvy = qy - t.y(), dvz = qz - t.z();  // from the source centre
      const float nq = std::sqrt(qx * qx + qy * qy + qz * qz);
      const float nd = std::sqrt(dvx * dvx + dvy * dvy + dvz * dvz);
      const float c = (qx * dvx + qy * dvy + qz * dvz) / (nq * nd);
      const float c2 = c * c, c4 = c2 * c2;
      w = std::max(0.02f, c4 * c4);  // cos^8: 10° -> 0.89, 30° -> 0.32
      if (nd > nq) w *= nq / nd;
    }
    pw_[i] = w;
  }

  // Rasterise the mesh.
  const double er = prm.edge_ratio, emin = prm.edge_min_mm * 0.001;
  const float max_area2 = float(prm.max_stretch);
  const float scale_xy = float(0.5 * (virt.fx / src.fx + virt.fy / src.fy));
  const float gap = float(prm.max_gap_px);  // |2*area| of a 0.5 px² triangle is 1
  auto consistent = [&](size_t a, size_t b, size_t c) {
    const float za = pz_[a], zb = pz_[b], zc = pz_[c];
    if (za <= 0 || zb <= 0 || zc <= 0) return false;
    if (src_label_[a] != src_label_[b] || src_label_[a] != src_label_[c]) return false;
    const float lo = std::min(za, std::min(zb, zc)), hi = std::max(za, std::max(zb, zc));
    if (hi - lo <= std::max(emin, er * lo)) return true;
    // Different depths but not torn apart by this view (a slanted surface):
    // no edge longer than its source length at the local scale + max_gap_px.
    const float scale = scale_xy * src_depth_[a] * 0.001f / za;
    auto edge_ok = [&](size_t i, size_t j) {
      const float su = float(int(i % W) - int(j % W)), sv = float(int(i / W) - int(j / W));
      const float lim = scale * std::sqrt(su * su + sv * sv) + gap;
      const float dx = px_[i] - px_[j], dy = py_[i] - py_[j];
      return dx * dx + dy * dy <= lim * lim;
    };
    return edge_ok(a, b) && edge_ok(b, c) && edge_ok(a, c);
  };
  auto raster = [&](size_t a, size_t b, size_t c, float ua, float va, float ub, float vb, float uc, float vc) {
    const float x0 = px_[a], y0 = py_[a], x1 = px_[b], y1 = py_[b], x2 = px_[c], y2 = py_[c];
    const float area2 = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    const float aa = std::fabs(area2);
    if (aa < 1e-12f || aa > max_area2) return;
    const int xmin = std::max(0, int(std::ceil(std::min(x0, std::min(x1, x2)))));
    const int xmax = std::min(VW - 1, int(std::floor(std::max(x0, std::max(x1, x2)))));
    const int ymin = std::max(0, int(std::ceil(std::min(y0, std::min(y1, y2)))));
    const int ymax = std::min(VH - 1, int(std::floor(std::max(y0, std::max(y1, y2)))));
    if (xmin > xmax || ymin > ymax) return;
    const float inv = 1.0f / area2;
    const float stretch = aa > 1.0f ? 1.0f / std::sqrt(aa) : 1.0f;
    const float wq = (pw_[a] + pw_[b] + pw_[c]) * (1.0f / 3.0f) * stretch;
    const uint8_t lab = src_label_[a];
    constexpr float eps = -0.02f;
    for (int y = ymin; y <= ymax; ++y) {
      const float fyv = float(y);
      for (int x = xmin; x <= xmax; ++x) {
        const float fxv = float(x);
        const float l1 = ((fxv - x0) * (y2 - y0) - (x2 - x0) * (fyv - y0)) * inv;
        const float l2 = ((x1 - x0) * (fyv - y0) - (fxv - x0) * (y1 - y0)) * inv;
        const float l0 = 1.0f - l1 - l2;
        if (l0 < eps || l1 < eps || l2 < eps) continue;
        const float z = l0 * pz_[a] + l1 * pz_[b] + l2 * pz_[c];
        const size_t o = size_t(y) * VW + x;
        if (z >= zbuf_[o]) continue;
        zbuf_[o] = z;
        su_[o] = l0 * ua + l1 * ub + l2 * uc;
        sv_[o] = l0 * va + l1 * vb + l2 * vc;
        wbuf_[o] = wq;
        lbuf_[o] = lab;
      }
    }
  };
  if (prm.mesh) {
    for (int v = 0; v + 1 < H; ++v) {
      const float fv = float(v), fv1 = fv + 1.0f;
      for (int u = 0; u + 1 < W; ++u) {
        const size_t a = size_t(v) * W + u, b = a + 1, c = a + W, d = c + 1;
        if (pz_[a] <= 0 && pz_[d] <= 0) continue;
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
  } else {
    // Each source pixel's cell [u +- 0.5] x [v +- 0.5] mapped by the local
    // affine map J (from the neighbours on the same surface) covers the
    // virtual pixels whose pre-image lies inside it: the mesh's coverage
    // without its per-triangle set-up. Pixels with no neighbour on their
    // surface (flying pixels, speckle) are not drawn.
    auto same_surface = [&](size_t i, size_t j) {
      const float zi = pz_[i], zj = pz_[j];
      if (zj <= 0 || src_label_[i] != src_label_[j]) return false;
      if (std::fabs(zi - zj) <= std::max(float(emin), float(er) * std::min(zi, zj))) return true;
      const float dx = px_[i] - px_[j], dy = py_[i] - py_[j];
      const float lim = scale_xy * src_depth_[i] * 0.001f / zi + gap;
      return dx * dx + dy * dy <= lim * lim;
    };
    constexpr float kCell = 0.5f + 1e-3f;
    constexpr float kEdge = 0.02f;
    constexpr uint8_t kRight = 1, kDown = 2;
    // Which neighbours (right, below) lie on the same surface: each test once.
    links_.resize(n);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const size_t i = size_t(v) * W + u;
        uint8_t f = 0;
        if (pz_[i] > 0) {
          if (u + 1 < W && same_surface(i, i + 1)) f |= kRight;
          if (v + 1 < H && same_surface(i, i + W)) f |= kDown;
        }
        links_[i] = f;
      }
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const size_t i = size_t(v) * W + u;
        const float zi = pz_[i];
        if (zi <= 0) continue;
        float jxu = 0, jyu = 0, jxv = 0, jyv = 0;
        bool hu = false, hv = false;
        const uint8_t nb = links_[i];
        const bool right = nb & kRight, down = nb & kDown;
        const bool left = u > 0 && (links_[i - 1] & kRight), up = v > 0 && (links_[i - W] & kDown);
        if (right) {
          jxu = px_[i + 1] - px_[i], jyu = py_[i + 1] - py_[i], hu = true;
        } else if (left) {
          jxu = px_[i] - px_[i - 1], jyu = py_[i] - py_[i - 1], hu = true;
        }
        if (down) {
          jxv = px_[i + W] - px_[i], jyv = py_[i + W] - py_[i], hv = true;
        } else if (up) {
          jxv = px_[i] - px_[i - W], jyv = py_[i] - py_[i - W], hv = true;
        }
        // Towards a depth edge the cell ends at the pixel centre, like the mesh:
        // the surface is not known to go on beyond it.
        const float umax = right || u + 1 >= W ? kCell : kEdge, umin = left || u == 0 ? -kCell : -kEdge;
        const float vmax = down || v + 1 >= H ? kCell : kEdge, vmin = up || v == 0 ? -kCell : -kEdge;
        if (!hu && !hv) continue;
        if (!hu) jxu = jyv, jyu = -jxv;  // a one-pixel-wide strip: assume a square cell
        if (!hv) jxv = -jyu, jyv = jxu;
        const float det = jxu * jyv - jxv * jyu;
        const float area = std::fabs(det);
        if (area < 1e-6f || area > max_area2) continue;
        const float idet = 1.0f / det;
        const float x = px_[i], y = py_[i];
        const float hx = kCell * (std::fabs(jxu) + std::fabs(jxv)), hy = kCell * (std::fabs(jyu) + std::fabs(jyv));
        if (x + hx < 0 || y + hy < 0 || x - hx > VW || y - hy > VH) continue;
        const int xmin = std::max(0, fast_ceil(x - hx)), xmax = std::min(VW - 1, fast_floor(x + hx));
        const int ymin = std::max(0, fast_ceil(y - hy)), ymax = std::min(VH - 1, fast_floor(y + hy));
        if (xmin > xmax || ymin > ymax) continue;
        const float wq = pw_[i] * (area > 1.0f ? 1.0f / std::sqrt(area) : 1.0f);
        const uint8_t lab = src_label_[i];
        const float fu = float(u), fv = float(v);
        for (int yi = ymin; yi <= ymax; ++yi) {
          const float dy = float(yi) - y;
          for (int xi = xmin; xi <= xmax; ++xi) {
            const float dx = float(xi) - x;
            const float du = (jyv * dx - jxv * dy) * idet, dv = (jxu * dy - jyu * dx) * idet;
            if (du > umax || du < umin || dv > vmax || dv < vmin) continue;
            const size_t o = size_t(yi) * VW + xi;
            if (zi >= zbuf_[o]) continue;
            zbuf_[o] = zi;
            su_[o] = fu + du;
            sv_[o] = fv + dv;
            wbuf_[o] = wq;
            lbuf_[o] = lab;
          }
        }
      }
    }
  }

  // Backward colour: bilinear at the sub-pixel source position.
  out->color.create(VH, VW, CV_8UC3);
  out->depth.create(VH, VW, CV_16UC1);
  out->label.create(VH, VW, CV_8UC1);
  out->weight.create(VH, VW, CV_8UC1);
  const int sstep = int(in.color.step);
  for (int y = 0; y < VH; ++y) {
    cv::Vec3b* oc = out->color.ptr<cv::Vec3b>(y);
    uint16_t* od = out->depth.ptr<uint16_t>(y);
    uint8_t* ol = out->label.ptr<uint8_t>(y);
    uint8_t* ow = out->weight.ptr<uint8_t>(y);
    for (int x = 0; x < VW; ++x) {
      const size_t o = size_t(y) * VW + x;
      const float z = zbuf_[o];
      if (z == kInf) {
        oc[x] = cv::Vec3b(0, 0, 0);
        od[x] = 0;
        ol[x] = 0;
        ow[x] = 0;
        continue;
      }
      const float su = std::clamp(su_[o], 0.0f, float(W - 1)), sv = std::clamp(sv_[o], 0.0f, float(H - 1));
      const int u0 = std::min(int(su), W - 2 < 0 ? 0 : W - 2), v0 = std::min(int(sv), H - 2 < 0 ? 0 : H - 2);
      const float fu = su - u0, fv = sv - v0;
      const uint8_t* p = in.color.data + size_t(v0) * sstep + 3 * u0;
      const float w00 = (1 - fu) * (1 - fv), w01 = fu * (1 - fv), w10 = (1 - fu) * fv, w11 = fu * fv;
      for (int ch = 0; ch < 3; ++ch) {
        const float c = w00 * p[ch] + w01 * p[3 + ch] + w10 * p[sstep + ch] + w11 * p[sstep + 3 + ch];
        oc[x][ch] = uint8_t(std::min(255.0f, c + 0.5f));
      }
      od[x] = uint16_t(std::min(65535.0f, z * 1000.0f + 0.5f));
      ol[x] = lbuf_[o];
      ow[x] = uint8_t(std::clamp(wbuf_[o] * 255.0f + 0.5f, 1.0f, 255.0f));
    }
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
