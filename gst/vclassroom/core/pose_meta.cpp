#include <gst/vclassroom/core/pose_meta.h>

namespace vclassroom {

namespace {

gboolean pose_meta_init(GstMeta* meta, gpointer, GstBuffer*) {
  auto* m = reinterpret_cast<PoseMeta*>(meta);
  m->seq = 0;
  m->viewer_time_ns = -1;
  m->session = 0;
  m->rendered = RenderedPose{};
  return TRUE;
}

// Copies, scaling and conversions keep the pose the frame shows.
gboolean pose_meta_transform(GstBuffer* dest, GstMeta* meta, GstBuffer*, GQuark, gpointer) {
  auto* m = reinterpret_cast<PoseMeta*>(meta);
  buffer_add_pose_meta(dest, m->seq, m->viewer_time_ns, m->rendered, m->session);
  return TRUE;
}

}  // namespace

GType pose_meta_api_get_type() {
  static GType type = 0;
  static const gchar* tags[] = {nullptr};
  if (g_once_init_enter(&type)) {
    GType t = gst_meta_api_type_register("VClassroomPoseMetaAPI", tags);
    g_once_init_leave(&type, t);
  }
  return type;
}

const GstMetaInfo* pose_meta_get_info() {
  static const GstMetaInfo* info = nullptr;
  if (g_once_init_enter(&info)) {
    const GstMetaInfo* mi = gst_meta_register(pose_meta_api_get_type(), "VClassroomPoseMeta", sizeof(PoseMeta),
                                              pose_meta_init, nullptr, pose_meta_transform);
    g_once_init_leave(&info, mi);
  }
  return info;
}

PoseMeta* buffer_add_pose_meta(GstBuffer* buf, uint64_t seq, int64_t viewer_time_ns, const RenderedPose& rendered,
                               uint64_t session) {
  PoseMeta* m = buffer_get_pose_meta(buf);
  if (!m) m = reinterpret_cast<PoseMeta*>(gst_buffer_add_meta(buf, pose_meta_get_info(), nullptr));
  m->seq = seq;
  m->viewer_time_ns = viewer_time_ns;
  m->session = session;
  m->rendered = rendered;
  return m;
}

PoseMeta* buffer_get_pose_meta(GstBuffer* buf) {
  return reinterpret_cast<PoseMeta*>(gst_buffer_get_meta(buf, pose_meta_api_get_type()));
}

}  // namespace vclassroom
