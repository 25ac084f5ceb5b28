/**
 * SECTION:element-depthcolorize
 * @title: depthcolorize
 *
 * Draws a depth map (GRAY16_LE, mm) as RGB with the turbo colour map: near warm, far cool, no measurement
 * (0) black.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstdepthcolorize.h"

#include <gst/vclassroom/core/visualize.h>

GST_DEBUG_CATEGORY_STATIC(depth_colorize_debug);
#define GST_CAT_DEFAULT depth_colorize_debug

enum { PROP_0, PROP_MIN_DEPTH, PROP_MAX_DEPTH };
constexpr guint kDefaultMin = 500, kDefaultMax = 6000;

struct _GstDepthColorize {
  GstVideoFilter parent;
  guint min_mm;  // guarded by the object lock
  guint max_mm;
};

G_DEFINE_TYPE(GstDepthColorize, gst_depth_colorize, GST_TYPE_VIDEO_FILTER)
GST_ELEMENT_REGISTER_DEFINE(depthcolorize, "depthcolorize", GST_RANK_NONE, GST_TYPE_DEPTH_COLORIZE)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY16_LE")));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGB")));

static GstCaps* gst_depth_colorize_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                                  GstCaps* filter) {
  GstCaps* out = gst_caps_copy(caps);
  const char* format = direction == GST_PAD_SINK ? "RGB" : "GRAY16_LE";
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    gst_structure_set(s, "format", G_TYPE_STRING, format, nullptr);
    gst_structure_remove_fields(s, "colorimetry", "chroma-site", nullptr);
  }
  if (filter) {
    GstCaps* tmp = gst_caps_intersect_full(filter, out, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(out);
    out = tmp;
  }
  return out;
}

static GstFlowReturn gst_depth_colorize_transform_frame(GstVideoFilter* filter, GstVideoFrame* in,
                                                        GstVideoFrame* out) {
  GstDepthColorize* self = GST_DEPTH_COLORIZE(filter);
  GST_OBJECT_LOCK(self);
  const double lo = self->min_mm, hi = self->max_mm;
  GST_OBJECT_UNLOCK(self);
  const int w = GST_VIDEO_FRAME_WIDTH(in), h = GST_VIDEO_FRAME_HEIGHT(in);
  cv::Mat depth(h, w, CV_16UC1, GST_VIDEO_FRAME_PLANE_DATA(in, 0), GST_VIDEO_FRAME_PLANE_STRIDE(in, 0));
  cv::Mat rgb(h, w, CV_8UC3, GST_VIDEO_FRAME_PLANE_DATA(out, 0), GST_VIDEO_FRAME_PLANE_STRIDE(out, 0));
  vclassroom::colorize_depth(depth, rgb, lo, hi);
  return GST_FLOW_OK;
}

static void gst_depth_colorize_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstDepthColorize* self = GST_DEPTH_COLORIZE(object);
  GST_OBJECT_LOCK(self);
  switch (prop_id) {
    case PROP_MIN_DEPTH:
      self->min_mm = g_value_get_uint(value);
      break;
    case PROP_MAX_DEPTH:
      self->max_mm = g_value_get_uint(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
  GST_OBJECT_UNLOCK(self);
}

static void gst_depth_colorize_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstDepthColorize* self = GST_DEPTH_COLORIZE(object);
  GST_OBJECT_LOCK(self);
  switch (prop_id) {
    case PROP_MIN_DEPTH:
      g_value_set_uint(value, self->min_mm);
      break;
    case PROP_MAX_DEPTH:
      g_value_set_uint(value, self->max_mm);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
  GST_OBJECT_UNLOCK(self);
}

static void gst_depth_colorize_class_init(GstDepthColorizeClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->set_property = gst_depth_colorize_set_property;
  gobject_class->get_property = gst_depth_colorize_get_property;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_CONTROLLABLE);
  g_object_class_install_property(gobject_class, PROP_MIN_DEPTH,
                                  g_param_spec_uint("min-depth", "Nearest depth",
                                                    "Depth (mm) drawn in the warmest colour; nearer is clamped", 0,
                                                    65535, kDefaultMin, flags));
  g_object_class_install_property(gobject_class, PROP_MAX_DEPTH,
                                  g_param_spec_uint("max-depth", "Farthest depth",
                                                    "Depth (mm) drawn in the coolest colour; farther is clamped", 1,
                                                    65535, kDefaultMax, flags));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Depth colouriser", "Filter/Converter/Video",
      "Draws a depth map as a colour picture", "gst-vclassroom developers");
  GST_BASE_TRANSFORM_CLASS(klass)->transform_caps = GST_DEBUG_FUNCPTR(gst_depth_colorize_transform_caps);
  GST_VIDEO_FILTER_CLASS(klass)->transform_frame = GST_DEBUG_FUNCPTR(gst_depth_colorize_transform_frame);
  GST_DEBUG_CATEGORY_INIT(depth_colorize_debug, "depthcolorize", 0, "depth colouriser");
}

static void gst_depth_colorize_init(GstDepthColorize* self) {
  self->min_mm = kDefaultMin;
  self->max_mm = kDefaultMax;
}
