#include <gst/vclassroom/vva/prepared_frame.h>

#include <atomic>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/image_io.h>

namespace vclassroom {

cv::Mat load_static_depth(const std::string& path) {
  const cv::Mat depth = read_image(path, cv::IMREAD_ANYDEPTH, "prior depth");
  if (depth.type() != CV_16UC1) throw Error("prior-depth " + path + ": cannot read it as a 16-bit depth image (mm)");
  return depth;
}

cv::Mat load_empty_room(const std::string& path) {
  cv::Mat rgb;
  cv::cvtColor(read_color_image(path, "empty-room colour"), rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

void FramePreparer::set_memory(int frames, const cv::Mat& empty_room) {
  if (frames == memory_frames_ && empty_room.data == empty_room_.data) return;  // the same: the memory goes on
  memory_frames_ = frames;
  empty_room_ = empty_room;
  memory_fresh_ = true;
}

std::shared_ptr<PreparedFrame> FramePreparer::prepare(const CameraCalib& camera, const cv::Mat& color,
                                                      const cv::Mat& depth, const cv::Mat& label,
                                                      const WarpParams& params) {
  // The last frame's images are reused when nobody holds that frame any more. use_count() is a relaxed
  // read: the fence orders the last holder's reads (another thread's) before the writes below.
  if (!last_ || last_.use_count() > 1) last_ = std::make_shared<PreparedFrame>();
  std::atomic_thread_fence(std::memory_order_acquire);
  std::shared_ptr<PreparedFrame> out = last_;
  WarpSource src;
  src.color = color;
  src.depth = depth;
  src.label = label;
  src.static_depth = static_depth_;
  if (memory_frames_ > 0) {
    if (memory_fresh_) {
      BackgroundMemoryParams mp;
      mp.frames = memory_frames_;
      memory_ = BackgroundMemory(mp);
      if (!empty_room_.empty() && empty_room_.size() == color.size()) memory_.seed(empty_room_);
      memory_fresh_ = false;
    }
    // Written straight into the prepared frame's images, which outlive the memory's next frame.
    memory_.apply(&src, &out->color, &out->room_color, &out->room_depth);
    // No room layer this frame (no static depth or labels): nor a depth left from the frame this one reuses.
    // (The remembered room stays in room_color, its buffer kept for the next frame; nothing draws it.)
    if (src.room_depth.empty()) out->room_depth.release();
  } else {
    out->color.release();
    out->room_color.release();
    out->room_depth.release();
  }
  warper_.prepare(camera, src, params, &out->source);
  out->edge_to_near = params.edge_to_near;
  out->boundary_px = params.boundary_px;
  return out;
}

WarpSource FramePreparer::source_of(const PreparedFrame& prepared, const cv::Mat& color, const cv::Mat& depth,
                                    const cv::Mat& label) {
  WarpSource src;
  src.color = prepared.color.empty() ? color : prepared.color;
  src.depth = depth;
  src.label = label;
  src.room_color = prepared.room_color;
  src.room_depth = prepared.room_depth;
  return src;
}

namespace {

gboolean prepared_frame_meta_init(GstMeta* meta, gpointer, GstBuffer*) {
  reinterpret_cast<PreparedFrameMeta*>(meta)->frame = nullptr;
  return TRUE;
}

void prepared_frame_meta_free(GstMeta* meta, GstBuffer*) {
  auto* m = reinterpret_cast<PreparedFrameMeta*>(meta);
  delete m->frame;
  m->frame = nullptr;
}

// A copy of the buffer shares the prepared frame; other transforms (a scaled or converted frame) drop it.
gboolean prepared_frame_meta_transform(GstBuffer* dest, GstMeta* meta, GstBuffer*, GQuark type, gpointer data) {
  auto* m = reinterpret_cast<PreparedFrameMeta*>(meta);
  if (!GST_META_TRANSFORM_IS_COPY(type) || !m->frame) return TRUE;
  const auto* copy = static_cast<const GstMetaTransformCopy*>(data);
  if (copy->region) return TRUE;  // a part of the buffer: not the frame that was prepared
  buffer_add_prepared_frame(dest, *m->frame);
  return TRUE;
}

}  // namespace

GType prepared_frame_meta_api_get_type() {
  static GType type = 0;
  // A tag of its own: elements that make a new frame out of this one (viewwarp itself, a scaler) do not
  // copy it, as GstBaseTransform copies only untagged metas by default.
  static const gchar* tags[] = {"vclassroom-frame-content", nullptr};
  if (g_once_init_enter(&type)) {
    GType t = gst_meta_api_type_register("VClassroomPreparedFrameMetaAPI", tags);
    g_once_init_leave(&type, t);
  }
  return type;
}

const GstMetaInfo* prepared_frame_meta_get_info() {
  static const GstMetaInfo* info = nullptr;
  if (g_once_init_enter(&info)) {
    const GstMetaInfo* mi =
        gst_meta_register(prepared_frame_meta_api_get_type(), "VClassroomPreparedFrameMeta", sizeof(PreparedFrameMeta),
                          prepared_frame_meta_init, prepared_frame_meta_free, prepared_frame_meta_transform);
    g_once_init_leave(&info, mi);
  }
  return info;
}

void buffer_add_prepared_frame(GstBuffer* buf, std::shared_ptr<const PreparedFrame> frame) {
  auto* m = reinterpret_cast<PreparedFrameMeta*>(gst_buffer_get_meta(buf, prepared_frame_meta_api_get_type()));
  if (!m) m = reinterpret_cast<PreparedFrameMeta*>(gst_buffer_add_meta(buf, prepared_frame_meta_get_info(), nullptr));
  if (!m) return;
  delete m->frame;
  m->frame = new std::shared_ptr<const PreparedFrame>(std::move(frame));
}

std::shared_ptr<const PreparedFrame> buffer_get_prepared_frame(GstBuffer* buf) {
  auto* m = reinterpret_cast<PreparedFrameMeta*>(gst_buffer_get_meta(buf, prepared_frame_meta_api_get_type()));
  return m && m->frame ? *m->frame : nullptr;
}

}  // namespace vclassroom
