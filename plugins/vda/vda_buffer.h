// Shared by depthcomplete and planerefine: the camera's part of a static
// model folder, a stream the model cannot serve, and output buffers whose
// depth plane is new while every other plane shares the input's memory.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/warning_limiter.h>
#include <gst/vclassroom/vda/static_model.h>

namespace vda {

// Loads `folder` (throws vclassroom::Error naming it when it cannot be read:
// the operator's own file, a setup error) and sets *refused to why the
// stream cannot use it (model_stream_mismatch: "" when it can).
vclassroom::StaticModel load_model_for_stream(const std::string& folder, const vclassroom::RgbdInfo& info,
                                              std::string* refused);

// A camera stream the model cannot serve (another camera, another size: the
// sender's fault, as caps arrive from the network). Its frames are dropped,
// each counted, with a rate-limited warning on the bus; the other cameras go
// on. Streaming thread only.
class RefusedStream {
 public:
  void set(const std::string& why, int camera_id);
  bool refused() const { return !why_.empty(); }
  // Drops a frame: posts the warning when one is due and returns
  // GST_BASE_TRANSFORM_FLOW_DROPPED.
  GstFlowReturn drop(GstElement* element);

 private:
  std::string why_;
  int camera_id_ = -1;
  vclassroom::WarningLimiter warnings_;
};

// The whole per-frame step of both elements: maps `in`, lets `compute` write
// the new depth into `depth_out` (same size, CV_16UC1) from the input frame,
// and builds the output buffer. Errors are posted on `element`, prefixed with
// its name. The frame is only read.
GstFlowReturn replace_depth(GstElement* element, GstBuffer* in, const vclassroom::RgbdInfo& info,
                            const std::function<void(const vclassroom::RgbdFrame& frame, cv::Mat& depth_out)>& compute,
                            GstBuffer** out);

}  // namespace vda
