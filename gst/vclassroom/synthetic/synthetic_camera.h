// One camera's frames of the synthetic classroom as rgbdtestsrc streams them: the clean render, the
// calibration board carried through the room when asked for, and the consumer sensor's noise when asked
// for, with the clean depth and the labels as ground truth. GStreamer-free.
#pragma once

#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/synthetic/classroom.h>

namespace vclassroom {

struct SyntheticCameraConfig {
  ClassroomConfig room;
  bool sensor_noise = true;        // the sensor model's depth and colour, else the clean render's
  bool calibration_board = false;  // the board of board_trace.h in the room
};

class SyntheticCamera {
 public:
  // A frame's planes: views of this object's images, valid until the next frame.
  struct Planes {
    cv::Mat color;     // CV_8UC3 RGB
    cv::Mat depth;     // CV_16UC1 mm, as the sensor measures it (or clean)
    cv::Mat label;     // CV_8UC1: 0 static, k learner k
    cv::Mat depth_gt;  // CV_16UC1 mm, clean
  };

  // Building the classroom takes a few hundred ms: it is kept when its seed and learners stay the same.
  // Throws Error.
  void configure(const SyntheticCameraConfig& config);
  // Frame `n` (it picks the sensor noise) at scene time `t` (s) seen by `cam`; configure() first.
  // Throws Error.
  Planes frame(const CameraCalib& cam, double t, uint64_t n);

 private:
  SyntheticCameraConfig config_;
  std::unique_ptr<Classroom> room_;
  ClassroomRenderer renderer_;
  RenderOutput clean_;
  cv::Mat noisy_depth_, noisy_color_;
  SensorParams sensor_;
};

}  // namespace vclassroom
