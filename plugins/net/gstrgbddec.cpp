/**
 * SECTION:element-rgbddec
 * @title: rgbddec
 *
 * The inverse of rgbdenc (docs/network.md): video/x-rgbd-coded back to video/x-rgbd, depth and labels
 * bit-exact.
 *
 * Caps arrive from the network (in-band through rtpgstdepay), so they are checked before anything is
 * allocated: caps beyond max-width, max-height or max-pixels, caps that do not parse, or a camera the rig
 * (when given) lacks or has at another size are refused with a warning, and that camera's frames are dropped
 * until acceptable caps come. A damaged, truncated or wrongly sized frame is dropped with a warning and the
 * stream goes on with the next good one. Warnings are rate-limited per kind (the first at once, then one per
 * 5 s with the count), and the drops are counted by kind in the "vclassroom-codec-stats" messages.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbdenc ! rgbddec ! rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! autovideosink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbddec.h"

#include <optional>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/rgbd_codec.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/core/warning_limiter.h>

#include "rgbdcoded.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_dec_debug);
#define GST_CAT_DEFAULT rgbd_dec_debug

using namespace vclassroom;

enum { PROP_0, PROP_MAX_WIDTH, PROP_MAX_HEIGHT, PROP_MAX_PIXELS, PROP_RIG };

namespace {

struct DecState {  // under the base's lock
  RgbdStreamLimits limits;
  std::string rig_path;
  std::optional<Rig> rig;  // loaded at start
  // Why the current caps were refused ("" when accepted), and their camera.
  std::string caps_refused;
  int refused_camera = -1;
  WarningLimiter warnings[kDropKinds];
  WarningLimiter caps_warnings;  // refused caps events (a sender may alternate them)
};

}  // namespace

struct _GstRgbdDec {
  GstRgbdFilter parent;
  CodecStats stats;  // object lock
  DecState* st;
};

G_DEFINE_TYPE(GstRgbdDec, gst_rgbd_dec, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(rgbddec, "rgbddec", GST_RANK_NONE, GST_TYPE_RGBD_DEC);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdCodedTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

// Drops a frame: counts it by kind and posts a warning when the limiter says
// one is due ("dropped 37 damaged frames from camera 2 in the last 5 s; the last: ...").
static void drop_frame(GstRgbdDec* self, DropKind kind, int camera_id, const std::string& why) {
  const guint64 dropped = codec_stats_drop(GST_ELEMENT(self), &self->stats, kind).dropped;
  uint64_t count = 0;
  int64_t span = 0;
  bool due;
  {
    const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
    due = self->st->warnings[int(kind)].note(g_get_monotonic_time() * 1000, &count, &span);
  }
  if (!due) return;
  static const char* const singular[kDropKinds] = {"a damaged frame", "a frame of the wrong size",
                                                   "a frame with refused caps"};
  static const char* const plural[kDropKinds] = {"damaged frames", "frames of the wrong size",
                                                 "frames with refused caps"};
  const std::string source = camera_id >= 0 ? "camera " + std::to_string(camera_id) : "";
  warn_dropped(GST_ELEMENT(self), count, span, singular[int(kind)], plural[int(kind)], source, why, dropped, "frames");
}

// Why `caps` (video/x-rgbd-coded from upstream) cannot be decoded, "" when
// they can. Checked before anything is allocated for their size.
static std::string caps_problem(GstRgbdDec* self, GstCaps* caps, int* camera_id) {
  *camera_id = -1;
  const GstStructure* s = gst_caps_get_structure(caps, 0);
  if (s) gst_structure_get_int(s, "camera-id", camera_id);
  GstCaps* raw = rgbd_caps_renamed(caps, kRgbdMediaType, false);
  RgbdInfo info;
  std::string err;
  const bool ok = gst_caps_is_fixed(raw) && rgbd_info_from_caps(raw, &info, &err);
  gst_caps_unref(raw);
  if (!ok) return "unusable caps (" + (err.empty() ? std::string("not fixed") : err) + ")";
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
  const DecState* st = self->st;
  return rgbd_stream_refusal(info.camera.id, info.width(), info.height(), st->limits,
                             st->rig ? &*st->rig : nullptr, st->rig_path);
}

// Records whether `caps` are refused; true when they are.
static bool refuse_caps(GstRgbdDec* self, GstCaps* caps) {
  int camera_id;
  const std::string why = caps_problem(self, caps, &camera_id);
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
  self->st->caps_refused = why;
  self->st->refused_camera = camera_id;
  return !why.empty();
}

static GstCaps* gst_rgbd_dec_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                            GstCaps* filter) {
  GstCaps* out = direction == GST_PAD_SINK ? rgbd_caps_renamed(caps, kRgbdMediaType, false)
                                           : rgbd_caps_renamed(caps, kRgbdCodedMediaType, true);
  return caps_filtered(out, filter);
}

static gboolean gst_rgbd_dec_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps* outcaps) {
  // Refused caps never get here through the caps event; they may through a
  // renegotiation (they stay the sink pad's current caps): keep what we had.
  if (refuse_caps(GST_RGBD_DEC(trans), incaps)) return TRUE;
  return GST_BASE_TRANSFORM_CLASS(gst_rgbd_dec_parent_class)->set_caps(trans, incaps, outcaps);
}

static GstFlowReturn gst_rgbd_dec_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  *outbuf = nullptr;
  std::string refused;
  int refused_camera;
  {
    const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
    refused = self->st->caps_refused;
    refused_camera = self->st->refused_camera;
  }
  if (!refused.empty()) {
    if (GstBuffer* in = trans->queued_buf) {
      trans->queued_buf = nullptr;
      gst_buffer_unref(in);
      drop_frame(self, DropKind::RejectedCaps, refused_camera, refused);
    }
    return GST_FLOW_OK;
  }
  GstBuffer* in;
  GstFlowReturn ret;
  GstRgbdFilter* filter = GST_RGBD_FILTER(trans);
  if (!take_queued_input(trans, rgbd_filter_negotiated(filter), &in, &ret)) return ret;
  const RgbdInfo& info = rgbd_filter_out_info(filter);
  RgbdCodedFrame f;
  std::string err;
  RgbdFrameFault fault = RgbdFrameFault::kDamaged;
  GstMapInfo map;
  bool ok = gst_buffer_map(in, &map, GST_MAP_READ);
  if (ok) {
    // The frame's header must declare the caps' size; the decoder checks
    // that before it allocates anything.
    ok = decode_rgbd_frame(map.data, map.size, info.width(), info.height(), &f, &err, &fault);
    gst_buffer_unmap(in, &map);
  } else {
    err = "cannot map the input buffer";
  }
  if (ok && info.has(Plane::Label) && f.label.empty()) {
    ok = false;
    err = "frame lacks the label plane its caps announce";
  }
  const gsize coded_size = gst_buffer_get_size(in);
  if (!ok) {
    drop_frame(self, fault == RgbdFrameFault::kWrongSize ? DropKind::WrongSize : DropKind::Damaged, info.camera.id,
               err + " (at " + std::to_string(GST_BUFFER_PTS(in)) + " ns)");
    gst_buffer_unref(in);
    return GST_FLOW_OK;
  }
  GstBuffer* out = rgbd_buffer_with_planes(info, {{Plane::Color, f.color}, {Plane::Depth, f.depth}, {Plane::Label, f.label}},
                                           &err);
  if (!out) {
    gst_buffer_unref(in);
    GST_ELEMENT_ERROR(self, CORE, FAILED, ("%s: %s", GST_OBJECT_NAME(self), err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  gst_buffer_unref(in);
  codec_stats_count(GST_ELEMENT(self), &self->stats, coded_size, false);
  *outbuf = out;
  return GST_FLOW_OK;
}

static gboolean gst_rgbd_dec_sink_event(GstBaseTransform* trans, GstEvent* event) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    if (refuse_caps(self, caps)) {
      // Accepted (so upstream goes on) but not passed on: downstream keeps
      // its caps and this camera's frames are dropped until good caps come.
      std::string why;
      int camera;
      uint64_t count = 0;
      int64_t span = 0;
      bool due;
      {
        const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
        why = self->st->caps_refused;
        camera = self->st->refused_camera;
        due = self->st->caps_warnings.note(g_get_monotonic_time() * 1000, &count, &span);
      }
      if (due && count == 1)
        GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                            ("refusing the caps of camera %d: %s; its frames are dropped until acceptable caps come",
                             camera, why.c_str()),
                            (nullptr));
      else if (due)
        GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                            ("refused %s; the last: %s",
                             describe_occurrences(count, "a caps event", "caps events",
                                                  "camera " + std::to_string(camera), span)
                                 .c_str(),
                             why.c_str()),
                            (nullptr));
      // The refused caps stay the sink pad's current caps; a pending
      // reconfiguration would negotiate them with downstream at the next buffer.
      gst_pad_check_reconfigure(GST_BASE_TRANSFORM_SRC_PAD(trans));
      gst_event_unref(event);
      return TRUE;
    }
  }
  return codec_stats_sink_event(trans, event, &self->stats,
                                GST_BASE_TRANSFORM_CLASS(gst_rgbd_dec_parent_class)->sink_event);
}

static gboolean gst_rgbd_dec_start(GstBaseTransform* trans) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  GST_OBJECT_LOCK(self);
  self->stats = CodecStats{0, 0, 0, self->stats.interval};
  GST_OBJECT_UNLOCK(self);
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
  DecState* st = self->st;
  st->caps_refused.clear();
  for (auto& w : st->warnings) w.reset();
  st->caps_warnings.reset();
  st->rig.reset();
  return rgbd_filter_guard_setup(GST_RGBD_FILTER(self), "property rig", [st] {
    if (!st->rig_path.empty()) st->rig = load_rig(st->rig_path);
    return true;
  });
}

static void gst_rgbd_dec_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdDec* self = GST_RGBD_DEC(object);
  if (codec_stats_set_property(GST_OBJECT(self), &self->stats, prop_id, value)) return;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
  switch (prop_id) {
    case PROP_MAX_WIDTH: self->st->limits.max_width = g_value_get_int(value); break;
    case PROP_MAX_HEIGHT: self->st->limits.max_height = g_value_get_int(value); break;
    case PROP_MAX_PIXELS: self->st->limits.max_pixels = g_value_get_uint64(value); break;
    case PROP_RIG: self->st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_dec_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdDec* self = GST_RGBD_DEC(object);
  if (codec_stats_get_property(GST_OBJECT(self), self->stats, prop_id, value)) return;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(self));
  switch (prop_id) {
    case PROP_MAX_WIDTH: g_value_set_int(value, self->st->limits.max_width); break;
    case PROP_MAX_HEIGHT: g_value_set_int(value, self->st->limits.max_height); break;
    case PROP_MAX_PIXELS: g_value_set_uint64(value, self->st->limits.max_pixels); break;
    case PROP_RIG: g_value_set_string(value, self->st->rig_path.c_str()); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_dec_finalize(GObject* object) {
  delete GST_RGBD_DEC(object)->st;
  G_OBJECT_CLASS(gst_rgbd_dec_parent_class)->finalize(object);
}

static void gst_rgbd_dec_class_init(GstRgbdDecClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->finalize = gst_rgbd_dec_finalize;
  gobject_class->set_property = gst_rgbd_dec_set_property;
  gobject_class->get_property = gst_rgbd_dec_get_property;
  codec_stats_install_properties(gobject_class, "Frames decoded since the element started");
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_MAX_WIDTH,
      g_param_spec_int("max-width", "Largest width", "Caps wider than this are refused (frames dropped, warning)", 1,
                       kMaxImageSide, RgbdStreamLimits().max_width, ready));
  g_object_class_install_property(
      gobject_class, PROP_MAX_HEIGHT,
      g_param_spec_int("max-height", "Largest height", "Caps higher than this are refused (frames dropped, warning)",
                       1, kMaxImageSide, RgbdStreamLimits().max_height, ready));
  g_object_class_install_property(
      gobject_class, PROP_MAX_PIXELS,
      g_param_spec_uint64("max-pixels", "Largest frame", "Caps of more pixels (width x height) than this are refused",
                          1, guint64(kMaxImageSide) * kMaxImageSide, RgbdStreamLimits().max_pixels, ready));
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file", "Rig YAML file whose cameras and sizes caps must match (empty: any)", "",
                          ready));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D decoder", "Codec/Decoder/Video",
                                        "Decodes rgbdenc's frames back to video/x-rgbd, dropping refused or damaged "
                                        "frames with rate-limited warnings.",
                                        "gst-vclassroom developers");
  // All the work is in generate_output, which allocates the decoded frames itself: without transform
  // functions GstBaseTransform makes no buffer pool for them and passes allocation queries through.
  trans_class->transform = nullptr;
  trans_class->transform_ip = nullptr;
  trans_class->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_dec_transform_caps);
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_dec_set_caps);
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_dec_generate_output);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_dec_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_dec_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_dec_debug, "rgbddec", 0, "RGB-D decoder");
}

static void gst_rgbd_dec_init(GstRgbdDec* self) {
  self->stats = CodecStats();
  self->st = new DecState();
}
