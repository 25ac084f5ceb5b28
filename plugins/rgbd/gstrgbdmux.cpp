/**
 * SECTION:element-rgbdmux
 * @title: rgbdmux
 *
 * Pairs a colour (RGB) and a registered depth (GRAY16_LE, mm) stream of one camera by running time into
 * video/x-rgbd, with the camera's calibration from a rig file in the caps. Zero copy.
 *
 * ## Properties
 *
 * max-skew: older unpaired frames are dropped.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbddemux name=d d.color ! queue ! m.color d.depth ! queue ! m.depth rgbdmux name=m ! rgbddemux name=e e.color ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdmux.h"

#include <gst/video/video.h>

#include <mutex>
#include <string>

#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_mux_debug);
#define GST_CAT_DEFAULT rgbd_mux_debug

using namespace vclassroom;

enum { PROP_0, PROP_RIG, PROP_CAMERA_ID, PROP_MAX_SKEW };

namespace {

struct MuxState {
  std::mutex lock;  // guards the properties
  std::string rig_path;
  int camera_id = 0;
  GstClockTime max_skew = GST_CLOCK_TIME_NONE;  // NONE: half a colour frame

  // Streaming thread only.
  GstVideoInfo color_info{};
  GstVideoInfo depth_info{};
  bool have_color_caps = false, have_depth_caps = false;
  bool caps_dirty = false;
  std::optional<CameraCalib> rig_camera;
  RgbdInfo out_info;
  bool have_out = false;
  guint64 dropped = 0;
};

}  // namespace

struct _GstRgbdMux {
  GstAggregator parent;
  GstAggregatorPad* color_pad;
  GstAggregatorPad* depth_pad;
  MuxState* st;
};

G_DEFINE_TYPE(GstRgbdMux, gst_rgbd_mux, GST_TYPE_AGGREGATOR)
GST_ELEMENT_REGISTER_DEFINE(rgbdmux, "rgbdmux", GST_RANK_NONE, GST_TYPE_RGBD_MUX)

static GstStaticPadTemplate color_template = GST_STATIC_PAD_TEMPLATE(
    "color", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGB")));
static GstStaticPadTemplate depth_template = GST_STATIC_PAD_TEMPLATE(
    "depth", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY16_LE")));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));


// Output stream description from the colour caps and the rig (or a nominal camera).
static gboolean compute_output_info(GstRgbdMux* self) {
  MuxState* st = self->st;
  const int w = GST_VIDEO_INFO_WIDTH(&st->color_info), h = GST_VIDEO_INFO_HEIGHT(&st->color_info);
  const int dw = GST_VIDEO_INFO_WIDTH(&st->depth_info), dh = GST_VIDEO_INFO_HEIGHT(&st->depth_info);
  if (w != dw || h != dh) {
    GST_ELEMENT_ERROR(self, STREAM, FORMAT, ("depth is %dx%d but colour is %dx%d", dw, dh, w, h),
                      ("rgbdmux pairs images of one size; register and scale depth to colour first"));
    return FALSE;
  }
  CameraCalib cam;
  if (st->rig_camera) {
    cam = *st->rig_camera;
    if (cam.width != w || cam.height != h) {
      std::lock_guard<std::mutex> g(st->lock);
      GST_ELEMENT_ERROR(self, STREAM, FORMAT,
                        ("rig file %s: camera %d is %dx%d but the colour stream is %dx%d", st->rig_path.c_str(),
                         cam.id, cam.width, cam.height, w, h),
                        (nullptr));
      return FALSE;
    }
  } else {
    // No rig: a nominal pinhole (about 60 degrees across) at the rig origin.
    std::lock_guard<std::mutex> g(st->lock);
    cam.id = st->camera_id;
    cam.width = w;
    cam.height = h;
    cam.fx = cam.fy = 0.866 * w;
    cam.cx = (w - 1) / 2.0;
    cam.cy = (h - 1) / 2.0;
    GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("no rig file set: using a nominal pinhole camera (fx = fy = %.1f)", cam.fx),
                        ("set the 'rig' property so downstream stages know the real calibration"));
  }
  st->out_info.camera = cam;
  st->out_info.fps_n = GST_VIDEO_INFO_FPS_N(&st->color_info);
  st->out_info.fps_d = GST_VIDEO_INFO_FPS_D(&st->color_info);
  st->out_info.planes = {Plane::Color, Plane::Depth};
  st->have_out = true;
  st->caps_dirty = false;
  return TRUE;
}

static GstFlowReturn gst_rgbd_mux_update_src_caps(GstAggregator* agg, GstCaps* downstream, GstCaps** ret) {
  GstRgbdMux* self = GST_RGBD_MUX(agg);
  MuxState* st = self->st;
  if (!st->have_color_caps || !st->have_depth_caps) return GST_AGGREGATOR_FLOW_NEED_DATA;
  if (!compute_output_info(self)) return GST_FLOW_NOT_NEGOTIATED;
  GstCaps* caps = rgbd_caps_new(st->out_info);
  if (!gst_caps_can_intersect(caps, downstream)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("downstream does not accept this camera's video/x-rgbd caps"),
                      ("ours: %" GST_PTR_FORMAT ", downstream: %" GST_PTR_FORMAT, caps, downstream));
    gst_caps_unref(caps);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  *ret = caps;
  return GST_FLOW_OK;
}

static GstFlowReturn gst_rgbd_mux_aggregate(GstAggregator* agg, gboolean timeout) {
  GstRgbdMux* self = GST_RGBD_MUX(agg);
  MuxState* st = self->st;
  GstBuffer* color = gst_aggregator_pad_peek_buffer(self->color_pad);
  GstBuffer* depth = gst_aggregator_pad_peek_buffer(self->depth_pad);
  GstFlowReturn ret = GST_FLOW_OK;

  if (!color || !depth) {
    // One stream has ended: nothing more can be paired.
    if ((!color && gst_aggregator_pad_is_eos(self->color_pad)) ||
        (!depth && gst_aggregator_pad_is_eos(self->depth_pad)))
      ret = GST_FLOW_EOS;
    else
      GST_LOG_OBJECT(self, "waiting for the other stream (timeout %d)", timeout);
    goto done;
  }
  if (!st->have_color_caps || !st->have_depth_caps) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("buffers arrived before caps"), (nullptr));
    ret = GST_FLOW_NOT_NEGOTIATED;
    goto done;
  }
  // Normally negotiated before aggregate(); a caps change that raced with
  // the data renegotiates here.
  if ((st->caps_dirty || !st->have_out) && !gst_aggregator_negotiate(agg)) {
    ret = GST_FLOW_NOT_NEGOTIATED;
    goto done;
  }
  {
    const GstClockTime rt_c = aggregator_pad_running_time(self->color_pad, color);
    const GstClockTime rt_d = aggregator_pad_running_time(self->depth_pad, depth);
    GstClockTime skew;
    {
      std::lock_guard<std::mutex> g(st->lock);
      skew = st->max_skew;
    }
    if (!GST_CLOCK_TIME_IS_VALID(skew)) {
      const GstClockTime dur = st->out_info.frame_duration();
      skew = GST_CLOCK_TIME_IS_VALID(dur) ? dur / 2 : 0;
    }
    if (GST_CLOCK_TIME_IS_VALID(rt_c) && GST_CLOCK_TIME_IS_VALID(rt_d)) {
      const GstClockTime diff = rt_c > rt_d ? rt_c - rt_d : rt_d - rt_c;
      if (diff > skew) {
        // Unpaired: drop the older image, the newer one may still find its mate.
        GstAggregatorPad* older = rt_c < rt_d ? self->color_pad : self->depth_pad;
        st->dropped++;
        GST_DEBUG_OBJECT(self, "dropping unpaired %s frame at %" GST_TIME_FORMAT " (other at %" GST_TIME_FORMAT ")",
                         older == self->color_pad ? "colour" : "depth", GST_TIME_ARGS(std::min(rt_c, rt_d)),
                         GST_TIME_ARGS(std::max(rt_c, rt_d)));
        gst_aggregator_pad_drop_buffer(older);
        goto done;
      }
    }
    const PlaneLayout lc = raw_plane_layout(color, st->out_info.width(), st->out_info.height(), GST_VIDEO_FORMAT_RGB);
    const PlaneLayout ld =
        raw_plane_layout(depth, st->out_info.width(), st->out_info.height(), GST_VIDEO_FORMAT_GRAY16_LE);
    GstBuffer* out = rgbd_buffer_assemble(st->out_info, {color, depth}, {lc, ld});
    GST_BUFFER_PTS(out) = rt_c;
    GST_BUFFER_DTS(out) = GST_CLOCK_TIME_NONE;
    GST_BUFFER_DURATION(out) = GST_BUFFER_DURATION(color);
    if (GST_BUFFER_FLAG_IS_SET(color, GST_BUFFER_FLAG_DISCONT)) GST_BUFFER_FLAG_SET(out, GST_BUFFER_FLAG_DISCONT);
    gst_aggregator_pad_drop_buffer(self->color_pad);
    gst_aggregator_pad_drop_buffer(self->depth_pad);
    GstSegment* seg = &GST_AGGREGATOR_PAD(agg->srcpad)->segment;
    GST_OBJECT_LOCK(agg);
    if (GST_CLOCK_TIME_IS_VALID(rt_c))
      seg->position = rt_c + (GST_BUFFER_DURATION_IS_VALID(out) ? GST_BUFFER_DURATION(out) : 0);
    GST_OBJECT_UNLOCK(agg);
    ret = gst_aggregator_finish_buffer(agg, out);
  }
done:
  if (color) gst_buffer_unref(color);
  if (depth) gst_buffer_unref(depth);
  return ret;
}

static gboolean gst_rgbd_mux_sink_event(GstAggregator* agg, GstAggregatorPad* pad, GstEvent* event) {
  GstRgbdMux* self = GST_RGBD_MUX(agg);
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    GstVideoInfo info;
    if (!gst_video_info_from_caps(&info, caps)) {
      GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("invalid caps on pad %s", GST_PAD_NAME(pad)), (nullptr));
      gst_event_unref(event);
      return FALSE;
    }
    if (pad == self->color_pad) {
      self->st->color_info = info;
      self->st->have_color_caps = true;
    } else {
      self->st->depth_info = info;
      self->st->have_depth_caps = true;
    }
    self->st->caps_dirty = true;
    gst_pad_mark_reconfigure(agg->srcpad);
    gst_event_unref(event);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_rgbd_mux_parent_class)->sink_event(agg, pad, event);
}

static gboolean gst_rgbd_mux_start(GstAggregator* agg) {
  GstRgbdMux* self = GST_RGBD_MUX(agg);
  MuxState* st = self->st;
  std::string path;
  int id;
  {
    std::lock_guard<std::mutex> g(st->lock);
    path = st->rig_path;
    id = st->camera_id;
  }
  st->rig_camera.reset();
  st->have_out = false;
  st->have_color_caps = st->have_depth_caps = false;
  st->dropped = 0;
  if (!path.empty()) {
    try {
      Rig rig = load_rig(path);
      st->rig_camera = rig.camera(id);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("%s", e.what()), ("property 'rig' of %s", GST_OBJECT_NAME(self)));
      return FALSE;
    }
  }
  return TRUE;
}

static gboolean gst_rgbd_mux_stop(GstAggregator* agg) {
  GstRgbdMux* self = GST_RGBD_MUX(agg);
  if (self->st->dropped) GST_INFO_OBJECT(self, "dropped %" G_GUINT64_FORMAT " unpaired frames", self->st->dropped);
  return TRUE;
}

static void gst_rgbd_mux_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdMux* self = GST_RGBD_MUX(object);
  std::lock_guard<std::mutex> g(self->st->lock);
  switch (prop_id) {
    case PROP_RIG: self->st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_CAMERA_ID: self->st->camera_id = g_value_get_int(value); break;
    case PROP_MAX_SKEW: self->st->max_skew = g_value_get_uint64(value); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_mux_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  GstRgbdMux* self = GST_RGBD_MUX(object);
  std::lock_guard<std::mutex> g(self->st->lock);
  switch (prop_id) {
    case PROP_RIG: g_value_set_string(value, self->st->rig_path.c_str()); break;
    case PROP_CAMERA_ID: g_value_set_int(value, self->st->camera_id); break;
    case PROP_MAX_SKEW: g_value_set_uint64(value, self->st->max_skew); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_mux_finalize(GObject* object) {
  delete GST_RGBD_MUX(object)->st;
  G_OBJECT_CLASS(gst_rgbd_mux_parent_class)->finalize(object);
}

static void gst_rgbd_mux_class_init(GstRgbdMuxClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* agg_class = GST_AGGREGATOR_CLASS(klass);

  gobject_class->set_property = gst_rgbd_mux_set_property;
  gobject_class->get_property = gst_rgbd_mux_get_property;
  gobject_class->finalize = gst_rgbd_mux_finalize;

  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML file with this camera's calibration (empty: a nominal pinhole, with a warning)",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_CAMERA_ID,
      g_param_spec_int("camera-id", "Camera id", "Id of this camera in the rig file", 0, G_MAXINT, 0,
                       GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_MAX_SKEW,
      g_param_spec_uint64("max-skew", "Maximum skew",
                          "Largest colour-depth running-time difference that still pairs, in ns (-1 = half a frame)",
                          0, G_MAXUINT64, GST_CLOCK_TIME_NONE,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));

  gst_element_class_add_static_pad_template_with_gtype(element_class, &color_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(element_class, &depth_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(element_class, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(element_class, "RGB-D muxer", "Muxer/Video",
      "Pairs a camera's colour and depth streams into one RGB-D stream", "gst-vclassroom developers");

  agg_class->aggregate = GST_DEBUG_FUNCPTR(gst_rgbd_mux_aggregate);
  agg_class->sink_event = GST_DEBUG_FUNCPTR(gst_rgbd_mux_sink_event);
  agg_class->update_src_caps = GST_DEBUG_FUNCPTR(gst_rgbd_mux_update_src_caps);
  agg_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_mux_start);
  agg_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_mux_stop);
  agg_class->get_next_time = gst_aggregator_simple_get_next_time;

  GST_DEBUG_CATEGORY_INIT(rgbd_mux_debug, "rgbdmux", 0, "RGB-D muxer");
}

static void gst_rgbd_mux_init(GstRgbdMux* self) {
  self->st = new MuxState();
  GstElementClass* klass = GST_ELEMENT_GET_CLASS(self);
  self->color_pad = GST_AGGREGATOR_PAD(g_object_new(GST_TYPE_AGGREGATOR_PAD, "name", "color", "direction",
                                                    GST_PAD_SINK, "template",
                                                    gst_element_class_get_pad_template(klass, "color"), nullptr));
  gst_element_add_pad(GST_ELEMENT(self), GST_PAD(self->color_pad));
  self->depth_pad = GST_AGGREGATOR_PAD(g_object_new(GST_TYPE_AGGREGATOR_PAD, "name", "depth", "direction",
                                                    GST_PAD_SINK, "template",
                                                    gst_element_class_get_pad_template(klass, "depth"), nullptr));
  gst_element_add_pad(GST_ELEMENT(self), GST_PAD(self->depth_pad));
}
