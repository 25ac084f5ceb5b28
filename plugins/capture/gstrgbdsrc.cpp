/**
 * SECTION:element-rgbdsrc
 * @title: rgbdsrc
 *
 * A consumer RGB-D camera through V4L2: its colour node (YUYV, RGB3, MJPG) and depth node (Z16, Y16) paired
 * by the kernel's capture time, as video/x-rgbd with the rig camera's calibration in the caps
 * (docs/capture.md).
 *
 * ## Properties
 *
 * color-device: YUYV, RGB3 or MJPG at the rig camera's size. depth-device: Z16 or Y16, aligned to the
 * colour at the rig camera's size or, when the rig gives depth_to_color, at the depth lens's size,
 * registered into the colour image; depth units are the rig's depth_scale. rig: see docs/rig-format.md;
 * empty, rgbdsrc takes the first size both nodes offer and a nominal calibration, with a warning.
 * max-skew: colour and depth frames further apart are dropped and counted, never mismatched; keep it under
 * half the frame interval. reconnect: a camera that goes away while streaming is a warning, and rgbdsrc
 * waits for it to return.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdsrc color-device=/dev/video0 depth-device=/dev/video2 rig=rig.yaml ! rgbddemux name=d d.color ! videoconvert ! fakesink
 * ]|
 */
// The camera itself (V4L2 nodes, pixel formats, registration, pairing by capture time) is the library's
// RgbdCamera (capture/rgbd_camera.h); this is the glue: properties, caps, start and stop here, the streaming
// thread's timestamps on the pipeline clock, loss warnings and reconnecting in gstrgbdsrc_capture.cpp.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdsrc.h"

#include <memory>
#include <mutex>
#include <string>

#include "gstrgbdsrc_state.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_src_debug);
#define GST_CAT_DEFAULT rgbd_src_debug

using namespace vclassroom;

enum { PROP_0, PROP_COLOR_DEVICE, PROP_DEPTH_DEVICE, PROP_RIG, PROP_CAMERA_ID, PROP_MAX_SKEW, PROP_FRAMERATE,
       PROP_FRAMES_UNPAIRED, PROP_FRAMES_DAMAGED, PROP_RECONNECT };

struct _GstRgbdSrc {
  GstPushSrc parent;
  RgbdSrcState* st;
};

G_DEFINE_TYPE(GstRgbdSrc, gst_rgbd_src, GST_TYPE_PUSH_SRC)
GST_ELEMENT_REGISTER_DEFINE(rgbdsrc, "rgbdsrc", GST_RANK_NONE, GST_TYPE_RGBD_SRC)

static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_rgbd_src_start(GstBaseSrc* src) {
  GstRgbdSrc* self = GST_RGBD_SRC(src);
  RgbdSrcState* st = self->st;
  std::string color_path, depth_path, rig_path;
  int id;
  guint64 skew;
  {
    std::lock_guard<std::mutex> g(st->lock);
    color_path = st->color_device;
    depth_path = st->depth_device;
    rig_path = st->rig_path;
    id = st->camera_id;
    skew = st->max_skew;
    st->info.fps_n = st->fps_n;
    st->info.fps_d = st->fps_d;
    st->unpaired = st->damaged = 0;
  }
  if (color_path.empty() || depth_path.empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("rgbdsrc needs color-device and depth-device"),
                      ("gst-device-monitor-1.0 lists the RGB-D cameras with both (docs/capture.md)"));
    return FALSE;
  }
  if (rig_path.empty()) {
    // No calibration yet (a camera just plugged in): the first size both
    // nodes offer, and a nominal pinhole, so the camera can be seen at once.
    try {
      st->info.camera = nominal_camera(color_path, depth_path, id);
    } catch (const CaptureError& e) {
      rgbd_src_post_capture_error(GST_ELEMENT(self), e);
      return FALSE;
    }
    GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS,
                        ("no rig: camera %d gets a nominal calibration (%dx%d, 64 degrees across); calibrate the "
                         "rig (vclassroom-calibrate) before views are rendered from it",
                         id, st->info.camera.width, st->info.camera.height),
                        (nullptr));
  } else {
    try {
      st->info.camera = load_rig(rig_path).camera(id);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()),
                        ("rgbdsrc rig=%s camera-id=%d", rig_path.c_str(), id));
      return FALSE;
    }
  }
  st->info.planes = {Plane::Color, Plane::Depth};
  try {
    st->camera = std::make_unique<RgbdCamera>(color_path, depth_path, st->info.camera, st->info.fps_n, st->info.fps_d,
                                              int64_t(skew));
  } catch (const CaptureError& e) {
    rgbd_src_post_capture_error(GST_ELEMENT(self), e);
    return FALSE;
  }
  st->damaged_warnings.reset();
  st->flushing = false;
  return TRUE;
}

