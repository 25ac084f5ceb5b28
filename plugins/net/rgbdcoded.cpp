#include "rgbdcoded.h"

#include <string>

#include <gst/vclassroom/core/warning_limiter.h>

GstCaps* caps_filtered(GstCaps* caps, GstCaps* filter) {
  if (!filter) return caps;
  GstCaps* out = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
  gst_caps_unref(caps);
  return out;
}

bool take_queued_input(GstBaseTransform* trans, gboolean negotiated, GstBuffer** in, GstFlowReturn* ret) {
  *in = trans->queued_buf;
  trans->queued_buf = nullptr;
  *ret = GST_FLOW_OK;
  if (!*in) return false;
  if (!negotiated) {
    gst_buffer_unref(*in);
    *in = nullptr;
    *ret = GST_FLOW_NOT_NEGOTIATED;
    return false;
  }
  return true;
}

void codec_stats_install_properties(GObjectClass* klass, const char* frames_blurb) {
  const auto ro = GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  g_object_class_install_property(klass, kPropFrames,
                                  g_param_spec_uint64("frames", "Frames", frames_blurb, 0, G_MAXUINT64, 0, ro));
  g_object_class_install_property(klass, kPropBytes,
                                  g_param_spec_uint64("bytes", "Bytes", "Compressed bytes of the frames counted in frames", 0,
                                                      G_MAXUINT64, 0, ro));
  g_object_class_install_property(
      klass, kPropDropped,
      g_param_spec_uint64("frames-dropped", "Frames dropped", "Frames dropped as damaged or unreadable", 0,
                          G_MAXUINT64, 0, ro));
  g_object_class_install_property(
      klass, kPropStatsInterval,
      g_param_spec_uint("stats-interval", "Statistics interval",
                        "Post a vclassroom-codec-stats message every N frames and at the end (0 = never)",
                        0, G_MAXUINT, 0,
                        GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
}

bool codec_stats_get_property(GstObject* self, const CodecStats& st, guint prop_id, GValue* value) {
  GST_OBJECT_LOCK(self);
  bool known = true;
  switch (prop_id) {
    case kPropFrames: g_value_set_uint64(value, st.frames); break;
    case kPropBytes: g_value_set_uint64(value, st.bytes); break;
    case kPropDropped: g_value_set_uint64(value, st.dropped); break;
    case kPropStatsInterval: g_value_set_uint(value, st.interval); break;
    default: known = false;
  }
  GST_OBJECT_UNLOCK(self);
  return known;
}

bool codec_stats_set_property(GstObject* self, CodecStats* st, guint prop_id, const GValue* value) {
  if (prop_id != kPropStatsInterval) return false;
  GST_OBJECT_LOCK(self);
  st->interval = g_value_get_uint(value);
  GST_OBJECT_UNLOCK(self);
  return true;
}

CodecStats codec_stats_count(GstElement* self, CodecStats* st, guint64 bytes, bool dropped) {
  if (dropped) return codec_stats_drop(self, st, DropKind::Damaged);
  GST_OBJECT_LOCK(self);
  st->frames++, st->bytes += bytes;
  const CodecStats now = *st;
  GST_OBJECT_UNLOCK(self);
  if (now.interval && (now.frames + now.dropped) % now.interval == 0) codec_stats_post(self, &now);
  return now;
}

CodecStats codec_stats_drop(GstElement* self, CodecStats* st, DropKind kind) {
  GST_OBJECT_LOCK(self);
  st->dropped++;
  st->dropped_by_kind[int(kind)]++;
  const CodecStats now = *st;
  GST_OBJECT_UNLOCK(self);
  if (now.interval && (now.frames + now.dropped) % now.interval == 0) codec_stats_post(self, &now);
  return now;
}

namespace {

// The element upstream of `self` (through single-input elements, a few hops)
// made by `factory`, or nullptr. Takes a reference.
GstElement* upstream_element(GstElement* self, const char* factory) {
  GstElement* at = GST_ELEMENT(gst_object_ref(self));
  for (int hop = 0; hop < 8; ++hop) {
    GstPad* sink = gst_element_get_static_pad(at, "sink");
    GstPad* peer = sink ? gst_pad_get_peer(sink) : nullptr;
    if (sink) gst_object_unref(sink);
    GstElement* up = peer ? gst_pad_get_parent_element(peer) : nullptr;
    if (peer) gst_object_unref(peer);
    gst_object_unref(at);
    if (!up) return nullptr;
    GstElementFactory* f = gst_element_get_factory(up);
    if (f && g_strcmp0(GST_OBJECT_NAME(f), factory) == 0) return up;
    at = up;
  }
  gst_object_unref(at);
  return nullptr;
}

}  // namespace

// What the network did to this camera's stream before the depayloader: the
// jitter buffer's counts of packets lost (not repaired in time), repaired
// (retransmissions that arrived) and asked for again, when rgbddec sits behind
// one (pipelines/server.sh: udpsrc … ! rtpjitterbuffer ! rtpgstdepay ! … ! rgbddec).
void add_link_stats(GstElement* self, GstStructure* s) {
  GstElement* jitter = upstream_element(self, "rtpjitterbuffer");
  if (!jitter) return;
  GstStructure* js = nullptr;
  g_object_get(jitter, "stats", &js, nullptr);
  gst_object_unref(jitter);
  if (!js) return;
  guint64 lost = 0, repaired = 0, requested = 0, pushed = 0;
  gst_structure_get_uint64(js, "num-lost", &lost);
  gst_structure_get_uint64(js, "rtx-success-count", &repaired);
  gst_structure_get_uint64(js, "rtx-count", &requested);
  gst_structure_get_uint64(js, "num-pushed", &pushed);
  gst_structure_free(js);
  gst_structure_set(s, "packets-received", G_TYPE_UINT64, pushed, "packets-lost", G_TYPE_UINT64, lost,
                    "packets-repaired", G_TYPE_UINT64, repaired, "retransmissions-requested", G_TYPE_UINT64,
                    requested, nullptr);
}

void codec_stats_post(GstElement* self, const CodecStats* st) {
  GST_OBJECT_LOCK(self);
  const CodecStats now = *st;
  GST_OBJECT_UNLOCK(self);
  if (!now.interval) return;
  GstStructure* s = gst_structure_new(
      "vclassroom-codec-stats", "frames", G_TYPE_UINT64, now.frames, "bytes", G_TYPE_UINT64, now.bytes,
      "frames-dropped", G_TYPE_UINT64, now.dropped, "dropped-damaged", G_TYPE_UINT64,
      now.dropped_by_kind[int(DropKind::Damaged)], "dropped-wrong-size", G_TYPE_UINT64,
      now.dropped_by_kind[int(DropKind::WrongSize)], "dropped-rejected-caps", G_TYPE_UINT64,
      now.dropped_by_kind[int(DropKind::RejectedCaps)], nullptr);
  add_link_stats(self, s);
  gst_element_post_message(self, gst_message_new_element(GST_OBJECT(self), s));
}

gboolean codec_stats_sink_event(GstBaseTransform* trans, GstEvent* event, CodecStats* st,
                                gboolean (*parent_sink_event)(GstBaseTransform*, GstEvent*)) {
  if (GST_EVENT_TYPE(event) == GST_EVENT_EOS) codec_stats_post(GST_ELEMENT(trans), st);
  return parent_sink_event(trans, event);
}

void warn_dropped(GstElement* self, uint64_t count, int64_t span, const char* singular, const char* plural,
                  const std::string& source, const std::string& why, guint64 dropped, const char* units) {
  const std::string what = vclassroom::describe_occurrences(count, singular, plural, source, span);
  GST_ELEMENT_WARNING(self, STREAM, DECODE, ("dropped %s; %s: %s", what.c_str(), count == 1 ? "why" : "the last",
                                             why.c_str()),
                      ("%" G_GUINT64_FORMAT " %s dropped so far", dropped, units));
}
