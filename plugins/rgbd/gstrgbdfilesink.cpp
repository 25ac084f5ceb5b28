/**
 * SECTION:element-rgbdfilesink
 * @title: rgbdfilesink
 *
 * Records a camera into a dataset folder that rgbdfilesrc plays (one instance per camera may share a
 * folder); the calibration from the caps goes into rig.yaml. video/x-rgbd becomes PNG colour, 16-bit PNG
 * depth in mm and the label/depth-gt planes when present (a few frames a second); video/x-rgbd-coded from
 * rgbdenc is recorded as it is, with each frame's running time, at the camera's full rate (a live
 * recording, played back at its original timing).
 *
 * ## Properties
 *
 * location: the camera is added to LOCATION/rig.yaml and its frames go to LOCATION/camID/PLANE/FRAME.png
 * (video/x-rgbd) or LOCATION/camID/stream.vcrs (video/x-rgbd-coded); docs/dataset-format.md describes the
 * layout.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=0 num-buffers=90 ! rgbdenc ! rgbdfilesink location=rec
 * ]|
 */
// The coded recording's format: datasets/coded_stream.h.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdfilesink.h"

#include <memory>
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
  std::unique_ptr<CodedStreamWriter> recording;  // with coded caps
};
}  // namespace

struct _GstRgbdFileSink {
  GstBaseSink parent;
  FileSinkState* st;
};

G_DEFINE_TYPE(GstRgbdFileSink, gst_rgbd_file_sink, GST_TYPE_BASE_SINK)
GST_ELEMENT_REGISTER_DEFINE(rgbdfilesink, "rgbdfilesink", GST_RANK_NONE, GST_TYPE_RGBD_FILE_SINK)


static std::string location_of(GstRgbdFileSink* self) {
  std::lock_guard<std::mutex> g(self->st->lock);
  return self->st->location;
}

static gboolean gst_rgbd_file_sink_start(GstBaseSink* sink) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  self->st->index = 0;
  self->st->have_info = false;
  self->st->recording.reset();
  if (location_of(self).empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("no dataset folder given"),
                      ("set the 'location' property of %s", GST_OBJECT_NAME(self)));
    return FALSE;
  }
  return TRUE;
}

static gboolean gst_rgbd_file_sink_stop(GstBaseSink* sink) {
  GST_RGBD_FILE_SINK(sink)->st->recording.reset();
  return TRUE;
}

static gboolean gst_rgbd_file_sink_set_caps(GstBaseSink* sink, GstCaps* caps) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  std::string err;
  RgbdInfo info;
  const bool coded = gst_structure_has_name(gst_caps_get_structure(caps, 0), kRgbdCodedMediaType);
  GstCaps* raw = coded ? rgbd_caps_renamed(caps, kRgbdMediaType, false) : gst_caps_ref(caps);
  const bool parsed = rgbd_info_from_caps(raw, &info, &err);
  gst_caps_unref(raw);
  if (!parsed) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  std::string rig_name;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    rig_name = self->st->rig_name;
  }
  try {
    const std::string location = location_of(self);
    dataset_write_camera(location, info.camera, rig_name);
    if (coded && !self->st->recording) {
      // A new recording per run; caps changing within a run keep the file
      // (rgbdfilesrc checks every frame against the rig camera).
      const std::string dir = dataset_camera_dir(location, info.camera.id);
      g_mkdir_with_parents(dir.c_str(), 0755);
      self->st->recording = std::make_unique<CodedStreamWriter>(
          dir + "/" + kCodedStreamFile, info.has(Plane::Label) ? kCodedStreamHasLabel : 0);
    }
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, WRITE, ("%s", e.what()), (nullptr));
    return FALSE;
  }
  self->st->info = info;
  self->st->have_info = true;
  return TRUE;
}

// The frame goes to disk as it came, with its running time (the frame index
// at the nominal rate when it carries no timestamp).
static GstFlowReturn record_coded_frame(GstRgbdFileSink* self, GstBuffer* buf) {
  FileSinkState* st = self->st;
  GstClockTime time = gst_segment_to_running_time(&GST_BASE_SINK(self)->segment, GST_FORMAT_TIME,
                                                  GST_BUFFER_PTS(buf));
  if (!GST_CLOCK_TIME_IS_VALID(time)) {
    const GstClockTime duration = st->info.frame_duration();
    time = GST_CLOCK_TIME_IS_VALID(duration) ? st->index * duration : st->index;
  }
  GstMapInfo map;
  if (!gst_buffer_map(buf, &map, GST_MAP_READ)) {
    GST_ELEMENT_ERROR(self, RESOURCE, WRITE, ("cannot read a coded frame"), (nullptr));
    return GST_FLOW_ERROR;
  }
  try {
    st->recording->write(time, map.data, map.size);
    st->recording->flush();
  } catch (const Error& e) {
    gst_buffer_unmap(buf, &map);
    GST_ELEMENT_ERROR(self, RESOURCE, WRITE, ("%s", e.what()), (nullptr));
    return GST_FLOW_ERROR;
  }
  gst_buffer_unmap(buf, &map);
  st->index++;
  return GST_FLOW_OK;
}

static GstFlowReturn gst_rgbd_file_sink_render(GstBaseSink* sink, GstBuffer* buf) {
  GstRgbdFileSink* self = GST_RGBD_FILE_SINK(sink);
  FileSinkState* st = self->st;
  if (!st->have_info) return GST_FLOW_NOT_NEGOTIATED;
  if (st->recording) return record_coded_frame(self, buf);
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
                          "Dataset folder to record into",
                          "", flags));
  g_object_class_install_property(gobject_class, PROP_RIG_NAME,
                                  g_param_spec_string("rig-name", "Rig name",
                                                      "Name written into a new rig.yaml", "recording", flags));
  // Raw frames become images; coded frames (rgbdenc) a live recording.
  GstCaps* sink_caps = gst_caps_from_string(kRgbdTemplateCaps);
  gst_caps_append(sink_caps, gst_caps_from_string(kRgbdCodedTemplateCaps));
  gst_element_class_add_pad_template(element_class,
                                     gst_pad_template_new("sink", GST_PAD_SINK, GST_PAD_ALWAYS, sink_caps));
  gst_caps_unref(sink_caps);
  gst_element_class_set_static_metadata(element_class, "RGB-D dataset sink", "Sink/File/Video",
      "Records a camera into a dataset folder", "gst-vclassroom developers");
  basesink_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_start);
  basesink_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_stop);
  basesink_class->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_set_caps);
  basesink_class->render = GST_DEBUG_FUNCPTR(gst_rgbd_file_sink_render);
  GST_DEBUG_CATEGORY_INIT(rgbd_file_sink_debug, "rgbdfilesink", 0, "RGB-D dataset sink");
}

static void gst_rgbd_file_sink_init(GstRgbdFileSink* self) {
  self->st = new FileSinkState();
  gst_base_sink_set_sync(GST_BASE_SINK(self), FALSE);
}
