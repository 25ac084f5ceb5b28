#include "vda_buffer.h"

#include <gst/vclassroom/core/error.h>

using namespace vclassroom;

namespace vda {

StaticModel load_model_for_stream(const std::string& folder, const RgbdInfo& info) {
  StaticModel m = load_static_model(folder);
  const CameraCalib* cam = m.rig.find(info.camera.id);
  if (!cam) {
    std::string ids;
    for (const CameraCalib& c : m.rig.cameras) ids += (ids.empty() ? "" : ", ") + std::to_string(c.id);
    throw Error("static model folder '" + folder + "' has no camera " + std::to_string(info.camera.id) +
                " (the stream's camera-id); it has camera(s) " + ids);
  }
  if (cam->width != info.width() || cam->height != info.height())
    throw Error("static model folder '" + folder + "': camera " + std::to_string(cam->id) + " is " +
                std::to_string(cam->width) + "x" + std::to_string(cam->height) + " but the stream is " +
                std::to_string(info.width()) + "x" + std::to_string(info.height()) +
                " (rebuild the model at the stream's size)");
  return m;
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
