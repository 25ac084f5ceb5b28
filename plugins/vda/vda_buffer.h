// Shared by depthcomplete and planerefine: the camera's part of a static
// model folder, and output buffers whose depth plane is new while every other
// plane shares the input's memory.
#pragma once

#include <functional>
#include <string>

#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/static_model.h>

namespace vda {

// Loads `folder` and checks it has camera `info.camera.id` at the stream's
// size. Throws vclassroom::Error with a message naming the folder, the camera
// and both sizes.
vclassroom::StaticModel load_model_for_stream(const std::string& folder, const vclassroom::RgbdInfo& info);

// The whole per-frame step of both elements: maps `in`, lets `compute` write
// the new depth into `depth_out` (same size, CV_16UC1) from the input frame,
// and builds the output buffer. Errors are posted on `element`, prefixed with
// its name. The frame is only read.
GstFlowReturn replace_depth(GstElement* element, GstBuffer* in, const vclassroom::RgbdInfo& info,
                            const std::function<void(const vclassroom::RgbdFrame& frame, cv::Mat& depth_out)>& compute,
                            GstBuffer** out);

}  // namespace vda
