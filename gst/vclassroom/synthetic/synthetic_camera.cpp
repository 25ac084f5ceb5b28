#include "synthetic_camera.h"

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/synthetic/board_trace.h>

namespace vclassroom {

void SyntheticCamera::configure(const SyntheticCameraConfig& config) {
  if (!room_ || room_->config().seed != config.room.seed || room_->config().learners != config.room.learners)
    room_ = std::make_unique<Classroom>(config.room);
  config_ = config;
}

SyntheticCamera::Planes SyntheticCamera::frame(const CameraCalib& cam, double t, uint64_t n) {
  if (!room_) throw Error("SyntheticCamera::frame before configure");
  renderer_.render(*room_, t, cam, &clean_);
  if (config_.calibration_board) draw_board(trace_board(), board_pose_on_trace(*room_, t), cam, &clean_);
  if (config_.sensor_noise)
    apply_sensor_model(clean_, cam, sensor_, room_->config().seed, n, &noisy_depth_, &noisy_color_);
  Planes planes;
  planes.color = config_.sensor_noise ? noisy_color_ : clean_.color;
  planes.depth = config_.sensor_noise ? noisy_depth_ : clean_.depth;
  planes.label = clean_.label;
  planes.depth_gt = clean_.depth;
  return planes;
}

}  // namespace vclassroom
