/**
 * SECTION:element-rgbdlinkmux
 * @title: rgbdlinkmux
 *
 * The camera side of the H.264 camera link (docs/network.md): after x264enc, puts each frame's depth, labels
 * and calibration (the meta rgbdlinksplit attached to its colour) into the frame's own H.264 access unit, as
 * a "VCDL" depth frame in an SEI user-data message that every H.264 decoder skips. Depth is coded across time
 * with an error of at most floor(depth-tolerance x z^2) mm at z metres (0: lossless); a depth key frame goes
 * with every IDR picture (x264enc's key-int-max, and the key frames a server asks for with RTCP PLI/FIR) and
 * at least every key-interval frames.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=30 ! rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast key-int-max=60 ! video/x-h264,profile=constrained-baseline ! rgbdlinkmux depth-tolerance=2.8 ! rgbdlinkdemux ! avdec_h264 max-threads=1 ! videoconvert ! rgbdlinkjoin ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdlinkmux.h"

#include <cmath>
#include <string>
#include <vector>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/depth_link.h>
#include <gst/vclassroom/net/h264_sei.h>

#include "rgbdcoded.h"
#include "rgbdlinkmeta.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_link_mux_debug);
#define GST_CAT_DEFAULT rgbd_link_mux_debug

using namespace vclassroom;

enum { PROP_0, PROP_TOLERANCE, PROP_KEY_INTERVAL };
constexpr double kDefaultTolerance = kDefaultDepthTolerance / 100.0;
constexpr guint kDefaultKeyInterval = 60;

struct _GstRgbdLinkMux {
  GstBaseTransform parent;
  double tolerance;    // object lock
  guint key_interval;  // object lock
  CodecStats stats;    // object lock
  // Streaming thread only:
  DepthLinkEncoder* encoder;
  RgbdInfo* info;
  GstCaps* info_caps;
  std::string* caps_text;  // info_caps serialised, as each depth frame carries it
  guint since_key;
  gboolean warned_no_meta;
};

G_DEFINE_TYPE(GstRgbdLinkMux, gst_rgbd_link_mux, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(rgbdlinkmux, "rgbdlinkmux", GST_RANK_NONE, GST_TYPE_RGBD_LINK_MUX)

#define H264_AU_CAPS "video/x-h264, stream-format=(string)byte-stream, alignment=(string)au"
static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(H264_AU_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(H264_AU_CAPS));

// Codes the meta's depth into the access unit `in`; false (with `why`) when it cannot.
static bool mux_depth(GstRgbdLinkMux* self, GstBuffer* in, GstRgbdLinkMeta* meta, std::vector<uint8_t>* au,
                      std::string* why) {
  if (!self->info_caps || !gst_caps_is_equal(self->info_caps, meta->caps)) {
    if (!rgbd_info_from_caps(meta->caps, self->info, why)) return false;
    gst_caps_replace(&self->info_caps, meta->caps);
    gchar* text = gst_caps_to_string(meta->caps);
    *self->caps_text = text;
    g_free(text);
  }
  GST_OBJECT_LOCK(self);
  const auto tolerance = uint16_t(std::lround(self->tolerance * 100));
  const guint interval = self->key_interval;
  GST_OBJECT_UNLOCK(self);
  RgbdFrame frame;
  if (!frame.map(meta->planes, *self->info, GST_MAP_READ, why)) return false;
  GstMapInfo map;
  if (!gst_buffer_map(in, &map, GST_MAP_READ)) {
    *why = "cannot map the access unit";
    return false;
  }
  const bool idr = h264_is_idr(map.data, map.size);
  const bool key = idr || self->since_key + 1 >= interval;
  std::vector<uint8_t> depth;
  try {
    self->encoder->encode(frame.depth(), frame.label(), *self->caps_text, key, tolerance, &depth);
    h264_insert_user_data(map.data, map.size, kDepthLinkSeiUuid, depth.data(), depth.size(), au);
  } catch (const Error& e) {
    *why = e.what();
  }
  gst_buffer_unmap(in, &map);
  if (!why->empty()) return false;
  self->since_key = key ? 0 : self->since_key + 1;
  codec_stats_count(GST_ELEMENT(self), &self->stats, depth.size(), false);
  return true;
}

static GstFlowReturn gst_rgbd_link_mux_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdLinkMux* self = GST_RGBD_LINK_MUX(trans);
  *outbuf = nullptr;
  GstBuffer* in;
  GstFlowReturn ret;
  if (!take_queued_input(trans, TRUE, &in, &ret)) return ret;
  GstRgbdLinkMeta* meta = gst_buffer_get_rgbd_link_meta(in);
  std::vector<uint8_t> au;
  std::string why;
  if (!meta) {
    why = "an access unit without its RGB-D frame (rgbdlinksplit must come before the encoder)";
  } else if (mux_depth(self, in, meta, &au, &why)) {
    // The access unit's bytes handed over as they are, not copied again.
    auto* bytes = new std::vector<uint8_t>(std::move(au));
    GstBuffer* out = gst_buffer_new_wrapped_full(GstMemoryFlags(0), bytes->data(), bytes->size(), 0, bytes->size(),
                                                 bytes, [](gpointer p) { delete static_cast<std::vector<uint8_t>*>(p); });
    gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
    gst_buffer_unref(in);
    *outbuf = out;
    return GST_FLOW_OK;
  }
  // The colour goes on without depth (the server drops it): the H.264 stream must stay whole.
  if (!self->warned_no_meta) {
    GST_ELEMENT_WARNING(self, STREAM, ENCODE, ("colour sent without depth: %s", why.c_str()), (nullptr));
    self->warned_no_meta = TRUE;
  }
  codec_stats_count(GST_ELEMENT(self), &self->stats, 0, true);
  in = gst_buffer_make_writable(in);
  if (meta) gst_buffer_remove_meta(in, &meta->meta);
  *outbuf = in;
  return GST_FLOW_OK;
}

static gboolean gst_rgbd_link_mux_sink_event(GstBaseTransform* trans, GstEvent* event) {
  return codec_stats_sink_event(trans, event, &GST_RGBD_LINK_MUX(trans)->stats,
                                GST_BASE_TRANSFORM_CLASS(gst_rgbd_link_mux_parent_class)->sink_event);
}

static gboolean gst_rgbd_link_mux_start(GstBaseTransform* trans) {
  GstRgbdLinkMux* self = GST_RGBD_LINK_MUX(trans);
  *self->encoder = DepthLinkEncoder();
  self->since_key = 0;
  self->warned_no_meta = FALSE;
  gst_caps_replace(&self->info_caps, nullptr);
  GST_OBJECT_LOCK(self);
  self->stats = CodecStats{0, 0, 0, self->stats.interval};
  GST_OBJECT_UNLOCK(self);
  return TRUE;
}

static void gst_rgbd_link_mux_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdLinkMux* self = GST_RGBD_LINK_MUX(object);
  GST_OBJECT_LOCK(self);
  if (prop_id == PROP_TOLERANCE) {
    self->tolerance = g_value_get_double(value);
  } else if (prop_id == PROP_KEY_INTERVAL) {
    self->key_interval = g_value_get_uint(value);
  } else {
    GST_OBJECT_UNLOCK(self);
    if (!codec_stats_set_property(GST_OBJECT(self), &self->stats, prop_id, value))
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
    return;
  }
  GST_OBJECT_UNLOCK(self);
}

static void gst_rgbd_link_mux_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdLinkMux* self = GST_RGBD_LINK_MUX(object);
  GST_OBJECT_LOCK(self);
  if (prop_id == PROP_TOLERANCE) {
    g_value_set_double(value, self->tolerance);
  } else if (prop_id == PROP_KEY_INTERVAL) {
    g_value_set_uint(value, self->key_interval);
  } else {
    GST_OBJECT_UNLOCK(self);
    if (!codec_stats_get_property(GST_OBJECT(self), self->stats, prop_id, value))
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
    return;
  }
  GST_OBJECT_UNLOCK(self);
}

static void gst_rgbd_link_mux_finalize(GObject* object) {
  GstRgbdLinkMux* self = GST_RGBD_LINK_MUX(object);
  gst_caps_replace(&self->info_caps, nullptr);
  delete self->caps_text;
  delete self->encoder;
  delete self->info;
  G_OBJECT_CLASS(gst_rgbd_link_mux_parent_class)->finalize(object);
}

static void gst_rgbd_link_mux_class_init(GstRgbdLinkMuxClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_rgbd_link_mux_set_property;
  gobject_class->get_property = gst_rgbd_link_mux_get_property;
  gobject_class->finalize = gst_rgbd_link_mux_finalize;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(gobject_class, PROP_TOLERANCE,
      g_param_spec_double("depth-tolerance", "Depth tolerance",
                          "Largest depth error in mm at 1 m; it grows with z^2 (2.8: 11 mm at 2 m); 0: lossless", 0,
                          655.35, kDefaultTolerance, flags));
  g_object_class_install_property(gobject_class, PROP_KEY_INTERVAL,
      g_param_spec_uint("key-interval", "Key interval",
                        "Most frames between depth key frames (one also goes with every IDR picture)", 1, 100000,
                        kDefaultKeyInterval, flags));
  codec_stats_install_properties(gobject_class, "Frames whose depth was sent since the element started");
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D camera link muxer", "Codec/Muxer/Video",
      "Puts each frame's depth, labels and calibration into its H.264 access unit (SEI)",
      "gst-vclassroom developers");
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_link_mux_generate_output);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_link_mux_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_link_mux_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_link_mux_debug, "rgbdlinkmux", 0, "RGB-D camera link muxer");
}

static void gst_rgbd_link_mux_init(GstRgbdLinkMux* self) {
  self->tolerance = kDefaultTolerance;
  self->key_interval = kDefaultKeyInterval;
  self->stats = CodecStats();
  self->encoder = new DepthLinkEncoder();
  self->info = new RgbdInfo();
  self->info_caps = nullptr;
  self->caps_text = new std::string();
}
