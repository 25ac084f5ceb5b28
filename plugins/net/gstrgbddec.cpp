// rgbddec: the inverse of rgbdenc. A damaged or truncated frame is dropped
// with a warning; the stream goes on with the next good one.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbddec.h"

#include <string>

#include <gst/vclassroom/rgbd.h>
#include <gst/vclassroom/rgbd_codec.h>

#include "rgbdcoded.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_dec_debug);
#define GST_CAT_DEFAULT rgbd_dec_debug

using namespace vclassroom;

struct _GstRgbdDec {
  GstBaseTransform parent;
  RgbdInfo* info;  // of the output
  gboolean have_info;
  CodecStats stats;  // object lock
};

G_DEFINE_TYPE(GstRgbdDec, gst_rgbd_dec, GST_TYPE_BASE_TRANSFORM)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdCodedTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static GstCaps* gst_rgbd_dec_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                            GstCaps* filter) {
  GstCaps* out = direction == GST_PAD_SINK ? rgbd_caps_renamed(caps, kRgbdMediaType, false)
                                           : rgbd_caps_renamed(caps, kRgbdCodedMediaType, true);
  return caps_filtered(out, filter);
}

static gboolean gst_rgbd_dec_set_caps(GstBaseTransform* trans, GstCaps*, GstCaps* outcaps) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  std::string err;
  if (!rgbd_info_from_caps(outcaps, self->info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  self->have_info = TRUE;
  return TRUE;
}

static GstFlowReturn gst_rgbd_dec_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  *outbuf = nullptr;
  GstBuffer* in;
  GstFlowReturn ret;
  if (!take_queued_input(trans, self->have_info, &in, &ret)) return ret;
  const RgbdInfo& info = *self->info;
  RgbdCodedFrame f;
  std::string err;
  GstMapInfo map;
  bool ok = gst_buffer_map(in, &map, GST_MAP_READ);
  if (ok) {
    ok = decode_rgbd_frame(map.data, map.size, info.width(), info.height(), &f, &err);
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
    const guint64 dropped = codec_stats_count(GST_ELEMENT(self), &self->stats, coded_size, true).dropped;
    GST_ELEMENT_WARNING(self, STREAM, DECODE,
                        ("dropping a damaged frame at %" GST_TIME_FORMAT ": %s", GST_TIME_ARGS(GST_BUFFER_PTS(in)),
                         err.c_str()),
                        ("%" G_GUINT64_FORMAT " dropped so far", dropped));
    gst_buffer_unref(in);
    return GST_FLOW_OK;
  }
  GstBuffer* out = rgbd_buffer_new(info);
  {
    RgbdFrame frame;
    if (!frame.map(out, info, GST_MAP_WRITE, &err)) {
      gst_buffer_unref(out);
      gst_buffer_unref(in);
      GST_ELEMENT_ERROR(self, CORE, FAILED, ("%s", err.c_str()), (nullptr));
      return GST_FLOW_ERROR;
    }
    f.color.copyTo(frame.color());
    f.depth.copyTo(frame.depth());
    if (info.has(Plane::Label)) f.label.copyTo(frame.label());
  }
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  gst_buffer_unref(in);
  codec_stats_count(GST_ELEMENT(self), &self->stats, coded_size, false);
  *outbuf = out;
  return GST_FLOW_OK;
}

static gboolean gst_rgbd_dec_sink_event(GstBaseTransform* trans, GstEvent* event) {
  return codec_stats_sink_event(trans, event, &GST_RGBD_DEC(trans)->stats,
                                GST_BASE_TRANSFORM_CLASS(gst_rgbd_dec_parent_class)->sink_event);
}

static gboolean gst_rgbd_dec_start(GstBaseTransform* trans) {
  GstRgbdDec* self = GST_RGBD_DEC(trans);
  GST_OBJECT_LOCK(self);
  self->stats = CodecStats{0, 0, 0, self->stats.interval};
  GST_OBJECT_UNLOCK(self);
  return TRUE;
}

static void gst_rgbd_dec_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdDec* self = GST_RGBD_DEC(object);
  if (!codec_stats_set_property(GST_OBJECT(self), &self->stats, prop_id, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
}

static void gst_rgbd_dec_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdDec* self = GST_RGBD_DEC(object);
  if (!codec_stats_get_property(GST_OBJECT(self), self->stats, prop_id, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
}

static void gst_rgbd_dec_finalize(GObject* object) {
  delete GST_RGBD_DEC(object)->info;
  G_OBJECT_CLASS(gst_rgbd_dec_parent_class)->finalize(object);
}

static void gst_rgbd_dec_class_init(GstRgbdDecClass* klass) {
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  G_OBJECT_CLASS(klass)->finalize = gst_rgbd_dec_finalize;
  G_OBJECT_CLASS(klass)->set_property = gst_rgbd_dec_set_property;
  G_OBJECT_CLASS(klass)->get_property = gst_rgbd_dec_get_property;
  codec_stats_install_properties(G_OBJECT_CLASS(klass), "Frames decoded since the element started");
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "RGB-D decoder", "Codec/Decoder/Video",
      "Decodes rgbdenc's frames back to video/x-rgbd (depth and labels bit-exact); a damaged or truncated frame "
      "is dropped with a warning and the stream goes on. Example: "
      "gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbdenc ! rgbddec ! rgbddemux name=d d.depth ! "
      "depthcolorize ! videoconvert ! autovideosink",
      "gst-vclassroom developers");
  trans_class->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_dec_transform_caps);
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_dec_set_caps);
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_dec_generate_output);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_dec_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_dec_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_dec_debug, "rgbddec", 0, "RGB-D decoder");
}

static void gst_rgbd_dec_init(GstRgbdDec* self) {
  self->info = new RgbdInfo();
  self->have_info = FALSE;
  self->stats = CodecStats();
}
