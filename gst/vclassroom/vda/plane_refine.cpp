#include <gst/vclassroom/vda/plane_refine.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <gst/vclassroom/vda/depth_tolerance.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace detail {

// One row of plane_refine, branch-free so that it vectorises: the tolerance
// max(min_mm, ratio * plane depth) with the ratio in 1/65536 steps.
VCLASSROOM_SIMD_CLONES
void plane_snap_row(const uint16_t* in, const uint16_t* plane_depth, const uint8_t* index, const uint8_t* label,
                    int n, uint32_t tol_min, uint32_t rq16, uint16_t* out) {
  for (int x = 0; x < n; ++x) {
    const uint32_t d = in[x], pd = plane_depth[x];
    const uint32_t t = depth_tolerance(pd, tol_min, rq16);
    const uint32_t diff = d > pd ? d - pd : pd - d;
    const bool snap = (d != 0) & (index[x] != PlaneMaps::kNoPlane) & (diff <= t) & (label[x] == 0);
    out[x] = snap ? static_cast<uint16_t>(pd) : static_cast<uint16_t>(d);
  }
}

}  // namespace detail

Eigen::Vector4d plane_in_camera(const RoomPlane& plane, const CameraCalib& cam) {
  // p_rig = R p_cam + t, so n . (R p_cam + t) + d = (R^T n) . p_cam + (n . t + d).
  const Eigen::Matrix3d r = cam.cam_to_rig.linear();
  const Eigen::Vector3d n = r.transpose() * plane.normal;
  return Eigen::Vector4d(n.x(), n.y(), n.z(), plane.normal.dot(cam.cam_to_rig.translation()) + plane.offset);
}

double plane_depth_mm(const Eigen::Vector4d& pc, const CameraCalib& cam, double u, double v) {
  const Eigen::Vector2d xn = cam.normalized(u, v);
  const double denom = pc.x() * xn.x() + pc.y() * xn.y() + pc.z();
  if (std::abs(denom) < 1e-9) return 0;
  const double z = -pc.w() / denom;
  return z > 0 ? z * 1000.0 : 0;
}

PlaneMaps plane_maps_for_camera(const std::vector<RoomPlane>& planes, const CameraCalib& cam, const cv::Mat& prior,
                                const PlaneTolerance& tol) {
  if (prior.type() != CV_16UC1 || prior.cols != cam.width || prior.rows != cam.height)
    throw Error("plane maps of camera " + std::to_string(cam.id) + ": prior depth is " +
                std::to_string(prior.cols) + "x" + std::to_string(prior.rows) + ", the camera is " +
                std::to_string(cam.width) + "x" + std::to_string(cam.height));
  if (planes.size() >= PlaneMaps::kNoPlane) throw Error("plane maps: too many planes (at most 254)");
  PlaneMaps m;
  m.index.create(prior.size(), CV_8UC1);
  m.index.setTo(PlaneMaps::kNoPlane);
  m.depth.create(prior.size(), CV_16UC1);
  m.depth.setTo(0);
  std::vector<Eigen::Vector4d> pc;
  for (const RoomPlane& p : planes) pc.push_back(plane_in_camera(p, cam));
  for (int v = 0; v < prior.rows; ++v)
    for (int u = 0; u < prior.cols; ++u) {
      const int q = prior.at<uint16_t>(v, u);
      if (!q) continue;
      const Eigen::Vector2d xn = cam.normalized(u, v);
      double best = 0;
      int best_i = -1;
      for (size_t i = 0; i < pc.size(); ++i) {
        const double denom = pc[i].x() * xn.x() + pc[i].y() * xn.y() + pc[i].z();
        if (std::abs(denom) < 1e-9) continue;
        const double z = -pc[i].w() / denom * 1000.0;
        if (z <= 0 || z > 65535 || std::abs(z - q) > tol.at(q)) continue;
        if (best_i < 0 || z < best) best = z, best_i = static_cast<int>(i);
      }
      if (best_i >= 0) {
        m.index.at<uint8_t>(v, u) = static_cast<uint8_t>(best_i);
        m.depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(best));
      }
    }
  return m;
}

void plane_refine(const cv::Mat& depth, const PlaneMaps& maps, const cv::Mat& label, const PlaneTolerance& tol,
                  cv::Mat& out) {
  CV_Assert(depth.type() == CV_16UC1 && maps.depth.size() == depth.size() && maps.index.size() == depth.size());
  CV_Assert(label.empty() || (label.type() == CV_8UC1 && label.size() == depth.size()));
  out.create(depth.size(), CV_16UC1);  // no reallocation when `out` is `depth`
  const uint32_t tol_min = static_cast<uint32_t>(std::max(0, tol.min_mm));
  const uint32_t rq16 = detail::ratio_q16(tol.ratio);
  thread_local std::vector<uint8_t> zeros;
  zeros.assign(depth.cols, 0);
  for (int y = 0; y < depth.rows; ++y)
    detail::plane_snap_row(depth.ptr<uint16_t>(y), maps.depth.ptr<uint16_t>(y), maps.index.ptr<uint8_t>(y),
                           label.empty() ? zeros.data() : label.ptr<uint8_t>(y), depth.cols, tol_min, rq16,
                           out.ptr<uint16_t>(y));
}

}  // namespace vclassroom
