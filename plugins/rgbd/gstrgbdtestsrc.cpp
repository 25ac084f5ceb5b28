/**
 * SECTION:element-rgbdtestsrc
 * @title: rgbdtestsrc
 *
 * A synthetic classroom with moving learners seen from one camera of a rig, as video/x-rgbd with the
 * camera's calibration in the caps, an optional consumer depth-sensor model and exact ground truth.
 *
 * ## Properties
 *
 * camera-id: in the default rig 0 is the centre camera, 1 the left and 2 the right, as seen from the
 * cameras. rig: the cameras' poses and intrinsics in the classroom's rig frame (docs/rig-format.md); the
 * default rig is 3 cameras 0.8 m apart at the front, 960x540 (docs/synthetic-classroom.md). seed: it picks
 * the textures, writing, learners' looks, seats and behaviour, and the sensor noise; instances with the
 * same seed show the same scene at the same frame. sensor-noise: depth holes on dark, glossy and grazing
 * surfaces and outside the depth field of view, noise growing with depth squared, flying pixels at depth
 * edges, 1 mm quantisation, colour noise. ground-truth: the label plane holds 0 for static pixels and k
 * for learner k; the caps planes are then "color,depth,label,depth-gt" (else "color,depth").
 * calibration-board: someone carries a 9x6 checkerboard of 80 mm squares through the room, holding it
 * still 1 s at each of 24 stops in front of the default rig (docs/real-classroom.md). flash-interval: the
 * room's colour turns white for 200 ms (half the interval when shorter) from each multiple of this running
 * time (ns; 0: never), the
 * picture's half of a clap whose sound is audiotestsrc's tick: vclassroom-measure-sync times both at the
 * lecturer's page.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! rgbddemux name=d d.color ! queue ! videoconvert ! fakesink d.depth ! queue ! depthcolorize ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdtestsrc.h"

#include <algorithm>

#include <mutex>
#include <string>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/synthetic/synthetic_camera.h>
#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_test_src_debug);
#define GST_CAT_DEFAULT rgbd_test_src_debug

using namespace vclassroom;

enum {
  PROP_0,
  PROP_CAMERA_ID,
  PROP_RIG,
  PROP_SEED,
  PROP_LEARNERS,
  PROP_SENSOR_NOISE,
  PROP_GROUND_TRUTH,
  PROP_IS_LIVE,
  PROP_FRAMERATE,
  PROP_CALIBRATION_BOARD,
  PROP_FLASH_INTERVAL,
};

namespace {
constexpr guint64 kDefaultSeed = 1;
constexpr int kDefaultLearners = 3;
constexpr guint64 kFlashLength = 200 * GST_MSECOND;

struct TestSrcState {
  std::mutex lock;  // guards the properties
  int camera_id = 0;
  std::string rig_path;
  guint64 seed = kDefaultSeed;
  int learners = kDefaultLearners;
  bool sensor_noise = true;
  bool ground_truth = true;
  int fps_n = 30, fps_d = 1;
  bool calibration_board = false;
  guint64 flash_interval = 0;  // ns of running time; 0: no flash

  // Streaming thread (and start/stop).
  bool started = false;
  SyntheticCamera camera;
  RgbdInfo info;
  guint64 frame = 0;  // next frame to produce
  // Live mode: running time of frame 0.
  GstClockTime live_base = GST_CLOCK_TIME_NONE;
};
}  // namespace

struct _GstRgbdTestSrc {
  GstPushSrc parent;
  TestSrcState* st;
};

G_DEFINE_TYPE(GstRgbdTestSrc, gst_rgbd_test_src, GST_TYPE_PUSH_SRC)
GST_ELEMENT_REGISTER_DEFINE(rgbdtestsrc, "rgbdtestsrc", GST_RANK_NONE, GST_TYPE_RGBD_TEST_SRC)

static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_rgbd_test_src_start(GstBaseSrc* src) {
  GstRgbdTestSrc* self = GST_RGBD_TEST_SRC(src);
  TestSrcState* st = self->st;
  std::string rig_path;
  int id;
  SyntheticCameraConfig cfg;
  bool ground_truth;
  {
    std::lock_guard<std::mutex> g(st->lock);
    rig_path = st->rig_path;
    id = st->camera_id;
    cfg.room.seed = st->seed;
    cfg.room.learners = st->learners;
    cfg.sensor_noise = st->sensor_noise;
    cfg.calibration_board = st->calibration_board;
    ground_truth = st->ground_truth;
    st->info.fps_n = st->fps_n;
    st->info.fps_d = st->fps_d;
  }
  try {
    const Rig rig = rig_path.empty() ? default_classroom_rig() : load_rig(rig_path);
    st->info.camera = rig.camera(id);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()),
                      ("rgbdtestsrc rig=%s camera-id=%d", rig_path.empty() ? "(default rig)" : rig_path.c_str(),
                       id));
    return FALSE;
  }
  try {
    st->camera.configure(cfg);  // keeps the classroom across restarts of the same seed
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, LIBRARY, INIT, ("%s", e.what()), (nullptr));
    return FALSE;
  }
  st->info.planes = {Plane::Color, Plane::Depth};
  if (ground_truth) {
    st->info.planes.push_back(Plane::Label);
    st->info.planes.push_back(Plane::DepthGT);
  }
  st->frame = 0;
  st->live_base = GST_CLOCK_TIME_NONE;
  st->started = true;
  GST_INFO_OBJECT(self, "camera %d (%dx%d), seed %" G_GUINT64_FORMAT ", %d learners, planes %s", id,
                  st->info.width(), st->info.height(), cfg.room.seed, cfg.room.learners, st->info.planes_string().c_str());
  return TRUE;
}

static gboolean gst_rgbd_test_src_stop(GstBaseSrc* src) {
  GST_RGBD_TEST_SRC(src)->st->started = false;
  return TRUE;
}

static GstCaps* gst_rgbd_test_src_get_caps(GstBaseSrc* src, GstCaps* filter) {
  GstRgbdTestSrc* self = GST_RGBD_TEST_SRC(src);
  return rgbd_source_caps(GST_BASE_SRC_PAD(src), self->st->started ? &self->st->info : nullptr, filter);
}

static GstClockTime frame_time(const RgbdInfo& info, guint64 n) {
  return gst_util_uint64_scale(n, GST_SECOND * guint64(info.fps_d), guint64(info.fps_n));
}

static gboolean gst_rgbd_test_src_is_seekable(GstBaseSrc* src) { return !gst_base_src_is_live(src); }

static gboolean gst_rgbd_test_src_do_seek(GstBaseSrc* src, GstSegment* segment) {
  TestSrcState* st = GST_RGBD_TEST_SRC(src)->st;
  // The first frame at or after the segment start.
  st->frame = gst_util_uint64_scale_ceil(segment->start, guint64(st->info.fps_n), GST_SECOND * guint64(st->info.fps_d));
  segment->time = segment->start;
  segment->position = segment->start;
  return TRUE;
}

// Live: basesrc waits on the clock until each buffer's running time.
static void gst_rgbd_test_src_get_times(GstBaseSrc* src, GstBuffer* buf, GstClockTime* start, GstClockTime* end) {
  if (gst_base_src_is_live(src)) {
    const GstClockTime ts = GST_BUFFER_PTS(buf);
    if (GST_CLOCK_TIME_IS_VALID(ts)) {
      *start = ts;
      *end = GST_BUFFER_DURATION_IS_VALID(buf) ? ts + GST_BUFFER_DURATION(buf) : GST_CLOCK_TIME_NONE;
      return;
    }
  }
  *start = *end = GST_CLOCK_TIME_NONE;
}

static gboolean gst_rgbd_test_src_query(GstBaseSrc* src, GstQuery* query) {
  TestSrcState* st = GST_RGBD_TEST_SRC(src)->st;
  if (GST_QUERY_TYPE(query) == GST_QUERY_LATENCY && st->started) {
    // A live frame is ready one frame period after its timestamp.
    const GstClockTime lat = gst_base_src_is_live(src) ? frame_time(st->info, 1) : 0;
    gst_query_set_latency(query, gst_base_src_is_live(src), lat, lat);
    return TRUE;
  }
  return GST_BASE_SRC_CLASS(gst_rgbd_test_src_parent_class)->query(src, query);
}

static GstFlowReturn gst_rgbd_test_src_create(GstPushSrc* psrc, GstBuffer** outbuf) {
  GstRgbdTestSrc* self = GST_RGBD_TEST_SRC(psrc);
  TestSrcState* st = self->st;
  const guint64 n = st->frame;
  // Scene time n / fps, so instances with the same seed show the same instant.
  const double t = double(n) * st->info.fps_d / st->info.fps_n;
  SyntheticCamera::Planes planes;
  try {
    planes = st->camera.frame(st->info.camera, t, n);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, LIBRARY, FAILED, ("%s", e.what()), ("rgbdtestsrc frame %" G_GUINT64_FORMAT, n));
    return GST_FLOW_ERROR;
  }
  GstClockTime base = 0;
  if (gst_base_src_is_live(GST_BASE_SRC(psrc))) {
    // Like videotestsrc: frames are stamped in running time, starting from
    // the running time at which the first one is made.
    if (!GST_CLOCK_TIME_IS_VALID(st->live_base)) {
      st->live_base = 0;
      GstClock* clock = gst_element_get_clock(GST_ELEMENT(self));
      if (clock) {
        const GstClockTime now = gst_clock_get_time(clock);
        const GstClockTime bt = gst_element_get_base_time(GST_ELEMENT(self));
        if (now > bt) st->live_base = now - bt;
        gst_object_unref(clock);
      }
    }
    base = st->live_base;
  }
  const GstClockTime pts = base + frame_time(st->info, n);
  const GstClockTime duration = frame_time(st->info, n + 1) - frame_time(st->info, n);
  guint64 flash_interval = 0;
  {
    std::lock_guard<std::mutex> g(st->lock);
    flash_interval = st->flash_interval;
  }
  // The flash: the frames of the first kFlashLength of each interval (from the one whose time span holds
  // its start) show the room white: long enough that a view dropping frames under load still shows one.
  if (flash_interval > 0 && pts % flash_interval < std::max<guint64>(duration, std::min(kFlashLength, flash_interval / 2)))
    planes.color = cv::Mat(planes.color.size(), planes.color.type(), cv::Scalar::all(255));
  std::string err;
  GstBuffer* buf = rgbd_buffer_with_planes(st->info,
                                           {{Plane::Color, planes.color},
                                            {Plane::Depth, planes.depth},
                                            {Plane::Label, planes.label},
                                            {Plane::DepthGT, planes.depth_gt}},
                                           &err);
  if (!buf) {
    GST_ELEMENT_ERROR(self, CORE, FAILED, ("%s", err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }

  GST_BUFFER_PTS(buf) = pts;
  GST_BUFFER_DTS(buf) = pts;
  GST_BUFFER_DURATION(buf) = duration;
  GST_BUFFER_OFFSET(buf) = n;
  GST_BUFFER_OFFSET_END(buf) = n + 1;
  st->frame++;
  *outbuf = buf;
  return GST_FLOW_OK;
}

static void gst_rgbd_test_src_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstRgbdTestSrc* self = GST_RGBD_TEST_SRC(object);
  TestSrcState* st = self->st;
  if (prop_id == PROP_IS_LIVE) {
    gst_base_src_set_live(GST_BASE_SRC(object), g_value_get_boolean(value));
    return;
  }
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_CAMERA_ID: st->camera_id = g_value_get_int(value); break;
    case PROP_RIG: st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_SEED: st->seed = g_value_get_uint64(value); break;
    case PROP_LEARNERS: st->learners = g_value_get_int(value); break;
    case PROP_SENSOR_NOISE: st->sensor_noise = g_value_get_boolean(value); break;
    case PROP_GROUND_TRUTH: st->ground_truth = g_value_get_boolean(value); break;
    case PROP_FRAMERATE:
      st->fps_n = gst_value_get_fraction_numerator(value);
      st->fps_d = gst_value_get_fraction_denominator(value);
      break;
    case PROP_CALIBRATION_BOARD: st->calibration_board = g_value_get_boolean(value); break;
    case PROP_FLASH_INTERVAL: st->flash_interval = g_value_get_uint64(value); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_test_src_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  TestSrcState* st = GST_RGBD_TEST_SRC(object)->st;
  if (prop_id == PROP_IS_LIVE) {
    g_value_set_boolean(value, gst_base_src_is_live(GST_BASE_SRC(object)));
    return;
  }
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_CAMERA_ID: g_value_set_int(value, st->camera_id); break;
    case PROP_RIG: g_value_set_string(value, st->rig_path.c_str()); break;
    case PROP_SEED: g_value_set_uint64(value, st->seed); break;
    case PROP_LEARNERS: g_value_set_int(value, st->learners); break;
    case PROP_SENSOR_NOISE: g_value_set_boolean(value, st->sensor_noise); break;
    case PROP_GROUND_TRUTH: g_value_set_boolean(value, st->ground_truth); break;
    case PROP_FRAMERATE: gst_value_set_fraction(value, st->fps_n, st->fps_d); break;
    case PROP_CALIBRATION_BOARD: g_value_set_boolean(value, st->calibration_board); break;
    case PROP_FLASH_INTERVAL: g_value_set_uint64(value, st->flash_interval); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_rgbd_test_src_finalize(GObject* object) {
  delete GST_RGBD_TEST_SRC(object)->st;
  G_OBJECT_CLASS(gst_rgbd_test_src_parent_class)->finalize(object);
}

static void gst_rgbd_test_src_class_init(GstRgbdTestSrcClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseSrcClass* basesrc_class = GST_BASE_SRC_CLASS(klass);
  GstPushSrcClass* pushsrc_class = GST_PUSH_SRC_CLASS(klass);

  gobject_class->set_property = gst_rgbd_test_src_set_property;
  gobject_class->get_property = gst_rgbd_test_src_get_property;
  gobject_class->finalize = gst_rgbd_test_src_finalize;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_CAMERA_ID,
      g_param_spec_int("camera-id", "Camera id",
                       "Which camera of the rig to render (default rig: 0 centre, 1 left, 2 right)",
                       0, G_MAXINT, 0, flags));
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML file of the cameras' poses and intrinsics (empty = the default rig)",
                          "", flags));
  g_object_class_install_property(
      gobject_class, PROP_SEED,
      g_param_spec_uint64("seed", "Seed",
                          "Seed of the classroom and of the sensor noise",
                          0, G_MAXUINT64, kDefaultSeed, flags));
  g_object_class_install_property(
      gobject_class, PROP_LEARNERS,
      g_param_spec_int("learners", "Learners", "Number of learners in the room (0 = the empty classroom)", 0,
                       kClassroomMaxLearners, kDefaultLearners, flags));
  g_object_class_install_property(
      gobject_class, PROP_SENSOR_NOISE,
      g_param_spec_boolean("sensor-noise", "Sensor noise",
                           "Simulate a consumer RGB-D camera's noise and holes (off = the clean render)",
                           TRUE, flags));
  g_object_class_install_property(
      gobject_class, PROP_GROUND_TRUTH,
      g_param_spec_boolean("ground-truth", "Ground truth",
                           "Add the learner label plane and the clean depth (depth-gt) to every buffer",
                           TRUE, flags));
  g_object_class_install_property(
      gobject_class, PROP_IS_LIVE,
      g_param_spec_boolean("is-live", "Is live",
                           "Act as a live source: produce frames in real time, stamped in running time", FALSE,
                           flags));
  g_object_class_install_property(
      gobject_class, PROP_FRAMERATE,
      gst_param_spec_fraction("framerate", "Frame rate",
                              "Frame rate; frame n shows scene time n / framerate", 1, 1, 1000, 1, 30, 1, flags));
  g_object_class_install_property(
      gobject_class, PROP_CALIBRATION_BOARD,
      g_param_spec_boolean("calibration-board", "Calibration board",
                           "Show a 9x6 checkerboard carried through the room (for vclassroom-calibrate --synthetic)",
                           FALSE, flags));
  g_object_class_install_property(
      gobject_class, PROP_FLASH_INTERVAL,
      g_param_spec_uint64("flash-interval", "Flash interval",
                          "The room is white for 200 ms from each multiple of this running time (ns), a clap's "
                          "picture (0: never)",
                          0, G_MAXUINT64, 0, flags));

  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Synthetic RGB-D classroom source", "Source/Video",
      "A synthetic classroom seen from one camera of a rig", "gst-vclassroom developers");

  basesrc_class->start = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_start);
  basesrc_class->stop = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_stop);
  basesrc_class->get_caps = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_get_caps);
  basesrc_class->is_seekable = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_is_seekable);
  basesrc_class->do_seek = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_do_seek);
  basesrc_class->get_times = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_get_times);
  basesrc_class->query = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_query);
  pushsrc_class->create = GST_DEBUG_FUNCPTR(gst_rgbd_test_src_create);
  GST_DEBUG_CATEGORY_INIT(rgbd_test_src_debug, "rgbdtestsrc", 0, "Synthetic RGB-D classroom source");
}

static void gst_rgbd_test_src_init(GstRgbdTestSrc* self) {
  self->st = new TestSrcState();
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}
