#include "vda_buffer.h"

#include <gst/base/gstbasetransform.h>

#include <gst/vclassroom/core/error.h>

using namespace vclassroom;

namespace vda {

StaticModel load_model_for_stream(const std::string& folder, const RgbdInfo& info, std::string* refused) {
  StaticModel m = load_static_model(folder);
  *refused = model_stream_mismatch(m, folder, info.camera.id, info.width(), info.height());
  return m;
}

void RefusedStream::set(const std::string& why, int camera_id) {
  if (why != why_ || camera_id != camera_id_) warnings_.reset();  // a new refusal is told at once
  why_ = why;
  camera_id_ = camera_id;
}

GstFlowReturn RefusedStream::drop(GstElement* element) {
  uint64_t count = 0;
  int64_t span = 0;
  if (warnings_.note(int64_t(g_get_monotonic_time()) * 1000, &count, &span)) {
    const std::string what =
        describe_occurrences(count, "a frame", "frames", "camera " + std::to_string(camera_id_), span);
    GST_ELEMENT_WARNING(element, STREAM, WRONG_TYPE,
                        ("%s: dropped %s; %s", GST_OBJECT_NAME(element), what.c_str(), why_.c_str()),
                        ("%" G_GUINT64_FORMAT " frames dropped since these caps came", guint64(warnings_.total())));
  }
  return GST_BASE_TRANSFORM_FLOW_DROPPED;
}

GstFlowReturn replace_depth(GstElement* element, GstBuffer* in, const RgbdInfo& info,
                            const std::function<void(const RgbdFrame&, cv::Mat&)>& compute, GstBuffer** out) {
  std::string err;
  RgbdPlaneOutput depth_out(info, Plane::Depth);
  if (!depth_out.mat.empty()) {
    RgbdFrame frame;
    if (!frame.map(in, info, GST_MAP_READ, &err)) {
      GST_ELEMENT_ERROR(element, STREAM, FAILED, ("%s: %s", GST_OBJECT_NAME(element), err.c_str()), (nullptr));
      return GST_FLOW_ERROR;
    }
    compute(frame, depth_out.mat);
  }
  *out = depth_out.finish(in, info, &err);
  if (!*out) {
    GST_ELEMENT_ERROR(element, STREAM, FAILED, ("%s: %s", GST_OBJECT_NAME(element), err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  return GST_FLOW_OK;
}

}  // namespace vda
