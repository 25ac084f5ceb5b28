// Coverage-aware navigation (docs/navigation.md): how much of a lecturer's
// view the cameras can show, a map of it over the room, and the bounds
// (NavigationBounds in core/rig.h) inside which it stays above a threshold.
// GStreamer-free.
#pragma once

#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/core/warning_limiter.h>
#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

// The share of a virtual view that some camera sees, judged on the static
// room: each camera's depth of the empty room (V-DA's prior, or a rendered
// stand-in) warped into the view at a small working size. A pixel no
// camera's room surface lands on can only be invented.
class CoverageEstimator {
 public:
  // `static_depth[i]` (CV_16UC1 mm) belongs to `cameras[i]`, at its size.
  // Views are judged `width` pixels wide, with the reference's aspect.
  CoverageEstimator(const std::vector<CameraCalib>& cameras, const std::vector<cv::Mat>& static_depth,
                    const CameraCalib& reference, int width = 96);
  double coverage(const ViewOffset& offset);
  const CameraCalib& reference() const { return reference_; }

 private:
  CameraCalib reference_;  // at full size: offsets are relative to it
  CameraCalib view_;       // the reference at the working size
  std::vector<CameraCalib> cameras_;
  std::vector<cv::Mat> depth_, color_;
  std::vector<ViewWarper> warpers_;
  std::vector<WarpedView> warped_;
  cv::Mat seen_;
};

// How far derive_navigation() looks, and in what steps.
struct NavigationSearch {
  double threshold = 0.9;               // the share of the view that must be seen
  std::array<double, 6> reach_min{{-3, -1.5, -2, -90, -80, -45}};  // right, up, forward (m), yaw, pitch, roll (deg)
  std::array<double, 6> reach_max{{3, 1.5, 4, 90, 80, 45}};
  double position_step = 0.05;          // m
  double angle_step = 2.5;              // deg
};

// Bounds around the reference view: the cone (yaw, pitch and roll each way
// from the reference position while the view stays covered), the box of
// positions grown face by face while the view straight ahead stays covered at
// the new face's corners and centre, then both shrunk by one factor until the
// view straight ahead and at the cone's yaw/pitch limits stays covered at
// every face's corners and centre. The reference view itself is always inside (even when it is covered
// less than the threshold: then the bounds are the reference view alone).
// `progress` (optional) is called with a short description now and then.
NavigationBounds derive_navigation(CoverageEstimator& estimator, int reference_camera, const NavigationSearch& search,
                                   const std::function<void(const std::string&)>& progress = nullptr);

// One sample of the coverage map: an offset from the reference and its coverage.
struct CoverageSample {
  ViewOffset offset;
  double coverage = 0;
};
// Coverage over a grid of positions (every `position_step` m within the reach)
// and view directions (yaw and pitch every `angle_step` degrees, no roll).
std::vector<CoverageSample> coverage_map(CoverageEstimator& estimator, const NavigationSearch& reach,
                                         double position_step, double angle_step,
                                         const std::function<void(size_t done, size_t total)>& progress = nullptr);

// Keeps poses inside a rig's navigation bounds (posenav for the lecturer's
// own view and pose traces, viewfuse for every pose any client sends), with
// rate-limited warnings that count what was clamped. Not thread-safe: callers
// lock.
class NavigationClamp {
 public:
  NavigationClamp() = default;
  // Without a navigation section in the rig, every pose passes as it is.
  explicit NavigationClamp(const Rig& rig);
  bool active() const { return bounds_.has_value(); }
  // Moves `pose` to the nearest allowed pose (clamp_to_navigation) and counts
  // it; true when it was outside. When a warning is due (the first at once,
  // then one per 5 s with the count) `*warning` gets it, else "": "37 poses
  // outside the navigation bounds from the lecturer in the last 5 s were moved
  // to the nearest allowed view". `source` names where they came from.
  bool apply(Pose* pose, int64_t now_ns, const std::string& source, std::string* warning);
  uint64_t clamped() const { return limiter_.total(); }

 private:
  std::optional<NavigationBounds> bounds_;
  CameraCalib reference_;
  WarningLimiter limiter_;
};

}  // namespace vclassroom
