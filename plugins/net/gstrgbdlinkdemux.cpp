/**
 * SECTION:element-rgbdlinkdemux
 * @title: rgbdlinkdemux
 *
 * The server side of the H.264 camera link (docs/network.md): before the H.264 decoder, reads the "VCDL"
 * depth frame from each access unit's SEI, checks its header (sizes before anything is allocated, the
 * checksum, the caps it names, that a delta frame's predecessor came), queues it and hangs its place in the
 * queue on the access unit as a meta, which the decoder carries to the picture. rgbdlinkjoin decodes the depth when it
 * joins that picture, in its own thread: where a leaky queue drops pictures before it, the depth frames they
 * came with are decoded only as far as later ones need them, and at that thread's priority
 * (docs/network.md, "Decoding the depth where the picture is used"). Every access unit is passed on (the
 * decoder needs them all); one whose depth is missing or damaged goes without the meta, and a rate-limited
 * warning says why (rgbdlinkjoin then drops that picture). With `rig` set, a camera the rig does not have, or
 * of another size than the rig's, is refused as rgbddec refuses it.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=30 ! rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast ! video/x-h264,profile=constrained-baseline ! rgbdlinkmux ! rtph264pay ! rtph264depay ! rgbdlinkdemux ! avdec_h264 max-threads=1 ! videoconvert ! rgbdlinkjoin ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdlinkdemux.h"

#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/core/warning_limiter.h>
#include <gst/vclassroom/net/depth_link_backlog.h>
#include <gst/vclassroom/net/h264_sei.h>
#include <gst/vclassroom/net/rgbd_codec.h>

#include "rgbdcoded.h"
#include "rgbdlinkmeta.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_link_demux_debug);
#define GST_CAT_DEFAULT rgbd_link_demux_debug

using namespace vclassroom;

enum { PROP_RIG = 1 };

struct _GstRgbdLinkDemux {
  GstBaseTransform parent;
  CodecStats stats;        // object lock
  std::string* rig_path;   // object lock
  // Streaming thread only:
  std::optional<Rig>* rig;  // loaded at start
  std::string* rig_source;  // the path it was loaded from
  std::shared_ptr<DepthLinkBacklog>* backlog;  // shared with the metas (rgbdlinkjoin decodes)
  std::string* caps_text;  // the caps string of out_caps
  GstCaps* out_caps;       // video/x-rgbd of the joined frames
  WarningLimiter* warnings;
  // A depth SEI that came in a unit without a picture (a payloader that puts SPS and PPS between the SEI and
  // the slice, as rtph264pay config-interval=-1 does, makes rtph264depay start a new access unit there): it
  // belongs to the picture of the same timestamp that comes next.
  std::vector<uint8_t>* pending;
  GstClockTime pending_pts;
};

G_DEFINE_TYPE(GstRgbdLinkDemux, gst_rgbd_link_demux, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(rgbdlinkdemux, "rgbdlinkdemux", GST_RANK_NONE, GST_TYPE_RGBD_LINK_DEMUX)

#define H264_AU_CAPS "video/x-h264, stream-format=(string)byte-stream, alignment=(string)au"
static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(H264_AU_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(H264_AU_CAPS));

// The access units pass unchanged. After rtph264depay they declare no profile, which decoders such as
// openh264dec require in their caps: any is offered (the decoder reads the real one from the stream).
static GstCaps* gst_rgbd_link_demux_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                                   GstCaps* filter) {
  GstCaps* out = gst_caps_copy(caps);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    if (direction == GST_PAD_SRC || gst_structure_has_field(s, "profile")) continue;
    GValue list = G_VALUE_INIT, v = G_VALUE_INIT;
    gst_value_list_init(&list, 4);
    g_value_init(&v, G_TYPE_STRING);
    for (const char* profile : {"constrained-baseline", "baseline", "main", "high"}) {
      g_value_set_string(&v, profile);
      gst_value_list_append_value(&list, &v);
    }
    gst_structure_take_value(s, "profile", &list);
    g_value_unset(&v);
  }
  if (direction == GST_PAD_SRC)
    for (guint i = 0; i < gst_caps_get_size(out); ++i)
      gst_structure_remove_fields(gst_caps_get_structure(out, i), "profile", "level", nullptr);
  return caps_filtered(out, filter);
}

static void drop_depth(GstRgbdLinkDemux* self, DropKind kind, const std::string& why) {
  const guint64 dropped = codec_stats_drop(GST_ELEMENT(self), &self->stats, kind).dropped;
  uint64_t count = 0;
  int64_t span = 0;
  if (!self->warnings[int(kind)].note(g_get_monotonic_time() * 1000, &count, &span)) return;
  warn_dropped(GST_ELEMENT(self), count, span, "a frame's depth", "frames' depth", "", why, dropped, "frames");
}

// The caps of the joined frames for a depth frame's caps string: checked (they come from the network) and
// kept while they stay the same.
static bool joined_caps(GstRgbdLinkDemux* self, const DepthLinkHeader& f, std::string* why, DropKind* kind) {
  if (self->out_caps && *self->caps_text == f.caps) return true;
  GstCaps* caps = gst_caps_from_string(f.caps.c_str());
  RgbdInfo info;
  const bool parsed = caps && gst_caps_is_fixed(caps) && rgbd_info_from_caps(caps, &info, why);
  if (caps) gst_caps_unref(caps);
  if (!parsed) {
    *kind = DropKind::RejectedCaps;
    if (why->empty()) *why = "the depth frame's caps do not parse";
    return false;
  }
  *why = rgbd_stream_refusal(info.camera.id, info.width(), info.height(), RgbdStreamLimits(),
                             *self->rig ? &**self->rig : nullptr, *self->rig_source);
  if (!why->empty()) {
    *kind = DropKind::RejectedCaps;
    return false;
  }
  if (info.width() != f.width || info.height() != f.height) {
    *kind = DropKind::WrongSize;
    *why = "the depth frame's caps declare another size than its depth";
    return false;
  }
  info.planes = {Plane::Color, Plane::Depth};
  if (f.labels) info.planes.push_back(Plane::Label);
  gst_caps_replace(&self->out_caps, nullptr);
  self->out_caps = rgbd_caps_new(info);
  *self->caps_text = f.caps;
  return true;
}

// Queues a depth frame; its id in the backlog, or false (with `why`) when it is refused. Its caps are checked first, so
// that a refused camera's frames are not kept.
static bool queue_depth(GstRgbdLinkDemux* self, std::vector<uint8_t> data, guint64* id, std::string* why,
                        DropKind* kind) {
  DepthLinkHeader header;
  *kind = DropKind::Damaged;
  *why = (*self->backlog)->check(data.data(), data.size(), &header);
  if (!why->empty() || !joined_caps(self, header, why, kind)) return false;
  const size_t bytes = data.size();
  uint64_t queued = 0;
  if (!(*self->backlog)->push_checked(std::move(data), header, &queued, why)) return false;
  codec_stats_count(GST_ELEMENT(self), &self->stats, bytes, false);
  *id = queued;
  return true;
}

// Queues the access unit's depth; its id in the backlog, or false: with `why` when there is none to use, with `why`
// empty when the unit holds no picture.
static bool demux_depth(GstRgbdLinkDemux* self, GstBuffer* in, guint64* id, std::string* why, DropKind* kind) {
  GstMapInfo map;
  if (!gst_buffer_map(in, &map, GST_MAP_READ)) return false;
  std::vector<uint8_t> data;
  const size_t max_len = 3 * size_t(4096) * 2160 + 65536;
  const SeiFind found = h264_find_user_data(map.data, map.size, kDepthLinkSeiUuid, max_len, &data, why);
  const bool picture = h264_has_slice(map.data, map.size);
  gst_buffer_unmap(in, &map);
  *kind = DropKind::Damaged;
  const GstClockTime pts = GST_BUFFER_PTS(in);
  if (found == SeiFind::kFound && !picture) {  // its picture comes next, with the same timestamp
    self->pending->swap(data);
    self->pending_pts = pts;
    return false;
  }
  const bool pending = !self->pending->empty() && GST_CLOCK_TIME_IS_VALID(pts) && pts == self->pending_pts;
  if (found == SeiFind::kAbsent && picture && pending) data.swap(*self->pending);
  self->pending->clear();
  if (!data.empty()) return queue_depth(self, std::move(data), id, why, kind);
  if (found == SeiFind::kAbsent && picture) *why = "an access unit without depth";
  return false;  // kMalformed says why; parameter sets alone say nothing
}

static GstFlowReturn gst_rgbd_link_demux_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(trans);
  *outbuf = nullptr;
  GstBuffer* in;
  GstFlowReturn ret;
  if (!take_queued_input(trans, TRUE, &in, &ret)) return ret;
  std::string why;
  DropKind kind = DropKind::Damaged;
  guint64 id = 0;
  const bool queued = demux_depth(self, in, &id, &why, &kind);
  in = gst_buffer_make_writable(in);
  if (queued) {
    gst_buffer_add_rgbd_link_backlog_meta(in, *self->backlog, id, self->out_caps);
  } else if (!why.empty()) {
    drop_depth(self, kind, why);
  }
  *outbuf = in;
  return GST_FLOW_OK;
}

static gboolean gst_rgbd_link_demux_sink_event(GstBaseTransform* trans, GstEvent* event) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(trans);
  if (GST_EVENT_TYPE(event) == GST_EVENT_FLUSH_STOP) {
    (*self->backlog)->reset();
    self->pending->clear();
  }
  return codec_stats_sink_event(trans, event, &self->stats,
                                GST_BASE_TRANSFORM_CLASS(gst_rgbd_link_demux_parent_class)->sink_event);
}

static gboolean gst_rgbd_link_demux_start(GstBaseTransform* trans) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(trans);
  (*self->backlog)->reset();
  self->pending->clear();
  gst_caps_replace(&self->out_caps, nullptr);
  self->caps_text->clear();
  for (int k = 0; k < kDropKinds; ++k) self->warnings[k].reset();
  GST_OBJECT_LOCK(self);
  self->stats = CodecStats{0, 0, 0, self->stats.interval};
  const std::string rig_path = *self->rig_path;
  GST_OBJECT_UNLOCK(self);
  self->rig->reset();
  *self->rig_source = rig_path;
  if (rig_path.empty()) return TRUE;
  try {
    *self->rig = load_rig(rig_path);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, READ, ("Cannot read the rig %s", rig_path.c_str()), ("%s", e.what()));
    return FALSE;
  }
  return TRUE;
}

static void gst_rgbd_link_demux_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(object);
  if (prop_id == PROP_RIG) {
    GST_OBJECT_LOCK(self);
    *self->rig_path = g_value_get_string(value) ? g_value_get_string(value) : "";
    GST_OBJECT_UNLOCK(self);
  } else if (!codec_stats_set_property(GST_OBJECT(object), &self->stats, prop_id, value)) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_link_demux_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(object);
  if (prop_id == PROP_RIG) {
    GST_OBJECT_LOCK(self);
    g_value_set_string(value, self->rig_path->c_str());
    GST_OBJECT_UNLOCK(self);
  } else if (!codec_stats_get_property(GST_OBJECT(object), self->stats, prop_id, value)) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_link_demux_finalize(GObject* object) {
  GstRgbdLinkDemux* self = GST_RGBD_LINK_DEMUX(object);
  gst_caps_replace(&self->out_caps, nullptr);
  delete self->backlog;
  delete self->caps_text;
  delete[] self->warnings;
  delete self->pending;
  delete self->rig_path;
  delete self->rig;
  delete self->rig_source;
  G_OBJECT_CLASS(gst_rgbd_link_demux_parent_class)->finalize(object);
}

static void gst_rgbd_link_demux_class_init(GstRgbdLinkDemuxClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_rgbd_link_demux_set_property;
  gobject_class->get_property = gst_rgbd_link_demux_get_property;
  gobject_class->finalize = gst_rgbd_link_demux_finalize;
  codec_stats_install_properties(gobject_class, "Frames whose depth came whole since the element started");
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file", "Rig YAML file whose cameras and sizes the depth's caps must match (empty: any)",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D camera link demuxer", "Codec/Demuxer/Video",
      "Hangs the depth, labels and calibration an H.264 access unit carries (SEI) on it as a meta",
      "gst-vclassroom developers");
  trans_class->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_link_demux_transform_caps);
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_link_demux_generate_output);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_link_demux_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_link_demux_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_link_demux_debug, "rgbdlinkdemux", 0, "RGB-D camera link demuxer");
}

static void gst_rgbd_link_demux_init(GstRgbdLinkDemux* self) {
  self->stats = CodecStats();
  self->backlog = new std::shared_ptr<DepthLinkBacklog>(std::make_shared<DepthLinkBacklog>());
  self->caps_text = new std::string();
  self->out_caps = nullptr;
  self->warnings = new WarningLimiter[kDropKinds];
  self->pending = new std::vector<uint8_t>();
  self->pending_pts = GST_CLOCK_TIME_NONE;
  self->rig_path = new std::string();
  self->rig = new std::optional<Rig>();
  self->rig_source = new std::string();
}
