// V-DA planar refinement (PAPER.md "V-DA" step 3, docs/vda.md): the room's
// planes, found once in the rig frame, are carried into each camera through
// its extrinsics; pixels whose depth lies on a plane get the plane's exact
// depth along the pixel ray. GStreamer-free.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/planes.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// The plane in a camera's frame (a X + b Y + c Z + d = 0, metres), as the
// paper carries it through [R|T].
Eigen::Vector4d plane_in_camera(const RoomPlane& plane, const CameraCalib& cam);
// Depth (mm along the optical axis) of a plane along the ray of pixel (u, v);
// 0 when the ray misses it (parallel or behind the camera).
double plane_depth_mm(const Eigen::Vector4d& plane_cam, const CameraCalib& cam, double u, double v);

// Precomputed per camera, so the per-frame step is a compare-and-copy.
struct PlaneMaps {
  cv::Mat index;  // CV_8UC1: plane index, kNoPlane where the pixel shows no plane
  cv::Mat depth;  // CV_16UC1: that plane's depth along the ray, mm
  static constexpr uint8_t kNoPlane = 255;
};

// Tolerance for "this depth lies on the plane": max(min_mm, ratio * depth).
// The default suits live sensor depth (about 3 sigma of a consumer ToF camera
// at 5 m).
struct PlaneTolerance {
  int min_mm = 20;
  double ratio = 0.015;
  int at(int depth_mm) const { return std::max(min_mm, static_cast<int>(ratio * depth_mm)); }
};

// Membership tolerance for priors whose plane pixels were snapped when the
// model was built (build_static_model does): they lie on the plane to rounding.
inline constexpr PlaneTolerance kSnappedPriorTolerance{3, 0.0};

// Assigns each pixel the nearest plane whose depth along its ray agrees with
// the static room's prior depth (CV_16UC1 mm, the camera's size) within `tol`.
// Throws Error when the prior's size is not the camera's.
PlaneMaps plane_maps_for_camera(const std::vector<RoomPlane>& planes, const CameraCalib& cam, const cv::Mat& prior,
                                const PlaneTolerance& tol = kSnappedPriorTolerance);

// out = the plane's depth where `maps` has a plane and `depth` lies within
// tolerance of it; `depth` elsewhere (learners, objects off the plane, holes).
// `label` (may be empty): pixels with label > 0 are never snapped. `out` may be `depth`.
void plane_refine(const cv::Mat& depth, const PlaneMaps& maps, const cv::Mat& label, const PlaneTolerance& tol,
                  cv::Mat& out);

}  // namespace vclassroom