static gboolean gst_rgbd_src_stop(GstBaseSrc* src) {
  GST_RGBD_SRC(src)->st->camera.reset();  // stops streaming, unmaps, closes
  return TRUE;
}

static gboolean gst_rgbd_src_unlock(GstBaseSrc* src) {
  GST_RGBD_SRC(src)->st->flushing = true;
  return TRUE;
}

static gboolean gst_rgbd_src_unlock_stop(GstBaseSrc* src) {
  GST_RGBD_SRC(src)->st->flushing = false;
  return TRUE;
}

static GstCaps* gst_rgbd_src_get_caps(GstBaseSrc* src, GstCaps* filter) {
  GstRgbdSrc* self = GST_RGBD_SRC(src);
  return rgbd_source_caps(GST_BASE_SRC_PAD(src), self->st->camera ? &self->st->info : nullptr, filter);
}

static gboolean gst_rgbd_src_query(GstBaseSrc* src, GstQuery* query) {
  GstRgbdSrc* self = GST_RGBD_SRC(src);
  if (GST_QUERY_TYPE(query) == GST_QUERY_LATENCY) {
    // A frame is out once its partner from the other node arrived: up to one
    // frame interval plus the skew allowed between them.
    const GstClockTime frame = gst_util_uint64_scale(GST_SECOND, guint64(self->st->info.fps_d), guint64(self->st->info.fps_n));
    const GstClockTime lat = frame + self->st->max_skew;
    gst_query_set_latency(query, TRUE, lat, lat + 2 * frame);
    return TRUE;
  }
  return GST_BASE_SRC_CLASS(gst_rgbd_src_parent_class)->query(src, query);
}

static GstFlowReturn gst_rgbd_src_create(GstPushSrc* psrc, GstBuffer** outbuf) {
  return rgbd_src_next_buffer(GST_ELEMENT(psrc), GST_RGBD_SRC(psrc)->st, outbuf);
}

