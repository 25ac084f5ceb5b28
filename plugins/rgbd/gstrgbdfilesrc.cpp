/**
 * SECTION:element-rgbdfilesrc
 * @title: rgbdfilesrc
 *
 * Plays one camera of a recorded RGB-D dataset (rig.yaml + colour and 16-bit depth images, or a live
 * recording of coded frames) as video/x-rgbd with the camera's calibration in the caps; a live recording
 * plays at the timing it was recorded with. Datasets come from rgbdfilesink or vclassroom-import
 * (docs/datasets.md).
 *
 * ## Properties
 *
 * location: a folder holding rig.yaml and camID/{color,depth,label,depth-gt}/ images, or
 * camID/stream.vcrs, a live recording of rgbdfilesink (docs/dataset-format.md). framerate: a live
 * recording plays at its recorded timing; framerate is then only the rate its caps announce.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdfilesrc location=out/art camera-id=1 loop=true framerate=15/1 ! rgbddemux name=d d.color ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdfilesrc.h"

#include <algorithm>
#include <memory>
#include <mutex>
#include <string>

#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_file_src_debug);
#define GST_CAT_DEFAULT rgbd_file_src_debug

using namespace vclassroom;

enum { PROP_0, PROP_LOCATION, PROP_CAMERA_ID, PROP_LOOP, PROP_FRAMERATE };

namespace {
struct FileSrcState {
  std::mutex lock;  // guards the properties
  std::string location;
  int camera_id = 0;
  bool loop = false;
  int fps_n = 30, fps_d = 1;

  // Streaming thread (and start/stop).
  std::unique_ptr<Dataset> dataset;
  RgbdInfo info;
  guint64 frame = 0;   // frames produced since start or the last seek
  guint64 frames = 0;  // frames in the dataset for this camera
  bool recording = false;
  GstClockTime loop_span = 0;  // of a recording: from its time origin to one frame after its last
};

// The running time of frame `n` (counting loops) of a live recording: its
// recorded time, shifted by a whole recording for each loop.
GstClockTime recorded_time(const FileSrcState* st, guint64 n) {
  return st->dataset->frame_time_ns(st->info.camera.id, static_cast<size_t>(n % st->frames)) +
         (n / st->frames) * st->loop_span;
}
}  // namespace

struct _GstRgbdFileSrc {
  GstPushSrc parent;
  FileSrcState* st;
};

G_DEFINE_TYPE(GstRgbdFileSrc, gst_rgbd_file_src, GST_TYPE_PUSH_SRC)
GST_ELEMENT_REGISTER_DEFINE(rgbdfilesrc, "rgbdfilesrc", GST_RANK_NONE, GST_TYPE_RGBD_FILE_SRC)

static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_rgbd_file_src_start(GstBaseSrc* src) {
  GstRgbdFileSrc* self = GST_RGBD_FILE_SRC(src);
  FileSrcState* st = self->st;
  std::string location;
  int id;
  {
    std::lock_guard<std::mutex> g(st->lock);
    location = st->location;
    id = st->camera_id;
    st->info.fps_n = st->fps_n;
    st->info.fps_d = st->fps_d;
  }
  if (location.empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("no dataset folder given"),
                      ("set the 'location' property of %s", GST_OBJECT_NAME(self)));
    return FALSE;
  }
  try {
    st->dataset = std::make_unique<Dataset>(Dataset::open(location));
    st->info.camera = st->dataset->rig().camera(id);
    st->frames = st->dataset->frame_count(id);
  } catch (const Error& e) {
    st->dataset.reset();
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("rgbdfilesrc camera-id=%d", id));
    return FALSE;
  }
  st->info.planes = {Plane::Color, Plane::Depth};
  if (st->dataset->has_label(id)) st->info.planes.push_back(Plane::Label);
  if (st->dataset->has_depth_gt(id)) st->info.planes.push_back(Plane::DepthGT);
  st->frame = 0;
  st->recording = st->dataset->is_recording(id);
  if (st->recording) {
    const GstClockTime nominal = st->info.frame_duration();
    st->loop_span = st->dataset->frame_time_ns(id, st->frames - 1) + (GST_CLOCK_TIME_IS_VALID(nominal) ? nominal : 0);
    const std::string& problem = st->dataset->recording_problem(id);
    if (!problem.empty())
      GST_ELEMENT_WARNING(self, STREAM, DECODE, ("%s camera %d: the recording ends early: %s", location.c_str(), id,
                                                 problem.c_str()),
                          ("playing its %" G_GUINT64_FORMAT " whole frames", st->frames));
  }
  GST_INFO_OBJECT(self, "%s camera %d: %" G_GUINT64_FORMAT " frames", location.c_str(), id, st->frames);
  return TRUE;
}

static gboolean gst_rgbd_file_src_stop(GstBaseSrc* src) {
  GST_RGBD_FILE_SRC(src)->st->dataset.reset();
  return TRUE;
}

static GstCaps* gst_rgbd_file_src_get_caps(GstBaseSrc* src, GstCaps* filter) {
  GstRgbdFileSrc* self = GST_RGBD_FILE_SRC(src);
  return rgbd_source_caps(GST_BASE_SRC_PAD(src), self->st->dataset ? &self->st->info : nullptr, filter);
}

static gboolean gst_rgbd_file_src_is_seekable(GstBaseSrc*) { return TRUE; }

static gboolean gst_rgbd_file_src_do_seek(GstBaseSrc* src, GstSegment* segment) {
  GstRgbdFileSrc* self = GST_RGBD_FILE_SRC(src);
  FileSrcState* st = self->st;
  const GstClockTime dur = st->info.frame_duration();
  if (st->recording && st->dataset) {
    // The first frame at or after the segment's start: whole loops first
    // (bounded, so no count can overflow), then a search within one.
    bool loop;
    {
      std::lock_guard<std::mutex> g(st->lock);
      loop = st->loop;
    }
    const guint64 loops =
        loop ? std::min<guint64>(segment->start / std::max<GstClockTime>(st->loop_span, 1), G_MAXUINT32) : 0;
    guint64 lo = loops * st->frames, hi = lo + st->frames;
    while (lo < hi) {
      const guint64 mid = lo + (hi - lo) / 2;
      if (recorded_time(st, mid) < segment->start) lo = mid + 1;
      else hi = mid;
    }
    st->frame = lo;
  } else if (!GST_CLOCK_TIME_IS_VALID(dur) || dur == 0) {
    self->st->frame = 0;
  } else {
    self->st->frame = gst_util_uint64_scale_ceil(segment->start, 1, dur);
  }
  segment->time = segment->start;
  segment->position = segment->start;
  return TRUE;
}

static GstFlowReturn gst_rgbd_file_src_create(GstPushSrc* psrc, GstBuffer** outbuf) {
  GstRgbdFileSrc* self = GST_RGBD_FILE_SRC(psrc);
  FileSrcState* st = self->st;
  bool loop;
  {
    std::lock_guard<std::mutex> g(st->lock);
    loop = st->loop;
  }
  if (!loop && st->frame >= st->frames) return GST_FLOW_EOS;
  const size_t index = static_cast<size_t>(st->frame % st->frames);
  RgbdImages im;
  try {
    im = st->dataset->load(st->info.camera.id, index);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, READ, ("%s", e.what()),
                      ("rgbdfilesrc camera-id=%d frame %zu", st->info.camera.id, index));
    return GST_FLOW_ERROR;
  }
  std::string err;
  GstBuffer* buf = rgbd_buffer_with_planes(st->info,
                                           {{Plane::Color, im.color},
                                            {Plane::Depth, im.depth},
                                            {Plane::Label, im.label},
                                            {Plane::DepthGT, im.depth_gt}},
                                           &err);
  if (!buf) {
    GST_ELEMENT_ERROR(self, CORE, FAILED, ("%s", err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }

  const GstClockTime dur = st->info.frame_duration();
  if (st->recording) {
    GST_BUFFER_PTS(buf) = recorded_time(st, st->frame);
    if (loop || st->frame + 1 < st->frames)
      GST_BUFFER_DURATION(buf) = recorded_time(st, st->frame + 1) - GST_BUFFER_PTS(buf);
    else if (GST_CLOCK_TIME_IS_VALID(dur))
      GST_BUFFER_DURATION(buf) = dur;
  } else if (GST_CLOCK_TIME_IS_VALID(dur)) {
    GST_BUFFER_PTS(buf) = st->frame * dur;
    GST_BUFFER_DURATION(buf) = dur;
  }
  GST_BUFFER_OFFSET(buf) = st->frame;
  GST_BUFFER_OFFSET_END(buf) = st->frame + 1;
  st->frame++;
  *outbuf = buf;
  return GST_FLOW_OK;
}

static void gst_rgbd_file_src_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  FileSrcState* st = GST_RGBD_FILE_SRC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_LOCATION:
      st->location = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_CAMERA_ID:
      st->camera_id = g_value_get_int(value);
      break;
    case PROP_LOOP:
      st->loop = g_value_get_boolean(value);
      break;
    case PROP_FRAMERATE:
      st->fps_n = gst_value_get_fraction_numerator(value);
      st->fps_d = gst_value_get_fraction_denominator(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_file_src_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  FileSrcState* st = GST_RGBD_FILE_SRC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_LOCATION:
      g_value_set_string(value, st->location.c_str());
      break;
    case PROP_CAMERA_ID:
      g_value_set_int(value, st->camera_id);
      break;
    case PROP_LOOP:
      g_value_set_boolean(value, st->loop);
      break;
    case PROP_FRAMERATE:
      gst_value_set_fraction(value, st->fps_n, st->fps_d);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_file_src_finalize(GObject* object) {
  delete GST_RGBD_FILE_SRC(object)->st;
  G_OBJECT_CLASS(gst_rgbd_file_src_parent_class)->finalize(object);
}

static void gst_rgbd_file_src_class_init(GstRgbdFileSrcClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseSrcClass* basesrc_class = GST_BASE_SRC_CLASS(klass);
  GstPushSrcClass* pushsrc_class = GST_PUSH_SRC_CLASS(klass);

  gobject_class->set_property = gst_rgbd_file_src_set_property;
  gobject_class->get_property = gst_rgbd_file_src_get_property;
  gobject_class->finalize = gst_rgbd_file_src_finalize;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_LOCATION,
      g_param_spec_string("location", "Dataset folder",
                          "Recorded dataset folder to play (docs/dataset-format.md)",
                          "", flags));
  g_object_class_install_property(gobject_class, PROP_CAMERA_ID,
                                  g_param_spec_int("camera-id", "Camera id", "Which camera of the rig to play", 0,
                                                   G_MAXINT, 0, flags));
  g_object_class_install_property(gobject_class, PROP_LOOP,
                                  g_param_spec_boolean("loop", "Loop",
                                                       "Start again at the first frame after the last one "
                                                       "(timestamps keep increasing)",
                                                       FALSE, flags));
  g_object_class_install_property(
      gobject_class, PROP_FRAMERATE,
      gst_param_spec_fraction("framerate", "Frame rate",
                              "Frame rate images are played at",
                              1, 1, 1000, 1, 30,
                              1, flags));

  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D dataset source", "Source/File/Video",
      "Plays one camera of a recorded RGB-D dataset", "gst-vclassroom developers");

  basesrc_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_start);
  basesrc_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_stop);
  basesrc_class->get_caps = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_get_caps);
  basesrc_class->is_seekable = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_is_seekable);
  basesrc_class->do_seek = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_do_seek);
  pushsrc_class->create = GST_DEBUG_FUNCPTR(gst_rgbd_file_src_create);
  GST_DEBUG_CATEGORY_INIT(rgbd_file_src_debug, "rgbdfilesrc", 0, "RGB-D dataset source");
}

static void gst_rgbd_file_src_init(GstRgbdFileSrc* self) {
  self->st = new FileSrcState();
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}
