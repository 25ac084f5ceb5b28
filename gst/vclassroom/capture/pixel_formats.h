// What a consumer RGB-D camera's V4L2 nodes deliver, turned into the
// video/x-rgbd planes (RGB colour, depth in mm). Every buffer comes from a
// driver, so its size is checked against the negotiated format before any
// pixel is read. GStreamer-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

// The pixel formats rgbdsrc takes (V4L2 fourccs).
enum class CapturePixelFormat {
  kYuyv,  // YUYV 4:2:2, 2 bytes a pixel (colour)
  kRgb3,  // RGB 8:8:8, 3 bytes a pixel (colour)
  kMjpg,  // motion JPEG, one JPEG a frame (colour)
  kZ16,   // 16-bit depth, little-endian, in the sensor's depth units
  kY16,   // 16-bit grey used for depth by some cameras, same layout as Z16
};

const char* capture_format_name(CapturePixelFormat f);
bool capture_format_is_depth(CapturePixelFormat f);

// One colour frame as RGB (CV_8UC3). `bytesused` is what the driver says the
// buffer holds and `stride` its bytes per line (0: packed). False, with the
// reason, when the buffer is too short for width x height, the stride too
// small, or a JPEG does not decode to that size.
bool capture_to_rgb(CapturePixelFormat f, const uint8_t* data, size_t bytesused, int width, int height, size_t stride,
                    cv::Mat* rgb, std::string* error);

// One depth frame as millimetres (CV_16UC1): each value times `depth_scale`
// (the rig camera's mm per unit), rounded, saturated at 65535; 0 stays 0 (no
// measurement). The same checks as above.
bool capture_to_depth_mm(CapturePixelFormat f, const uint8_t* data, size_t bytesused, int width, int height,
                         size_t stride, double depth_scale, cv::Mat* depth_mm, std::string* error);

// RGB (CV_8UC3, even width) as a UVC camera sends YUYV: BT.601 in limited
// range (Y 16-235, U and V 16-240), each pair of pixels sharing U and V; what
// capture_to_rgb() reads back. For test stand-ins and benchmarks.
std::vector<uint8_t> rgb_to_yuyv(const cv::Mat& rgb);

}  // namespace vclassroom
