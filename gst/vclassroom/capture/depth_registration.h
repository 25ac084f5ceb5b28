// Depth seen through the colour lens: a consumer RGB-D camera's depth sensor
// sits a few centimetres beside its colour sensor, so its image must be
// re-projected into the colour camera before colour and depth share pixels
// (the rig's `depth_to_color`, docs/rig-format.md). GStreamer-free.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// Registers depth images of one camera pair; keeps per-pixel rays between
// frames. Each depth pixel's centre is projected into the colour image and
// its footprint there (one depth pixel's size, scaled by the two focal
// lengths and depths) gives every colour pixel whose centre it covers its
// depth, the nearest winning (z-buffer): a surface seen
// whole by the depth sensor comes out without holes from the re-projection,
// and what the depth sensor could not see from its side stays 0.
class DepthRegistration {
 public:
  // `depth` is the depth sensor's own calibration (intrinsics, its size);
  // `color` the colour camera; `depth_to_color` maps depth-camera points to
  // colour-camera points (metres).
  DepthRegistration(const CameraCalib& depth, const CameraCalib& color, const Eigen::Isometry3d& depth_to_color);
  // depth_mm: CV_16UC1 at the depth camera's size; out: CV_16UC1 at the
  // colour camera's size, mm along the colour camera's optical axis.
  void register_depth(const cv::Mat& depth_mm, cv::Mat* out);

 private:
  CameraCalib depth_, color_;
  Eigen::Matrix3f rotation_;
  Eigen::Vector3f translation_;
  std::vector<float> ray_x_, ray_y_, ray_z_;  // each depth pixel's ray in the colour camera's orientation
  cv::Mat zbuffer_;
  // One depth row at a time, padded to whole groups of eight: the row's depth, and where each pixel's
  // footprint lands in the colour image with its depth there (0: nowhere).
  std::vector<uint16_t> row_depth_;
  std::vector<int32_t> x0_, x1_, y0_, y1_, zc_;
  std::vector<int32_t> single_;  // the colour pixel of a one-pixel footprint inside the image, else -1
};

// The colour camera's calibration for the depth sensor when the rig says the
// two are aligned (no depth_to_color): then no registration is needed.
inline bool needs_registration(const CameraCalib& c) { return c.depth_to_color.has_value(); }

}  // namespace vclassroom
