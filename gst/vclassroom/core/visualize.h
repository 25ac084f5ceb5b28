// Images for people: depth maps a reader can see.
#pragma once

#include <opencv2/core.hpp>

namespace vclassroom {

// Depth in mm (CV_16UC1) to an RGB image (CV_8UC3, `out` may be preallocated):
// near = warm, far = cool over [min_mm, max_mm] (turbo colour map), no
// measurement (0) = black.
void colorize_depth(const cv::Mat& depth_mm, cv::Mat& out_rgb, double min_mm, double max_mm);

}  // namespace vclassroom
