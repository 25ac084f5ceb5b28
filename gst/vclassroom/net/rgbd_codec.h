// One compressed RGB-D frame (docs/rgbd-codec.md): colour as JPEG (libjpeg-turbo),
// depth and labels lossless with a fast run-length + prediction coder, each
// section checksummed so a damaged frame is detected, never half decoded.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// Lossless 16-bit depth (CV_16UC1). Zeros (no measurement) are coded as runs;
// valid pixels as the zigzagged difference to a prediction from their valid
// neighbours (median edge detector), in 4-bit groups. In the spirit of
// Wilson's RVL (2017), with 2-D prediction.
void encode_depth_lossless(const cv::Mat& depth, std::vector<uint8_t>* out);
// False when the data is malformed or does not fill a width x height image.
bool decode_depth_lossless(const uint8_t* data, size_t size, int width, int height, cv::Mat* depth);

// 8-bit labels (CV_8UC1) as byte runs.
void encode_labels(const cv::Mat& labels, std::vector<uint8_t>* out);
bool decode_labels(const uint8_t* data, size_t size, int width, int height, cv::Mat* labels);

struct RgbdCodedFrame {
  cv::Mat color;   // CV_8UC3 RGB
  cv::Mat depth;   // CV_16UC1 mm
  cv::Mat label;   // CV_8UC1, optional (empty: absent)
};

// The container: header ("VCRD", version, size, section count) then one
// section per plane (plane id, codec, length, CRC-32 of the payload).
void encode_rgbd_frame(const RgbdCodedFrame& frame, int jpeg_quality, std::vector<uint8_t>* out);
// Decodes and checks everything; false with a reason on any damage.
// What made decode_rgbd_frame() refuse a frame, for counting by kind.
enum class RgbdFrameFault { kNone, kDamaged, kWrongSize };
bool decode_rgbd_frame(const uint8_t* data, size_t size, int width, int height, RgbdCodedFrame* frame,
                       std::string* error, RgbdFrameFault* fault = nullptr);

// What a decoder accepts of the stream a sender declares (its caps come from the network), checked before
// anything is allocated for its size.
struct RgbdStreamLimits {
  int max_width = 4096, max_height = 4096;
  uint64_t max_pixels = 4096ull * 2160;  // 4K
};
// Why camera `camera_id`'s stream of width x height is refused, "" when it is not: beyond `limits`, or,
// with a `rig` (read from `rig_path`, which the reason names), a camera the rig lacks or has at another
// size.
std::string rgbd_stream_refusal(int camera_id, int width, int height, const RgbdStreamLimits& limits,
                                const Rig* rig, const std::string& rig_path);

}  // namespace vclassroom
