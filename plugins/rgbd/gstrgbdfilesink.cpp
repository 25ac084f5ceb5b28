// rgbdfilesink: records a video/x-rgbd stream into the dataset format that
// rgbdfilesrc plays (one instance per camera may share a folder).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdfilesink.h"

#include <mutex>
#include <string>

#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_file_sink_debug);
#define GST_CAT_DEFAULT rgbd_file_sink_debug

using namespace vclassroom;

enum { PROP_0, PROP_LOCATION, PROP_RIG_NAME };

namespace {
struct FileSinkState {
  std::mutex lock;  // guards the properties
  std::string location;
  std::string rig_name = "recording";
  RgbdInfo info;
  bool have_info = false;
  guint64 index = 0;
};
}  // namespace

struct _GstRgbdFileSink {
  GstBaseSink parent;
  FileSinkState* st;
};

G_DEFINE_TYPE(GstRgbdFileSink, gst_rgbd_file_sink, GST_TYPE_BASE_SINK)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static std::string location_of(GstRgbdFileSink* self) {
  std::lock_guard<std::mutex> g(self->st->lock);
  return self->st->location;
}

static gboolean gst_rgbd_file_sink_start(GstBaseSink* sink) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  self->st->index = 0;
  self->st->have_info = false;
  if (location_of(self).empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("no dataset folder given"),
                      ("set the 'location' property of %s", GST_OBJECT_NAME(self)));
    return FALSE;
  }
  return TRUE;
}

static gboolean gst_rgbd_file_sink_set_caps(GstBaseSink* sink, GstCaps* caps) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  std::string err;
  RgbdInfo info;
  if (!rgbd_info_from_caps(caps, &info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  std::string rig_name;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    rig_name = self->st->rig_name;
  }
  try {
    dataset_write_camera(location_of(self), info.camera, rig_name);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, WRITE, ("%s", e.what()), (nullptr));
    return FALSE;
  }
  self->st->info = info;
  self->st->have_info = true;
  return TRUE;
}

static GstFlowReturn gst_rgbd_file_sink_render(GstBaseSink* sink, GstBuffer* buf) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  FileSinkState* st = self->st;
  if (!st->have_info) return GST_FLOW_NOT_NEGOTIATED;
  RgbdFrame frame;
  std::string err;
  if (!frame.map(buf, st->info, GST_MAP_READ, &err)) {
    GST_ELEMENT_WARNING(self, STREAM, DECODE, ("dropping corrupt frame: %s", err.c_str()), (nullptr));
    return GST_FLOW_OK;
  }
  RgbdImages im{frame.color(), frame.depth(), frame.label(), frame.plane(Plane::DepthGT)};
  try {
    dataset_write_frame(location_of(self), st->info.camera.id, st->index, im);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, WRITE, ("%s", e.what()), (nullptr));
    return GST_FLOW_ERROR;
  }
  st->index++;
  return GST_FLOW_OK;
}

static void gst_rgbd_file_sink_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  FileSinkState* st = GST_RGBD_FILE_SINK(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_LOCATION:
      st->location = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_RIG_NAME:
      st->rig_name = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_file_sink_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  FileSinkState* st = GST_RGBD_FILE_SINK(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_LOCATION:
      g_value_set_string(value, st->location.c_str());
      break;
    case PROP_RIG_NAME:
      g_value_set_string(value, st->rig_name.c_str());
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_file_sink_finalize(GObject* object) {
  delete GST_RGBD_FILE_SINK(object)->st;
  G_OBJECT_CLASS(gst_rgbd_file_sink_parent_class)->finalize(object);
}

static void gst_rgbd_file_sink_class_init(GstRgbdFileSinkClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseSinkClass* basesink_class = GST_BASE_SINK_CLASS(klass);
  gobject_class->set_property = gst_rgbd_file_sink_set_property;
  gobject_class->get_property = gst_rgbd_file_sink_get_property;
  gobject_class->finalize = gst_rgbd_file_sink_finalize;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_LOCATION,
      g_param_spec_string("location", "Dataset folder",
                          "Folder to record into: the camera is added to <location>/rig.yaml and its frames go to "
                          "<location>/cam<ID>/<plane>/<frame>.png",
                          "", flags));
  g_object_class_install_property(gobject_class, PROP_RIG_NAME,
                                  g_param_spec_string("rig-name", "Rig name",
                                                      "Name written into a new rig.yaml", "recording", flags));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_set_static_metadata(
      element_class, "RGB-D dataset sink", "Sink/File/Video",
      "Records video/x-rgbd into a dataset folder that rgbdfilesrc plays: PNG colour, 16-bit PNG depth in mm, "
      "and the label/depth-gt planes when present; the calibration from the caps goes into rig.yaml. Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=0 num-buffers=90 ! rgbdfilesink location=rec",
      "gst-vclassroom developers");
  basesink_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_start);
  basesink_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_set_caps);
  basesink_class->render = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_render);
  GST_DEBUG_CATEGORY_INIT(rgbd_file_sink_debug, "rgbdfilesink", 0, "RGB-D dataset sink");
}

static void gst_rgbd_file_sink_init(GstRgbdFileSink* self) {
  self->st = new FileSinkState();
  gst_base_sink_set_sync(GST_BASE_SINK(self), FALSE);
}
