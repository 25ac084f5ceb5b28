#include "rgbdlinkmeta.h"

GType gst_rgbd_link_meta_api_get_type() {
  static GType type = 0;
  static const gchar* tags[] = {nullptr};  // no tags: converters, encoders and decoders copy it
  if (g_once_init_enter(&type)) {
    GType t = gst_meta_api_type_register("GstRgbdLinkMetaAPI", tags);
    g_once_init_leave(&type, t);
  }
  return type;
}

static gboolean rgbd_link_meta_init(GstMeta* meta, gpointer, GstBuffer*) {
  auto* m = reinterpret_cast<GstRgbdLinkMeta*>(meta);
  m->planes = nullptr;
  m->backlog = nullptr;
  m->id = 0;
  m->caps = nullptr;
  m->pts = GST_CLOCK_TIME_NONE;
  return TRUE;
}

static void rgbd_link_meta_free(GstMeta* meta, GstBuffer*) {
  auto* m = reinterpret_cast<GstRgbdLinkMeta*>(meta);
  if (m->planes) gst_buffer_unref(m->planes);
  delete m->backlog;
  if (m->caps) gst_caps_unref(m->caps);
}

static const GstMetaInfo* rgbd_link_meta_get_info();

static gboolean rgbd_link_meta_transform(GstBuffer* dest, GstMeta* meta, GstBuffer*, GQuark type, gpointer) {
  if (!GST_META_TRANSFORM_IS_COPY(type)) return FALSE;  // a scaled or cropped frame no longer matches
  auto* m = reinterpret_cast<GstRgbdLinkMeta*>(meta);
  GstRgbdLinkMeta* copy = m->backlog ? gst_buffer_add_rgbd_link_backlog_meta(dest, *m->backlog, m->id, m->caps)
                                      : gst_buffer_add_rgbd_link_meta(dest, m->planes, m->caps);
  if (copy) copy->pts = m->pts;
  return copy != nullptr;
}

static const GstMetaInfo* rgbd_link_meta_get_info() {
  static const GstMetaInfo* info = nullptr;
  if (g_once_init_enter(&info)) {
    const GstMetaInfo* i = gst_meta_register(gst_rgbd_link_meta_api_get_type(), "GstRgbdLinkMeta",
                                             sizeof(GstRgbdLinkMeta), rgbd_link_meta_init, rgbd_link_meta_free,
                                             rgbd_link_meta_transform);
    g_once_init_leave(&info, i);
  }
  return info;
}

GstRgbdLinkMeta* gst_buffer_add_rgbd_link_meta(GstBuffer* buffer, GstBuffer* planes, GstCaps* caps) {
  auto* m = reinterpret_cast<GstRgbdLinkMeta*>(gst_buffer_add_meta(buffer, rgbd_link_meta_get_info(), nullptr));
  if (!m) return nullptr;
  m->planes = gst_buffer_ref(planes);
  m->caps = gst_caps_ref(caps);
  m->pts = GST_BUFFER_PTS(buffer);
  return m;
}

GstRgbdLinkMeta* gst_buffer_add_rgbd_link_backlog_meta(GstBuffer* buffer,
                                                       const std::shared_ptr<vclassroom::DepthLinkBacklog>& backlog,
                                                       guint64 id, GstCaps* caps) {
  auto* m = reinterpret_cast<GstRgbdLinkMeta*>(gst_buffer_add_meta(buffer, rgbd_link_meta_get_info(), nullptr));
  if (!m) return nullptr;
  m->backlog = new std::shared_ptr<vclassroom::DepthLinkBacklog>(backlog);
  m->id = id;
  m->caps = gst_caps_ref(caps);
  m->pts = GST_BUFFER_PTS(buffer);
  return m;
}

GstRgbdLinkMeta* gst_buffer_get_rgbd_link_meta(GstBuffer* buffer) {
  return reinterpret_cast<GstRgbdLinkMeta*>(gst_buffer_get_meta(buffer, gst_rgbd_link_meta_api_get_type()));
}
