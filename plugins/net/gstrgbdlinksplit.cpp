/**
 * SECTION:element-rgbdlinksplit
 * @title: rgbdlinksplit
 *
 * The camera side of the H.264 camera link (docs/network.md): passes each video/x-rgbd frame's colour on as
 * plain video for x264enc — I420 (BT.601, converted here: videoconvert after it then passes it through, where
 * its general path cost two thirds of the colour's CPU time) or, with format=RGB, the camera's RGB for a
 * videoconvert to other formats — and keeps the whole frame (depth, labels, calibration) on it as a meta that
 * the encoder carries to its access unit, where rgbdlinkmux puts the depth into the H.264 stream. Colour and
 * depth of one instant therefore travel in one access unit.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=30 ! rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast key-int-max=60 ! video/x-h264,profile=constrained-baseline ! rgbdlinkmux ! rtph264pay mtu=1400 ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdlinksplit.h"

#include <cstring>
#include <string>

#include <gst/video/video.h>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/colour_i420.h>

#include "rgbdcoded.h"
#include "rgbdlinkmeta.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_link_split_debug);
#define GST_CAT_DEFAULT rgbd_link_split_debug

using namespace vclassroom;

struct _GstRgbdLinkSplit {
  GstBaseTransform parent;
  RgbdInfo* info;
  GstCaps* caps;  // the rgbd caps, for the meta
  gboolean have_info;
  gboolean rgb;       // property "format": RGB rather than I420
  GstVideoInfo out;   // the negotiated output
};

enum { PROP_0, PROP_FORMAT };

G_DEFINE_TYPE(GstRgbdLinkSplit, gst_rgbd_link_split, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(rgbdlinksplit, "rgbdlinksplit", GST_RANK_NONE, GST_TYPE_RGBD_LINK_SPLIT)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS("video/x-raw, format=(string){ I420, RGB }, width=(int)[1, 65535], "
                                                        "height=(int)[1, 65535], framerate=(fraction)[0/1, MAX]"));

// Width, height and frame rate carry over; the rest is one side's own.
static GstCaps* gst_rgbd_link_split_transform_caps(GstBaseTransform* trans, GstPadDirection direction,
                                                   GstCaps* caps, GstCaps* filter) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(trans);
  GST_OBJECT_LOCK(self);
  const bool rgb = self->rgb;
  GST_OBJECT_UNLOCK(self);
  GstCaps* out = gst_caps_new_empty();
  for (guint i = 0; i < gst_caps_get_size(caps); ++i) {
    const GstStructure* in = gst_caps_get_structure(caps, i);
    GstStructure* s = gst_structure_new_empty(direction == GST_PAD_SINK ? "video/x-raw" : kRgbdMediaType);
    if (direction == GST_PAD_SINK && rgb) gst_structure_set(s, "format", G_TYPE_STRING, "RGB", nullptr);
    if (direction == GST_PAD_SINK && !rgb)  // what rgb_to_i420() makes
      gst_structure_set(s, "format", G_TYPE_STRING, "I420", "colorimetry", G_TYPE_STRING, "bt601", "chroma-site",
                        G_TYPE_STRING, "jpeg", nullptr);
    for (const char* f : {"width", "height", "framerate"})
      if (const GValue* v = gst_structure_get_value(in, f)) gst_structure_set_value(s, f, v);
    gst_caps_append_structure(out, s);
  }
  return caps_filtered(out, filter);
}

static gboolean gst_rgbd_link_split_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps* outcaps) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(trans);
  std::string err;
  if (!rgbd_info_from_caps(incaps, self->info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  if (!gst_video_info_from_caps(&self->out, outcaps)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("output caps that are not video"), (nullptr));
    return FALSE;
  }
  gst_caps_replace(&self->caps, incaps);
  self->have_info = TRUE;
  return TRUE;
}

static GstFlowReturn gst_rgbd_link_split_generate_output(GstBaseTransform* trans, GstBuffer** outbuf) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(trans);
  *outbuf = nullptr;
  GstBuffer* in;
  GstFlowReturn ret;
  if (!take_queued_input(trans, self->have_info, &in, &ret)) return ret;
  RgbdFrame frame;
  std::string err;
  if (!frame.map(in, *self->info, GST_MAP_READ, &err)) {
    GST_ELEMENT_WARNING(self, STREAM, ENCODE, ("dropping corrupt frame: %s", err.c_str()), (nullptr));
    gst_buffer_unref(in);
    return GST_FLOW_OK;
  }
  const cv::Mat color = frame.color();
  const GstVideoInfo& vinfo = self->out;
  GstBuffer* out = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&vinfo), nullptr);
  GstMapInfo map;
  gst_buffer_map(out, &map, GST_MAP_WRITE);
  auto plane = [&](int p) { return map.data + GST_VIDEO_INFO_PLANE_OFFSET(&vinfo, p); };
  auto stride = [&](int p) { return GST_VIDEO_INFO_PLANE_STRIDE(&vinfo, p); };
  if (GST_VIDEO_INFO_FORMAT(&vinfo) == GST_VIDEO_FORMAT_I420) {
    rgb_to_i420(color.data, int(color.step), color.cols, color.rows, plane(0), stride(0), plane(1), stride(1),
                plane(2), stride(2));
  } else {
    for (int y = 0; y < color.rows; ++y)
      std::memcpy(plane(0) + size_t(y) * size_t(stride(0)), color.ptr(y), size_t(color.cols) * 3);
  }
  gst_buffer_unmap(out, &map);
  frame.unmap();
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  gst_buffer_add_rgbd_link_meta(out, in, self->caps);
  gst_buffer_unref(in);
  *outbuf = out;
  return GST_FLOW_OK;
}

static void gst_rgbd_link_split_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(object);
  if (prop_id != PROP_FORMAT) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
    return;
  }
  const char* format = g_value_get_string(value);
  if (format != nullptr && g_ascii_strcasecmp(format, "RGB") != 0 && g_ascii_strcasecmp(format, "I420") != 0)
    GST_WARNING_OBJECT(self, "format '%s' is neither I420 nor RGB: I420 it is", format);
  GST_OBJECT_LOCK(self);
  self->rgb = format != nullptr && g_ascii_strcasecmp(format, "RGB") == 0;
  GST_OBJECT_UNLOCK(self);
  gst_base_transform_reconfigure_src(GST_BASE_TRANSFORM(self));
}

static void gst_rgbd_link_split_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(object);
  if (prop_id != PROP_FORMAT) {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
    return;
  }
  GST_OBJECT_LOCK(self);
  g_value_set_string(value, self->rgb ? "RGB" : "I420");
  GST_OBJECT_UNLOCK(self);
}

static gboolean gst_rgbd_link_split_stop(GstBaseTransform* trans) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(trans);
  gst_caps_replace(&self->caps, nullptr);
  self->have_info = FALSE;
  return TRUE;
}

static void gst_rgbd_link_split_finalize(GObject* object) {
  GstRgbdLinkSplit* self = GST_RGBD_LINK_SPLIT(object);
  gst_caps_replace(&self->caps, nullptr);
  delete self->info;
  G_OBJECT_CLASS(gst_rgbd_link_split_parent_class)->finalize(object);
}

static void gst_rgbd_link_split_class_init(GstRgbdLinkSplitClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->finalize = gst_rgbd_link_split_finalize;
  gobject_class->set_property = gst_rgbd_link_split_set_property;
  gobject_class->get_property = gst_rgbd_link_split_get_property;
  g_object_class_install_property(gobject_class, PROP_FORMAT,
      g_param_spec_string("format", "Format", "The colour's format: I420 (converted here, BT.601, for x264enc) or "
                          "RGB (the camera's own, for a videoconvert to other formats)", "I420",
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D camera link splitter", "Filter/Converter/Video",
      "Passes an RGB-D frame's colour on as I420 (or RGB) video, the frame riding along as a meta for rgbdlinkmux",
      "gst-vclassroom developers");
  trans_class->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_link_split_transform_caps);
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_link_split_set_caps);
  trans_class->generate_output = GST_DEBUG_FUNCPTR(gst_rgbd_link_split_generate_output);
  trans_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_link_split_stop);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_link_split_debug, "rgbdlinksplit", 0, "RGB-D camera link splitter");
}

static void gst_rgbd_link_split_init(GstRgbdLinkSplit* self) {
  self->info = new RgbdInfo();
  self->caps = nullptr;
  self->have_info = FALSE;
  self->rgb = FALSE;
  gst_video_info_init(&self->out);
}
