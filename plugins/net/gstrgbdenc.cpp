/**
 * SECTION:element-rgbdenc
 * @title: rgbdenc
 *
 * Compresses each video/x-rgbd frame into one buffer: colour as JPEG (libjpeg-turbo), depth and labels
 * lossless, every part checksummed (docs/rgbd-codec.md); the calibration stays in the caps
 * (video/x-rgbd-coded) so it crosses rtpgstpay.
 *
 * ## Properties
 *
 * stats-interval: the vclassroom-codec-stats message carries frames, bytes, frames-dropped and the drops by
 * kind (dropped-damaged, dropped-wrong-size, dropped-rejected-caps); docs/network.md lists its fields.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbdenc quality=80 ! rtpgstpay mtu=1400 ! rtpgstdepay ! rgbddec ! rgbddemux name=d d.color ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdenc.h"

#include <string>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/rgbd_codec.h>

#include "rgbdcoded.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_enc_debug);
#define GST_CAT_DEFAULT rgbd_enc_debug

using namespace vclassroom;

enum { PROP_0, PROP_QUALITY };
constexpr int kDefaultQuality = 90;

struct _GstRgbdEnc {
  GstBaseTransform parent;
  gint quality;  // object lock
  RgbdInfo* info;
  gboolean have_info;
  CodecStats stats;  // object lock
};

G_DEFINE_TYPE(GstRgbdEnc, gst_rgbd_enc, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(rgbdenc, "rgbdenc", GST_RANK_NONE, GST_TYPE_RGBD_ENC)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdCodedTemplateCaps));

static GstCaps* gst_rgbd_enc_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                            GstCaps* filter) {
  GstCaps* out;
  if (direction == GST_PAD_SINK) {
    out = rgbd_caps_renamed(caps, kRgbdCodedMediaType, true);
  } else {
    // Upstream may carry more planes than are coded (e.g. depth-gt): any will do.
    out = rgbd_caps_renamed(caps, kRgbdMediaType, false);
    for (guint i = 0; i < gst_caps_get_size(out); ++i) gst_structure_remove_field(gst_caps_get_structure(out, i), "planes");
  }
  return caps_filtered(out, filter);
}

static gboolean gst_rgbd_enc_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps*) {
  GstRgbdEnc* self = GST_RGBD_ENC(trans);
  std::string err;
  if (!rgbd_info_from_caps(incaps, self->info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  for (Plane p : self->info->planes) {
    if (p == Plane::Color || p == Plane::Depth || p == Plane::Label) continue;
    GST_ELEMENT_WARNING(self, STREAM, ENCODE, ("plane '%s' is not sent: rgbdenc codes colour, depth and labels",
                                               plane_name(p)),
                        (nullptr));
  }
  self->have_info = TRUE;
  return TRUE;
}

static GstFlowReturn gst_rgbd_enc_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdEnc* self = GST_RGBD_ENC(trans);
  *outbuf = nullptr;
  GstBuffer* in;
  GstFlowReturn ret;
  if (!take_queued_input(trans, self->have_info, &in, &ret)) return ret;
  GST_OBJECT_LOCK(self);
  const int quality = self->quality;
  GST_OBJECT_UNLOCK(self);
  std::vector<uint8_t> bytes;
  {
    RgbdFrame frame;
    std::string err;
    if (!frame.map(in, *self->info, GST_MAP_READ, &err)) {
      GST_ELEMENT_WARNING(self, STREAM, ENCODE, ("dropping corrupt frame: %s", err.c_str()), (nullptr));
      codec_stats_count(GST_ELEMENT(self), &self->stats, 0, true);
      gst_buffer_unref(in);
      return GST_FLOW_OK;
    }
    RgbdCodedFrame f{frame.color(), frame.depth(), frame.label()};
    encode_rgbd_frame(f, quality, &bytes);
  }
  GstBuffer* out = gst_buffer_new_allocate(nullptr, bytes.size(), nullptr);
  gst_buffer_fill(out, 0, bytes.data(), bytes.size());
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  gst_buffer_unref(in);
  codec_stats_count(GST_ELEMENT(self), &self->stats, bytes.size(), false);
  *outbuf = out;
  return GST_FLOW_OK;
}

static gboolean gst_rgbd_enc_sink_event(GstBaseTransform* trans, GstEvent* event) {
  return codec_stats_sink_event(trans, event, &GST_RGBD_ENC(trans)->stats,
                                GST_BASE_TRANSFORM_CLASS(gst_rgbd_enc_parent_class)->sink_event);
}

static gboolean gst_rgbd_enc_start(GstBaseTransform* trans) {
  GstRgbdEnc* self = GST_RGBD_ENC(trans);
  GST_OBJECT_LOCK(self);
  self->stats = CodecStats{0, 0, 0, self->stats.interval};
  GST_OBJECT_UNLOCK(self);
  return TRUE;
}

static void gst_rgbd_enc_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdEnc* self = GST_RGBD_ENC(object);
  if (prop_id == PROP_QUALITY) {
    GST_OBJECT_LOCK(self);
    self->quality = g_value_get_int(value);
    GST_OBJECT_UNLOCK(self);
  } else if (!codec_stats_set_property(GST_OBJECT(self), &self->stats, prop_id, value)) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_enc_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdEnc* self = GST_RGBD_ENC(object);
  if (prop_id == PROP_QUALITY) {
    GST_OBJECT_LOCK(self);
    g_value_set_int(value, self->quality);
    GST_OBJECT_UNLOCK(self);
  } else if (!codec_stats_get_property(GST_OBJECT(self), self->stats, prop_id, value)) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_enc_finalize(GObject* object) {
  delete GST_RGBD_ENC(object)->info;
  G_OBJECT_CLASS(gst_rgbd_enc_parent_class)->finalize(object);
}

static void gst_rgbd_enc_class_init(GstRgbdEncClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_rgbd_enc_set_property;
  gobject_class->get_property = gst_rgbd_enc_get_property;
  gobject_class->finalize = gst_rgbd_enc_finalize;
  g_object_class_install_property(
      gobject_class, PROP_QUALITY,
      g_param_spec_int("quality", "JPEG quality", "JPEG quality of the colour image (depth is always lossless)", 1,
                       100, kDefaultQuality,
                       GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  codec_stats_install_properties(gobject_class, "Frames encoded since the element started");
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D encoder", "Codec/Encoder/Video",
      "Compresses each RGB-D frame into one checksummed buffer", "gst-vclassroom developers");
  trans_class->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_enc_transform_caps);
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_enc_set_caps);
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_enc_generate_output);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_enc_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_enc_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_enc_debug, "rgbdenc", 0, "RGB-D encoder");
}

static void gst_rgbd_enc_init(GstRgbdEnc* self) {
  self->quality = kDefaultQuality;
  self->info = new RgbdInfo();
  self->have_info = FALSE;
  self->stats = CodecStats();
}
