#include "vda_buffer.h"

#include <gst/vclassroom/error.h>

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

DepthOutput::DepthOutput(const RgbdInfo& info) {
  const int i = info.index_of(Plane::Depth);
  stride_ = info.default_stride(static_cast<size_t>(i));
  buf_ = gst_buffer_new_allocate(nullptr, static_cast<gsize>(stride_) * info.height(), nullptr);
  if (buf_ && gst_buffer_map(buf_, &map_, GST_MAP_WRITE)) {
    mapped_ = true;
    mat = cv::Mat(info.height(), info.width(), CV_16UC1, map_.data, static_cast<size_t>(stride_));
  }
}

DepthOutput::~DepthOutput() {
  if (mapped_) gst_buffer_unmap(buf_, &map_);
  if (buf_) gst_buffer_unref(buf_);
}

GstBuffer* DepthOutput::finish(GstBuffer* in, const RgbdInfo& info, std::string* error) {
  if (!mapped_) {
    *error = "cannot allocate the output depth plane";
    return nullptr;
  }
  gst_buffer_unmap(buf_, &map_);
  mapped_ = false;
  mat = cv::Mat();
  std::vector<GstBuffer*> parts;
  std::vector<PlaneLayout> layouts;
  for (size_t i = 0; i < info.planes.size(); ++i) {
    if (info.planes[i] == Plane::Depth) {
      parts.push_back(buf_);
      layouts.push_back(PlaneLayout{0, stride_});
      continue;
    }
    PlaneLayout l;
    if (!rgbd_plane_layout(in, info, i, &l, error)) return nullptr;
    parts.push_back(in);
    layouts.push_back(l);
  }
  GstBuffer* out = rgbd_buffer_assemble(info, parts, layouts);
  if (!out) {
    *error = "cannot assemble the output buffer";
    return nullptr;
  }
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  return out;
}

GstFlowReturn replace_depth(GstElement* element, GstBuffer* in, const RgbdInfo& info,
                            const std::function<void(const RgbdFrame&, cv::Mat&)>& compute, GstBuffer** out) {
  std::string err;
  DepthOutput depth_out(info);
  {
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
