#include <gst/vclassroom/vva/virtual_view.h>

#include <algorithm>
#include <cmath>

namespace vclassroom {

CameraCalib virtual_view_base(const CameraCalib& src, int width, int height, double fov_deg) {
  CameraCalib v = (width > 0 && height > 0 && (width != src.width || height != src.height))
                      ? scale_camera(src, width, height)
                      : src;
  v.distortion = {0, 0, 0, 0, 0};
  v.depth_to_color.reset();
  if (fov_deg > 0) v.fx = v.fy = 0.5 * v.width / std::tan(0.5 * fov_deg * M_PI / 180.0);
  v.cam_to_rig = Eigen::Isometry3d::Identity();
  return v;
}

Pose trace_pose_for_frame(const std::vector<PoseSample>& trace, double running_time_s, uint64_t frame) {
  const size_t i = !std::isnan(running_time_s) && !std::isnan(trace.front().t)
                       ? pose_trace_index(trace, running_time_s, frame)
                       : std::min<size_t>(frame, trace.size() - 1);
  Pose pose = trace[i].pose;
  pose.seq = i + 1;
  const double t = trace[i].t;
  pose.viewer_time_ns = std::isnan(t) ? -1 : int64_t(std::llround(t * 1e9));
  return pose;
}

Pose trace_pose_in_turn(const std::vector<PoseSample>& trace, size_t n) {
  const size_t i = std::min(n, trace.size() - 1);
  Pose pose = trace[i].pose;
  pose.seq = i + 1;
  return pose;
}

}  // namespace vclassroom
