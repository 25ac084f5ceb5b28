// One consumer RGB-D camera through V4L2, as rgbdsrc runs it: its colour and
// depth nodes opened at the rig camera's modes, every frame converted (colour
// to RGB, depth to mm, and registered into the colour image when the rig gives
// the depth lens apart) and colour and depth paired by their capture time.
// GStreamer-free; plugins/capture/gstrgbdsrc.cpp is its glue.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/capture/depth_registration.h>
#include <gst/vclassroom/capture/frame_pairing.h>
#include <gst/vclassroom/capture/v4l2_device.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// A camera without a rig: the first size both nodes offer (colour formats in
// rgbdsrc's order), a pinhole 64 degrees across, depth in mm, at the origin.
// Throws CaptureError when the two are not the nodes of one camera.
CameraCalib nominal_camera(const std::string& color_path, const std::string& depth_path, int id);

class RgbdCamera {
 public:
  struct Frame {
    cv::Mat color;  // CV_8UC3 RGB at the camera's size
    cv::Mat depth;  // CV_16UC1 mm, in the colour camera
    int64_t capture_ns = 0;  // the colour frame's kernel capture time (CLOCK_MONOTONIC)
  };
  // What one call saw besides the pair: frames dropped unpaired, and damaged ones with why.
  struct Losses {
    uint64_t unpaired = 0;
    std::vector<std::string> damaged;  // "node: why", one per damaged frame
  };

  // Opens both nodes (throws CaptureError): colour YUYV, RGB3 or MJPG and depth Z16 or Y16 at the camera's
  // size (the depth lens's with depth_to_color), at fps_n/fps_d.
  RgbdCamera(std::string color_path, std::string depth_path, const CameraCalib& camera, int fps_n, int fps_d,
             int64_t max_skew_ns);

  // Waits at most `timeout_ms` for frames; true with the next pair in *out. Throws CaptureError: kIo for one
  // frame the driver could not deliver (the stream goes on), kVanished when a node went away.
  bool next(int timeout_ms, Frame* out, Losses* losses);

  // After kVanished: tries once to open both nodes again (throws CaptureError while they are not back);
  // what was waiting for a partner is forgotten.
  void reopen();

  const std::string& color_path() const { return color_path_; }
  const std::string& depth_path() const { return depth_path_; }

 private:
  void open();
  void take(V4l2Device* dev, bool is_color, Losses* losses);
  // The next complete pair, if any; what the pairer gave up on is freed and counted.
  bool pop(Frame* out, Losses* losses);

  std::string color_path_, depth_path_;
  CameraCalib camera_;
  int fps_n_, fps_d_;
  std::unique_ptr<V4l2Device> color_, depth_;
  FramePairer pairer_;
  std::unique_ptr<DepthRegistration> registration_;  // when the rig gives the depth lens apart
  std::map<uint64_t, cv::Mat> colors_, depths_;      // converted frames waiting for their partner, by id
  uint64_t next_id_ = 0;
};

}  // namespace vclassroom
