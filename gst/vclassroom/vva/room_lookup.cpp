// The reference form of the backward room lookup (room_lookup.h): clear before fast, per pixel in float.
#include <gst/vclassroom/vva/room_lookup.h>

#include <algorithm>
#include <cmath>

namespace vclassroom {

namespace {

// One camera's look at one view pixel.
struct Look {
  float su = 0, sv = 0;  // source position (px)
  float quality = 0;     // the warp's per-point quality before the magnification term (0: not seen)
  bool strict = false;   // every neighbour of the 2x2 agrees (the warp's cell coverage)
  float rgb[3] = {0, 0, 0};
};

struct CameraGeometry {
  Eigen::Matrix3f r;  // view -> camera
  Eigen::Vector3f t;
  Eigen::Vector3f centre;  // the camera's centre in view coordinates
};

CameraGeometry geometry_of(const CameraCalib& cam, const CameraCalib& virt) {
  const Eigen::Isometry3d T = cam.cam_to_rig.inverse() * virt.cam_to_rig;
  return {T.linear().cast<float>(), T.translation().cast<float>(), T.inverse().translation().cast<float>()};
}

bool agrees(float z_mm, int d_mm, const RoomLookupParams& p) {
  if (d_mm == 0) return false;
  const float nearer = std::min(z_mm, float(d_mm));
  const float tol = std::max(float(p.depth_tol_mm), float(p.depth_tol_ratio) * nearer);
  return std::fabs(z_mm - float(d_mm)) <= tol;
}

// The colour at (u, v) from the neighbours whose depth agrees with z_mm; false when none does.
bool sample(const RoomLookupSource& s, float u, float v, float z_mm, const RoomLookupParams& p, Look* look,
            bool* remembered) {
  const int W = s.color.cols, H = s.color.rows;
  u = std::clamp(u, 0.0f, float(W - 1));
  v = std::clamp(v, 0.0f, float(H - 1));
  if (p.sampling == RoomSampling::Nearest) {
    const int x = int(u + 0.5f), y = int(v + 0.5f);
    if (!agrees(z_mm, s.depth.at<uint16_t>(y, x), p)) return false;
    const cv::Vec3b c = s.color.at<cv::Vec3b>(y, x);
    for (int k = 0; k < 3; ++k) look->rgb[k] = c[k];
    *remembered = !s.remembered.empty() && s.remembered.at<uint8_t>(y, x);
    return true;
  }
  const int x0 = std::min(int(u), W - 1), y0 = std::min(int(v), H - 1);
  const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
  const float fx = u - float(x0), fy = v - float(y0);
  const int xs[4] = {x0, x1, x0, x1}, ys[4] = {y0, y0, y1, y1};
  const float ws[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  float sum = 0, acc[3] = {0, 0, 0}, mem = 0;
  constexpr float kEdge = 0.02f;  // view_warp.cpp: how far a cell reaches past its centre towards a depth edge
  const float reach[4] = {std::min(1 - fx, 1 - fy), std::min(fx, 1 - fy), std::min(1 - fx, fy), std::min(fx, fy)};
  look->strict = true;
  for (int k = 0; k < 4; ++k) {
    const bool ok = agrees(z_mm, s.depth.at<uint16_t>(ys[k], xs[k]), p);
    if (!ok && reach[k] > kEdge) look->strict = false;
    if (ws[k] <= 0 || !ok) continue;
    const cv::Vec3b c = s.color.at<cv::Vec3b>(ys[k], xs[k]);
    for (int ch = 0; ch < 3; ++ch) acc[ch] += ws[k] * float(c[ch]);
    sum += ws[k];
    if (!s.remembered.empty() && s.remembered.at<uint8_t>(ys[k], xs[k])) mem += ws[k];
  }
  if (sum <= 1e-6f) return false;
  if (p.sampling == RoomSampling::BilinearAll) {
    sum = 1.0f, acc[0] = acc[1] = acc[2] = 0;
    for (int k = 0; k < 4; ++k) {
      const cv::Vec3b c = s.color.at<cv::Vec3b>(ys[k], xs[k]);
      for (int ch = 0; ch < 3; ++ch) acc[ch] += ws[k] * float(c[ch]);
    }
  }
  for (int ch = 0; ch < 3; ++ch) look->rgb[ch] = acc[ch] / sum;
  *remembered = mem > 0.5f * sum;
  return true;
}

// The camera's room depth (mm) at (u, v) from the neighbours that agree with z_mm, bilinear; 0 when none does.
float surface_depth(const RoomLookupSource& s, float u, float v, float z_mm, const RoomLookupParams& p) {
  const int W = s.depth.cols, H = s.depth.rows;
  u = std::clamp(u, 0.0f, float(W - 1));
  v = std::clamp(v, 0.0f, float(H - 1));
  const int x0 = std::min(int(u), W - 1), y0 = std::min(int(v), H - 1);
  const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
  const float fx = u - float(x0), fy = v - float(y0);
  const int xs[4] = {x0, x1, x0, x1}, ys[4] = {y0, y0, y1, y1};
  const float ws[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  float sum = 0, acc = 0;
  for (int k = 0; k < 4; ++k) {
    const int d = s.depth.at<uint16_t>(ys[k], xs[k]);
    if (ws[k] <= 0 || !agrees(z_mm, d, p)) continue;
    acc += ws[k] * float(d);
    sum += ws[k];
  }
  return sum > 1e-6f ? acc / sum : 0.0f;
}

// Camera `s` looking at every candidate pixel of the view: where it lands, whether it sees the point, and
// its quality there.
void look_from(const RoomLookupSource& s, const CameraCalib& virt, const cv::Mat& view_depth, const cv::Mat& mask,
               const RoomLookupParams& p, std::vector<Look>* looks) {
  const CameraGeometry g = geometry_of(s.camera, virt);
  const int VW = view_depth.cols, VH = view_depth.rows;
  const float ifx = float(1 / virt.fx), ify = float(1 / virt.fy), vcx = float(virt.cx), vcy = float(virt.cy);
  const bool distorted = s.camera.has_distortion();
  looks->assign(size_t(VW) * VH, Look());
  for (int y = 0; y < VH; ++y)
    for (int x = 0; x < VW; ++x) {
      const int z_mm = view_depth.at<uint16_t>(y, x);
      if (!mask.at<uint8_t>(y, x) || z_mm == 0) continue;
      const Eigen::Vector3f ray((float(x) - vcx) * ifx, (float(y) - vcy) * ify, 1.0f);
      Eigen::Vector3f P = ray * (float(z_mm) * 0.001f), q;
      float u = 0, v = 0;
      bool inside = false;
      for (int step = 0; step <= p.refine_steps; ++step) {
        if (step > 0) {  // onto the camera's own surface: q.z = its depth, along the view ray
          const float d = surface_depth(s, u, v, q.z() * 1000.0f, p), a = g.r.row(2).dot(ray);
          if (d == 0 || std::fabs(a) < 1e-3f) break;
          const float z = (d * 0.001f - g.t.z()) / a;
          if (!agrees(z * 1000.0f, z_mm, p)) break;  // not the view's surface any more
          P = ray * z;
        }
        q = g.r * P + g.t;
        if (q.z() < 0.05f) break;
        if (distorted) {
          const auto uv = s.camera.project(q.cast<double>());
          if (!uv) break;
          u = float(uv->x()), v = float(uv->y());
        } else {
          u = float(s.camera.fx) * q.x() / q.z() + float(s.camera.cx);
          v = float(s.camera.fy) * q.y() / q.z() + float(s.camera.cy);
        }
        inside = u >= -0.5f && v >= -0.5f && u <= float(s.camera.width) - 0.5f && v <= float(s.camera.height) - 0.5f;
        if (!inside) break;
      }
      if (!inside) continue;
      Look& look = (*looks)[size_t(y) * VW + x];
      bool remembered = false;
      if (!sample(s, u, v, q.z() * 1000.0f, p, &look, &remembered)) continue;
      look.su = u, look.sv = v;
      const Eigen::Vector3f d = P - g.centre;
      const float c = P.dot(d) / (P.norm() * d.norm()), c2 = c * c, c4 = c2 * c2, c8 = c4 * c4;
      const float nearer = p.weights == RoomWeights::Angle ? 1.0f : std::min(1.0f, P.norm() / d.norm());
      look.quality = std::max(0.02f, c8) * nearer * (remembered ? p.remembered_weight : 1.0f);
      if (p.weights == RoomWeights::Equal) look.quality = 1.0f;
    }
}

// How many view pixels one source pixel covers at (x, y), from the source positions of its neighbours in the
// view (seen by the same camera); 1 where none is.
float magnification(const std::vector<Look>& looks, int VW, int VH, int x, int y) {
  const Look& o = looks[size_t(y) * VW + x];
  const int xn = x + 1 < VW && looks[size_t(y) * VW + x + 1].quality > 0 ? x + 1
                 : x > 0 && looks[size_t(y) * VW + x - 1].quality > 0 ? x - 1 : -1;
  const int yn = y + 1 < VH && looks[size_t(y + 1) * VW + x].quality > 0 ? y + 1
                 : y > 0 && looks[size_t(y - 1) * VW + x].quality > 0 ? y - 1 : -1;
  if (xn < 0 || yn < 0) return 1.0f;
  const Look &a = looks[size_t(y) * VW + xn], &b = looks[size_t(yn) * VW + x];
  const float sx = float(xn - x), sy = float(yn - y);
  const float dudx = (a.su - o.su) * sx, dvdx = (a.sv - o.sv) * sx, dudy = (b.su - o.su) * sy,
              dvdy = (b.sv - o.sv) * sy;
  const float det = std::fabs(dudx * dvdy - dudy * dvdx);  // source px^2 per view px^2
  return det > 1e-6f ? 1.0f / det : 1e6f;
}

}  // namespace

RoomLookupStats room_lookup(const std::vector<RoomLookupSource>& sources, const CameraCalib& virt,
                            const cv::Mat& view_depth, const cv::Mat& mask, const RoomLookupParams& p,
                            cv::Mat* color, cv::Mat* replaced) {
  CV_Assert(view_depth.type() == CV_16UC1 && mask.type() == CV_8UC1 && color->type() == CV_8UC3);
  CV_Assert(mask.size() == view_depth.size() && color->size() == view_depth.size());
  const int VW = view_depth.cols, VH = view_depth.rows;
  std::vector<std::vector<Look>> looks(sources.size());
  for (size_t i = 0; i < sources.size(); ++i) look_from(sources[i], virt, view_depth, mask, p, &looks[i]);
  if (replaced) replaced->create(view_depth.size(), CV_8UC1), replaced->setTo(0);
  RoomLookupStats st;
  for (int y = 0; y < VH; ++y)
    for (int x = 0; x < VW; ++x) {
      if (!mask.at<uint8_t>(y, x) || !view_depth.at<uint16_t>(y, x)) continue;
      ++st.candidates;
      float sum = 0, acc[3] = {0, 0, 0};
      int seen = 0;
      bool any_strict = false;
      if (p.sampling == RoomSampling::BilinearStrict)
        for (size_t i = 0; i < sources.size(); ++i)
          any_strict |= looks[i][size_t(y) * VW + x].quality > 0 && looks[i][size_t(y) * VW + x].strict;
      for (size_t i = 0; i < sources.size(); ++i) {
        const Look& l = looks[i][size_t(y) * VW + x];
        if (l.quality <= 0 || (any_strict && !l.strict)) continue;
        float q = l.quality;
        if (p.weights == RoomWeights::Fuse) q /= std::sqrt(std::max(magnification(looks[i], VW, VH, x, y), 1.0f));
        const float byte = std::clamp(std::floor(q * 255.0f + 0.5f), 1.0f, 255.0f);  // the warp's weight byte
        const float w = float(std::pow(byte / 255.0, p.weight_power)) + 1e-6f;
        for (int ch = 0; ch < 3; ++ch) acc[ch] += w * l.rgb[ch];
        sum += w;
        ++seen;
      }
      if (seen == 0) continue;
      ++st.replaced;
      st.by_one += seen == 1;
      cv::Vec3b& out = color->at<cv::Vec3b>(y, x);
      for (int ch = 0; ch < 3; ++ch) out[ch] = cv::saturate_cast<uint8_t>(acc[ch] / sum);
      if (replaced) replaced->at<uint8_t>(y, x) = uint8_t(seen);
    }
  return st;
}

}  // namespace vclassroom