static void gst_rgbd_src_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  RgbdSrcState* st = GST_RGBD_SRC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  auto text = [&] { return std::string(g_value_get_string(value) ? g_value_get_string(value) : ""); };
  switch (prop_id) {
    case PROP_COLOR_DEVICE: st->color_device = text(); break;
    case PROP_DEPTH_DEVICE: st->depth_device = text(); break;
    case PROP_RIG: st->rig_path = text(); break;
    case PROP_CAMERA_ID: st->camera_id = g_value_get_int(value); break;
    case PROP_MAX_SKEW: st->max_skew = g_value_get_uint64(value); break;
    case PROP_FRAMERATE:
      st->fps_n = gst_value_get_fraction_numerator(value);
      st->fps_d = gst_value_get_fraction_denominator(value);
      break;
    case PROP_RECONNECT: st->reconnect = g_value_get_boolean(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_src_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  RgbdSrcState* st = GST_RGBD_SRC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_COLOR_DEVICE: g_value_set_string(value, st->color_device.c_str()); break;
    case PROP_DEPTH_DEVICE: g_value_set_string(value, st->depth_device.c_str()); break;
    case PROP_RIG: g_value_set_string(value, st->rig_path.c_str()); break;
    case PROP_CAMERA_ID: g_value_set_int(value, st->camera_id); break;
    case PROP_MAX_SKEW: g_value_set_uint64(value, st->max_skew); break;
    case PROP_FRAMERATE: gst_value_set_fraction(value, st->fps_n, st->fps_d); break;
    case PROP_FRAMES_UNPAIRED: g_value_set_uint64(value, st->unpaired); break;
    case PROP_FRAMES_DAMAGED: g_value_set_uint64(value, st->damaged); break;
    case PROP_RECONNECT: g_value_set_boolean(value, st->reconnect); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_src_finalize(GObject* object) {
  delete GST_RGBD_SRC(object)->st;
  G_OBJECT_CLASS(gst_rgbd_src_parent_class)->finalize(object);
}

static void gst_rgbd_src_class_init(GstRgbdSrcClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseSrcClass* basesrc_class = GST_BASE_SRC_CLASS(klass);
  gobject_class->set_property = gst_rgbd_src_set_property;
  gobject_class->get_property = gst_rgbd_src_get_property;
  gobject_class->finalize = gst_rgbd_src_finalize;
  const auto rw = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto ro = GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  g_object_class_install_property(gobject_class, PROP_COLOR_DEVICE,
                                  g_param_spec_string("color-device", "Colour device",
                                                      "The camera's colour V4L2 node (/dev/videoN or a /dev/v4l/by-id name)",
                                                      "", rw));
  g_object_class_install_property(gobject_class, PROP_DEPTH_DEVICE,
                                  g_param_spec_string("depth-device", "Depth device",
                                                      "The camera's depth V4L2 node (/dev/videoN or a /dev/v4l/by-id name)",
                                                      "", rw));
  g_object_class_install_property(gobject_class, PROP_RIG,
                                  g_param_spec_string("rig", "Rig file",
                                                      "Rig YAML file of the camera's size, calibration and depth scale (empty = nominal)",
                                                      "", rw));
  g_object_class_install_property(gobject_class, PROP_CAMERA_ID,
                                  g_param_spec_int("camera-id", "Camera id", "Which camera of the rig this is", 0,
                                                   G_MAXINT, 0, rw));
  g_object_class_install_property(
      gobject_class, PROP_MAX_SKEW,
      g_param_spec_uint64("max-skew", "Maximum skew",
                          "Largest colour-depth capture time difference that still pairs, in ns",
                          0, GST_SECOND, kRgbdSrcDefaultMaxSkew, rw));
  g_object_class_install_property(gobject_class, PROP_FRAMERATE,
                                  gst_param_spec_fraction("framerate", "Frame rate", "Frame rate asked of the camera",
                                                          1, 1, 1000, 1, 30, 1, rw));
  g_object_class_install_property(
      gobject_class, PROP_RECONNECT,
      g_param_spec_boolean("reconnect", "Reconnect",
                           "Wait for an unplugged camera to return (off = an error that stops the pipeline)",
                           FALSE, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(gobject_class, PROP_FRAMES_UNPAIRED,
                                  g_param_spec_uint64("frames-unpaired", "Unpaired frames",
                                                      "Colour or depth frames dropped for want of a partner", 0,
                                                      G_MAXUINT64, 0, ro));
  g_object_class_install_property(gobject_class, PROP_FRAMES_DAMAGED,
                                  g_param_spec_uint64("frames-damaged", "Damaged frames",
                                                      "Frames dropped as short, flagged by the driver or undecodable",
                                                      0, G_MAXUINT64, 0, ro));
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D camera source", "Source/Video",
      "A consumer RGB-D camera through V4L2 as video/x-rgbd", "gst-vclassroom developers");
  basesrc_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_src_start);
  basesrc_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_src_stop);
  basesrc_class->unlock = GST_DEBUG_FUNCPTR(gst_rgbd_src_unlock);
  basesrc_class->unlock_stop = GST_DEBUG_FUNCPTR(gst_rgbd_src_unlock_stop);
  basesrc_class->get_caps = GST_DEBUG_FUNCPTR(gst_rgbd_src_get_caps);
  basesrc_class->query = GST_DEBUG_FUNCPTR(gst_rgbd_src_query);
  GST_PUSH_SRC_CLASS(klass)->create = GST_DEBUG_FUNCPTR(gst_rgbd_src_create);
  GST_DEBUG_CATEGORY_INIT(rgbd_src_debug, "rgbdsrc", 0, "RGB-D camera source");
}

static void gst_rgbd_src_init(GstRgbdSrc* self) {
  self->st = new RgbdSrcState();
  gst_base_src_set_live(GST_BASE_SRC(self), TRUE);
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}
