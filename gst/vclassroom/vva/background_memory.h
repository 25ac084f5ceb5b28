// A camera's memory of the static room's colour (issue 15): per pixel, the
// mean of the last few colours seen where no learner is (label 0). A change
// larger than the camera's noise (a chair moved, a learner gone, the light)
// starts the mean again at that pixel, so the memory follows the room without
// ghosts; through it the static room no longer flickers with the camera's
// noise. GStreamer-free; viewwarp's background-memory property uses it.
#pragma once

#include <opencv2/core.hpp>

namespace vclassroom {

struct BackgroundMemoryParams {
  int frames = 8;   // the mean's length: the noise falls by about sqrt(frames)
  int change = 24;  // grey levels on any channel that count as a change, not noise
};

class BackgroundMemory {
 public:
  explicit BackgroundMemory(BackgroundMemoryParams params = BackgroundMemoryParams()) : params_(params) {}

  // Takes this frame (RGB CV_8UC3; label CV_8UC1, 0 static, or empty: all static) into the memory and writes
  // to *out the frame with every static pixel replaced by its remembered colour (the others as they are).
  // Throws Error on a wrong type or size; the memory starts again when the size changes.
  void update(const cv::Mat& color, const cv::Mat& label, cv::Mat* out);
  void reset() { mean_.release(); count_.release(); }

 private:
  BackgroundMemoryParams params_;
  cv::Mat mean_;   // CV_32FC3
  cv::Mat count_;  // CV_8UC1: frames in the mean, 0 = nothing remembered
};

}  // namespace vclassroom
