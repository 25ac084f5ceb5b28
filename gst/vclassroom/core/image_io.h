// Images read from files and bytes from outside (datasets, static models, imports, the empty room): every
// size checked from the header before decoding, every failure an Error naming the file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace vclassroom {

// The largest image file read (docs/dataset-format.md).
inline constexpr size_t kMaxImageFileBytes = size_t(1) << 30;

// Reads a 16-bit depth image (PNG/PGM) and converts it to mm with `depth_scale`.
// With an `expected` size, another size is an error naming `expected_from`
// (e.g. "rig camera 1"); a PNG is checked from its header before decoding.
cv::Mat read_depth_mm(const std::string& path, double depth_scale, cv::Size expected = {},
                      const std::string& expected_from = "");

// The one image reader of files from outside (datasets, static models,
// imports): a missing, oversized, undecodable or wrongly sized image is an
// Error naming the file; OpenCV's exceptions never escape. `what` names the
// plane ("colour", "depth").
cv::Mat read_image(const std::string& path, int flags, const std::string& what, cv::Size expected = {},
                   const std::string& expected_from = "");
// A colour image as read_image reads it, which must be 8-bit with three
// channels (BGR, as OpenCV reads them): a 16-bit or grey image in a colour
// folder is a mistake (a depth map put there, a wrong export) that reading it
// with conversion would hide, so it is an Error naming the file and what it is.
cv::Mat read_color_image(const std::string& path, const std::string& what, cv::Size expected = {},
                         const std::string& expected_from = "");
// The width and height a PNG, JPEG or PNM image declares in its header; false
// when the bytes are none of these (or the header is cut short).
bool image_header_size(const uint8_t* data, size_t size, uint32_t* width, uint32_t* height);
// The same from bytes in memory; `name` stands for the file in messages.
cv::Mat decode_image(const uint8_t* data, size_t size, int flags, const std::string& what, const std::string& name,
                     cv::Size expected = {}, const std::string& expected_from = "");

}  // namespace vclassroom
