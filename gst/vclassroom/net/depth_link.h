// Depth for the camera link (docs/network.md, "The H.264 camera link"): depth coded across time with an
// error bound that grows with z², as a consumer depth sensor's own resolution does, plus the learner labels
// and the camera's caps, in one checksummed frame ("VCDL") that rides in the colour's H.264 access unit.
//
// The bound: every coded depth z' of a measured depth z (mm) satisfies |z' - z| <= e(z) with
//   e(z) = floor(t * z^2 / 10^8) mm, t = tolerance in 1/100 mm at 1 m (t = 280: 2.8 mm at 1 m, 11 mm at 2 m),
// no measurement (0) stays 0 and a measurement never becomes 0. t = 0 is lossless.
// How: depth is mapped to bins of width 2 e(a) + 1 starting at a (every member of a bin lies within e(z)
// of its centre). Each row sends its runs of measured pixels and holes, then only the measured pixels whose
// value changes, as gaps between them: in a delta frame a pixel keeps its last value since the key frame
// while the measurement stays within the bound of it, and a changed one steps on the grid p + k (e(p) / 2 + 1)
// towards the encoder's running estimate of the true depth (or sends its bin where no grid point is within
// the bound, or the row's is cheaper); in a key frame a pixel keeps the row's last depth. So the decoder's
// work is a copy of each run plus one code per change, not a decision per pixel. Every field is an adaptive
// Golomb-Rice code (the parameter following the context's last values); labels deflated with zlib
// (docs/network.md has the layout, field by field). Decoding is exact, so nothing drifts between key frames.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

// Largest error the coder allows at depth z (mm) for `tolerance_centi_mm` (1/100 mm at 1 m).
uint16_t depth_error_bound(uint16_t z_mm, uint16_t tolerance_centi_mm);

// The default: 2.8 mm at 1 m, just under a Kinect v1's depth step (1/8 px of disparity at f = 580 px,
// b = 75 mm: 2.87 mm x z^2 in metres; Khoshelham & Elberink 2012), i.e. the coder's error stays inside
// the step the sensor itself resolves at every depth.
inline constexpr uint16_t kDefaultDepthTolerance = 280;

// Limits a decoder applies to what the wire declares, before anything is allocated for it.
struct DepthLinkLimits {
  int max_width = 4096, max_height = 4096;
  uint64_t max_pixels = 4096ull * 2160;
  size_t max_caps_bytes = 4096;
};

struct DepthLinkFrame {
  cv::Mat depth;      // CV_16UC1 mm
  cv::Mat label;      // CV_8UC1 or empty
  std::string caps;   // the camera's video/x-rgbd caps (calibration), as GStreamer serialises them
  uint32_t number = 0;
  bool key = false;
  uint16_t tolerance = 0;
};

// What a depth frame's header declares.
struct DepthLinkHeader {
  uint32_t number = 0;
  bool key = false;
  bool labels = false;
  uint16_t tolerance = 0;
  int width = 0, height = 0;
  std::string caps;
};

// Checks a depth frame's header, the lengths of its sections and its checksum against `limits`, without
// decoding it (cheap: what a receiver can afford on every frame); "" or why not.
std::string check_depth_frame(const uint8_t* data, size_t size, const DepthLinkLimits& limits,
                              DepthLinkHeader* header);

// The header's fixed part, in bytes.
inline constexpr size_t kDepthLinkHeaderBytes = 32;

// A depth frame's checksum (docs/network.md): CRC-32 of the header's first 28 bytes and of everything after
// the header; `size` >= kDepthLinkHeaderBytes. It is stored in bytes 28..31.
uint32_t depth_frame_crc(const uint8_t* frame, size_t size);

class DepthLinkEncoder {
 public:
  // Codes `depth` (and `label` when not empty; same size) as the next frame. A key frame when `key`, when
  // the size or tolerance changed, at the first frame, or where a delta frame would send more than half of its
  // measured pixels (the camera moved). Appends to `out`.
  void encode(const cv::Mat& depth, const cv::Mat& label, const std::string& caps, bool key,
              uint16_t tolerance_centi_mm, std::vector<uint8_t>* out, int zlib_level = 1);
  // The depth the decoder will reconstruct for the last frame encoded (for tests and measurement).
  cv::Mat reconstructed() const;
  uint32_t frames() const { return number_; }

 private:
  cv::Mat recon_;    // CV_16UC1: the last frame as the decoder reconstructs it (mm, 0: no measurement)
  cv::Mat mem_;      // CV_16UC1: each pixel's last reconstructed measurement since the key frame (mm)
  cv::Mat estimate_;  // CV_32FC1: each pixel's estimate of its true depth (the encoder's alone; mm)
  std::vector<uint8_t> flags_;  // per pixel: to be sent (delta frames), then measured
  uint16_t tolerance_ = 0;
  uint32_t number_ = 0;
  bool have_ref_ = false;
};

class DepthLinkDecoder {
 public:
  explicit DepthLinkDecoder(DepthLinkLimits limits = {}) : limits_(limits) {}
  // Checks everything (sizes before use, checksum, the frame it builds on) and decodes; false with a reason
  // when the frame is damaged, oversized, or a delta frame whose predecessor was not decoded (then every
  // frame is refused until the next key frame).
  bool decode(const uint8_t* data, size_t size, DepthLinkFrame* frame, std::string* error);
  // The same checks and the same state, for a frame nobody will use (one a later delta frame builds on):
  // its labels are not inflated and its depth goes to a scratch image.
  bool skip(const uint8_t* data, size_t size, std::string* error) { return decode_frame(data, size, nullptr, error); }
  void reset() { have_ref_ = false; }

 private:
  bool decode_frame(const uint8_t* data, size_t size, DepthLinkFrame* frame, std::string* error);

  DepthLinkLimits limits_;
  cv::Mat scratch_;  // skip()'s depth
  cv::Mat mem_;      // as the encoder's
  cv::Size size_;
  uint16_t tolerance_ = 0;
  uint32_t number_ = 0;
  bool have_ref_ = false;
};

}  // namespace vclassroom
