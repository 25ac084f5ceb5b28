// viewwarp: one camera's video/x-rgbd stream warped to the lecturer's current
// virtual view (V-VA step 2, docs/vva.md). Consumes `vclassroom/pose` events.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewwarp.h"

#include <cmath>
#include <mutex>
#include <string>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/view_warp.h>
#include <gst/vclassroom/vva/warp_start.h>
#include <gst/vclassroom/vva/virtual_view.h>

GST_DEBUG_CATEGORY_STATIC(view_warp_debug);
#define GST_CAT_DEFAULT view_warp_debug

using namespace vclassroom;

enum {
  PROP_0,
  PROP_WIDTH,
  PROP_HEIGHT,
  PROP_FOV,
  PROP_PRIOR_DEPTH,
  PROP_BOUNDARY,
  PROP_EDGE_TO_NEAR,
  PROP_RIG,
  PROP_REFERENCE,
  PROP_POSES_RECEIVED,
  PROP_POSE_TRACE,
  PROP_BACKGROUND_MEMORY,
  PROP_EMPTY_ROOM
};

namespace {

struct WarpState {
  std::mutex lock;  // guards the properties and the pose
  int width = 0, height = 0;
  double fov = 0;
  std::string prior_path;
  int boundary_px = 0;
  bool edge_to_near = true;
  int memory_frames = 0;  // background-memory; 0: off
  std::string empty_room_path;
  std::string rig_path;
  int reference_id = 0;
  std::string trace_path;
  // Latest pose (a new session's first, then the highest seq within it); the rig's reference camera until one
  // arrives.
  Pose pose;
  bool have_pose = false;
  guint64 poses_received = 0;

  // Streaming thread only.
  RgbdInfo in_info, out_info;
  cv::Mat prior;
  bool use_prior = false;  // the prior fits the negotiated camera size
  std::vector<PoseSample> trace;  // pose-trace, loaded at start
  uint64_t frames = 0;
  ViewWarper warper;
  WarpedView warped;
  FramePreparer preparer;   // the memory and the warp's first half, for frames viewprep did not prepare
  cv::Mat empty_room;       // empty-room, RGB: the memory's seed
  bool told_unprepared = false;  // the warning that a prepared frame's settings differ from ours
};

}  // namespace

struct _GstViewWarp {
  GstBaseTransform parent;
  WarpState* st;
};

G_DEFINE_TYPE(GstViewWarp, gst_view_warp, GST_TYPE_BASE_TRANSFORM)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-rgbd, width = (int) [ 1, 16384 ], height = (int) [ 1, 16384 ], "
                    "framerate = (fraction) [ 0/1, 2147483647/1 ], planes = (string) \"color,depth,label,weight\""));

static bool output_info(GstViewWarp* self, const RgbdInfo& in, RgbdInfo* out) {
  int w, h;
  double fov;
  Eigen::Isometry3d initial;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    w = self->st->width;
    h = self->st->height;
    fov = self->st->fov;
    initial = self->st->pose.cam_to_rig();
  }
  *out = in;
  out->camera = virtual_view_base(in.camera, w, h, fov);
  // The caps show the view at negotiation time; each buffer's pose meta says which pose it shows.
  out->camera.cam_to_rig = initial;
  out->planes = {Plane::Color, Plane::Depth, Plane::Label, Plane::Weight};
  return true;
}

static GstCaps* gst_view_warp_transform_caps(GstBaseTransform* trans, GstPadDirection direction, GstCaps* caps,
                                             GstCaps* filter) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  GstCaps* out = nullptr;
  if (direction == GST_PAD_SINK && gst_caps_is_fixed(caps)) {
    RgbdInfo in, o;
    std::string err;
    if (rgbd_info_from_caps(caps, &in, &err) && output_info(self, in, &o)) {
      out = rgbd_caps_new(o);
      gst_caps_set_simple(out, "virtual-view", G_TYPE_BOOLEAN, TRUE, nullptr);
    }
  }
  if (!out) {
    GstPad* other = direction == GST_PAD_SINK ? GST_BASE_TRANSFORM_SRC_PAD(trans) : GST_BASE_TRANSFORM_SINK_PAD(trans);
    out = gst_pad_get_pad_template_caps(other);
  }
  if (filter) {
    GstCaps* tmp = gst_caps_intersect_full(filter, out, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(out);
    out = tmp;
  }
  return out;
}

static gboolean gst_view_warp_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps* outcaps) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  WarpState* st = self->st;
  std::string err;
  if (!rgbd_info_from_caps(incaps, &st->in_info, &err) || !rgbd_info_from_caps(outcaps, &st->out_info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  // A camera may change its size mid-stream (another mode, another sender):
  // it is renegotiated, and warped from its live depth alone while the prior
  // made for the other size does not fit, rather than stopping the server.
  st->use_prior = !st->prior.empty();
  if (st->use_prior && (st->prior.cols != st->in_info.width() || st->prior.rows != st->in_info.height())) {
    st->use_prior = false;
    GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS,
                        ("prior-depth is %dx%d but camera %d now streams %dx%d: warping it without the prior",
                         st->prior.cols, st->prior.rows, st->in_info.camera.id, st->in_info.width(),
                         st->in_info.height()),
                        (nullptr));
  }
  int memory_frames;
  {
    std::lock_guard<std::mutex> g(st->lock);
    memory_frames = st->memory_frames;
  }
  if (memory_frames > 0 && !st->empty_room.empty() &&
      (st->empty_room.cols != st->in_info.width() || st->empty_room.rows != st->in_info.height()))
    GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                        ("empty-room is %dx%d but camera %d streams %dx%d: the background memory learns the room as "
                         "it sees it",
                         st->empty_room.cols, st->empty_room.rows, st->in_info.camera.id, st->in_info.width(),
                         st->in_info.height()),
                        (nullptr));
  st->preparer.set_static_depth(st->use_prior ? st->prior : cv::Mat());
  GST_INFO_OBJECT(self, "camera %d %dx%d -> virtual view %dx%d (fx %.1f)", st->in_info.camera.id,
                  st->in_info.width(), st->in_info.height(), st->out_info.width(), st->out_info.height(),
                  st->out_info.camera.fx);
  return TRUE;
}

static gboolean gst_view_warp_get_unit_size(GstBaseTransform*, GstCaps* caps, gsize* size) {
  RgbdInfo info;
  std::string err;
  if (!rgbd_info_from_caps(caps, &info, &err)) return FALSE;
  *size = info.default_total_size();
  return TRUE;
}

static GstFlowReturn gst_view_warp_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* in, GstBuffer** out) {
  *out = rgbd_buffer_new(GST_VIEW_WARP(trans)->st->out_info);
  gst_buffer_copy_into(*out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  return GST_FLOW_OK;
}

static gboolean gst_view_warp_start(GstBaseTransform* trans) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  WarpState* st = self->st;
  std::string path, rig_path, trace_path, empty_room_path;
  int ref;
  {
    std::lock_guard<std::mutex> g(st->lock);
    path = st->prior_path;
    empty_room_path = st->empty_room_path;
    rig_path = st->rig_path;
    trace_path = st->trace_path;
    ref = st->reference_id;
  }
  // Until the first pose event: the reference camera's view.
  try {
    const Rig rig = rig_path.empty() ? default_classroom_rig() : load_rig(rig_path);
    std::lock_guard<std::mutex> g(st->lock);
    if (const CameraCalib* c = rig.find(ref)) {
      st->pose = Pose::from_cam_to_rig(c->cam_to_rig);
      st->have_pose = false;
    } else {
      GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS,
                        ("reference-camera %d is not in the rig %s", ref,
                         rig_path.empty() ? "(default classroom rig)" : rig_path.c_str()),
                        (nullptr));
      return FALSE;
    }
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("property rig of %s", GST_OBJECT_NAME(self)));
    return FALSE;
  }
  st->trace.clear();
  st->frames = 0;
  if (!trace_path.empty()) {
    try {
      st->trace = load_pose_trace(trace_path);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()),
                        ("property pose-trace of %s", GST_OBJECT_NAME(self)));
      return FALSE;
    }
    if (st->trace.empty()) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("pose trace %s has no poses", trace_path.c_str()), (nullptr));
      return FALSE;
    }
  }
  st->prior.release();
  st->empty_room.release();
  try {
    if (!path.empty()) st->prior = load_static_depth(path);
    if (!empty_room_path.empty()) st->empty_room = load_empty_room(empty_room_path);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("properties prior-depth and empty-room of %s",
                                                                     GST_OBJECT_NAME(self)));
    return FALSE;
  }
  return TRUE;
}

static GstFlowReturn gst_view_warp_transform(GstBaseTransform* trans, GstBuffer* inbuf, GstBuffer* outbuf) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  WarpState* st = self->st;
  Pose pose;
  WarpParams params;
  int memory_frames;
  {
    std::lock_guard<std::mutex> g(st->lock);
    params.boundary_px = st->boundary_px;
    params.edge_to_near = st->edge_to_near;
    memory_frames = st->memory_frames;
  }
  RgbdFrame in, out;
  std::string err;
  if (!in.map(inbuf, st->in_info, GST_MAP_READ, &err) || !out.map(outbuf, st->out_info, GST_MAP_WRITE, &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  // What does not depend on the pose (the memory, the warp's first half) is done before the pose is read: it
  // is not part of the pose's latency. A viewprep upstream may have done it once for every view.
  std::shared_ptr<const PreparedFrame> prepared = buffer_get_prepared_frame(inbuf);
  if (prepared && (prepared->edge_to_near != params.edge_to_near || prepared->boundary_px != params.boundary_px ||
                   prepared->source.width != st->in_info.width() || prepared->source.height != st->in_info.height())) {
    if (!st->told_unprepared)
      GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                          ("camera %d's frames were prepared (viewprep) with other edge-to-near, boundary or size "
                           "than this viewwarp's: it prepares them again itself", st->in_info.camera.id),
                          (nullptr));
    st->told_unprepared = true;
    prepared = nullptr;
  }
  try {
    if (!prepared) {
      // A new seed (start) or length starts the memory again.
      st->preparer.set_memory(memory_frames, st->empty_room);
      prepared = st->preparer.prepare(st->in_info.camera, in.color(), in.depth(), in.label(), params);
    }
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", e.what()), (nullptr));
    return GST_FLOW_ERROR;
  } catch (const cv::Exception& e) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("view warp failed: %s", e.what()), (nullptr));
    return GST_FLOW_ERROR;
  }
  const WarpSource src = FramePreparer::source_of(*prepared, in.color(), in.depth(), in.label());
  const GstClockTime running_time = trans->segment.format == GST_FORMAT_TIME && GST_BUFFER_PTS_IS_VALID(inbuf)
                                       ? gst_segment_to_running_time(&trans->segment, GST_FORMAT_TIME, GST_BUFFER_PTS(inbuf))
                                       : GST_CLOCK_TIME_NONE;
  // Live, viewfuse holds this until the view's other cameras have a frame to warp too (its warp-sync), so
  // that all read the same newest pose below.
  GstQuery* warp_start = gst_query_new_custom(
      GST_QUERY_CUSTOM, gst_structure_new(kWarpStartQueryName, "running-time", G_TYPE_UINT64, running_time, nullptr));
  gst_pad_peer_query(GST_BASE_TRANSFORM_SRC_PAD(trans), warp_start);
  gst_query_unref(warp_start);
  {
    std::lock_guard<std::mutex> g(st->lock);
    pose = st->pose;
  }
  if (!st->trace.empty()) {
    // The frame's own moment of the trace (trace_pose_for_frame()).
    pose = trace_pose_for_frame(
        st->trace, GST_CLOCK_TIME_IS_VALID(running_time) ? double(running_time) / GST_SECOND : NAN, st->frames);
  }
  ++st->frames;
  const CameraCalib virt = virtual_camera(st->out_info.camera, pose.cam_to_rig(), pose.fov_deg);
  GST_LOG_OBJECT(self, "pose seq %" G_GUINT64_FORMAT " at (%.3f, %.3f, %.3f); source camera %d at (%.3f, %.3f, %.3f)",
                 pose.seq, pose.position.x(), pose.position.y(), pose.position.z(), st->in_info.camera.id,
                 st->in_info.camera.cam_to_rig.translation().x(), st->in_info.camera.cam_to_rig.translation().y(),
                 st->in_info.camera.cam_to_rig.translation().z());
  // Warp straight into the output planes.
  st->warped.color = out.color();
  st->warped.depth = out.depth();
  st->warped.label = out.label();
  st->warped.weight = out.plane(Plane::Weight);
  try {
    st->warper.warp_prepared(st->in_info.camera, src, prepared->source, virt, params, &st->warped);
  } catch (const cv::Exception& e) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("view warp failed: %s", e.what()), (nullptr));
    return GST_FLOW_ERROR;
  }
  buffer_add_pose_meta(outbuf, pose.seq, pose.viewer_time_ns, rendered_pose_of(pose), pose.session);
  return GST_FLOW_OK;
}

// Pose events end here: they steer this element and nothing upstream of it.
static gboolean gst_view_warp_src_event(GstBaseTransform* trans, GstEvent* event) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  if (is_pose_event(event)) {
    Pose pose;
    std::string err;
    if (!pose_event_parse(event, &pose, &err)) {
      GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("ignoring a bad pose event: %s", err.c_str()), (nullptr));
    } else {
      std::lock_guard<std::mutex> g(self->st->lock);
      ++self->st->poses_received;
      // The receiver upstream of the fuse chose the session; a pose of another session than the one shown is
      // the new steering one (docs/network.md, "Sessions"), and within a session the latest seq wins.
      const Pose& shown = self->st->pose;
      if (!self->st->have_pose || pose.session != shown.session || pose.seq >= shown.seq) {
        self->st->pose = pose;
        self->st->have_pose = true;
      }
    }
    gst_event_unref(event);
    return TRUE;
  }
  return GST_BASE_TRANSFORM_CLASS(gst_view_warp_parent_class)->src_event(trans, event);
}

static void gst_view_warp_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  WarpState* st = GST_VIEW_WARP(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_WIDTH:
      st->width = g_value_get_int(value);
      break;
    case PROP_HEIGHT:
      st->height = g_value_get_int(value);
      break;
    case PROP_FOV:
      st->fov = g_value_get_double(value);
      break;
    case PROP_PRIOR_DEPTH:
      st->prior_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_BOUNDARY:
      st->boundary_px = g_value_get_int(value);
      break;
    case PROP_EDGE_TO_NEAR:
      st->edge_to_near = g_value_get_boolean(value);
      break;
    case PROP_BACKGROUND_MEMORY:
      st->memory_frames = g_value_get_int(value);
      break;
    case PROP_EMPTY_ROOM:
      st->empty_room_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_RIG:
      st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_REFERENCE:
      st->reference_id = g_value_get_int(value);
      break;
    case PROP_POSE_TRACE:
      st->trace_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_view_warp_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  WarpState* st = GST_VIEW_WARP(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_WIDTH:
      g_value_set_int(value, st->width);
      break;
    case PROP_HEIGHT:
      g_value_set_int(value, st->height);
      break;
    case PROP_FOV:
      g_value_set_double(value, st->fov);
      break;
    case PROP_PRIOR_DEPTH:
      g_value_set_string(value, st->prior_path.c_str());
      break;
    case PROP_BOUNDARY:
      g_value_set_int(value, st->boundary_px);
      break;
    case PROP_EDGE_TO_NEAR:
      g_value_set_boolean(value, st->edge_to_near);
      break;
    case PROP_BACKGROUND_MEMORY:
      g_value_set_int(value, st->memory_frames);
      break;
    case PROP_EMPTY_ROOM:
      g_value_set_string(value, st->empty_room_path.c_str());
      break;
    case PROP_RIG:
      g_value_set_string(value, st->rig_path.c_str());
      break;
    case PROP_REFERENCE:
      g_value_set_int(value, st->reference_id);
      break;
    case PROP_POSE_TRACE:
      g_value_set_string(value, st->trace_path.c_str());
      break;
    case PROP_POSES_RECEIVED:
      g_value_set_uint64(value, st->poses_received);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_view_warp_finalize(GObject* object) {
  delete GST_VIEW_WARP(object)->st;
  G_OBJECT_CLASS(gst_view_warp_parent_class)->finalize(object);
}

static void gst_view_warp_class_init(GstViewWarpClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_view_warp_set_property;
  gobject_class->get_property = gst_view_warp_get_property;
  gobject_class->finalize = gst_view_warp_finalize;
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto playing = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(
      gobject_class, PROP_WIDTH,
      g_param_spec_int("width", "Virtual width", "Width of the virtual view (0: the camera's); intrinsics scale with it",
                       0, 16384, 0, ready));
  g_object_class_install_property(
      gobject_class, PROP_HEIGHT,
      g_param_spec_int("height", "Virtual height", "Height of the virtual view (0: the camera's)", 0, 16384, 0, ready));
  g_object_class_install_property(
      gobject_class, PROP_FOV,
      g_param_spec_double("fov", "Field of view",
                          "Horizontal field of view of the virtual view in degrees (0: the camera's); a pose "
                          "event's fov overrides it",
                          0, 179, 0, ready));
  g_object_class_install_property(
      gobject_class, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth",
                          "16-bit PNG (mm) of the empty classroom seen by this camera: the static layer's depth for "
                          "pixels labelled 0 (V-DA's prior depth, or vclassroom-eval-views --write-priors). Empty: "
                          "the stream's depth everywhere",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_BOUNDARY,
      g_param_spec_int("boundary", "Edge boundary",
                       "Source pixels dropped on the far side of a depth edge (their colour mixes both surfaces), "
                       "beyond the one edge-to-near gives the near side",
                       0, 8, 0, playing));
  g_object_class_install_property(
      gobject_class, PROP_EDGE_TO_NEAR,
      g_param_spec_boolean("edge-to-near", "Edge pixels to the near side",
                           "The far-side pixel next to a depth edge (the object's rim, its colour mixed with the "
                           "background) moves with the nearer surface instead of staying on the background",
                           TRUE, playing));
  g_object_class_install_property(
      gobject_class, PROP_BACKGROUND_MEMORY,
      g_param_spec_int("background-memory", "Background memory",
                       "Show the static room (label 0) through a memory of its colour: the mean of up to this many "
                       "frames, started again where the colour changes by more than the camera's noise (docs/vva.md); "
                       "the camera's noise then no longer flickers in the view. With prior-depth, the room behind "
                       "the learners, as last seen, is drawn behind them: where the view looks past a learner it "
                       "shows that room, not a smear. 0: off",
                       0, 64, 0, playing));
  g_object_class_install_property(
      gobject_class, PROP_EMPTY_ROOM,
      g_param_spec_string("empty-room", "Empty room",
                          "RGB image of the empty classroom seen by this camera (V-DA's model: "
                          "prior-color/cam<ID>.png) that background-memory starts from, so the room behind a "
                          "learner who has not moved yet is known. Empty: the memory learns the room as it sees it",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML file; only used for the view shown before the first pose event (the reference "
                          "camera's). Empty: the default classroom rig",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_REFERENCE,
      g_param_spec_int("reference-camera", "Reference camera",
                       "Id of the rig camera whose view is rendered until the first pose event arrives", 0, G_MAXINT,
                       0, ready));
  g_object_class_install_property(
      gobject_class, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace (docs/pose.md) that sets the view of each frame by its running time against "
                          "the trace's t column (without either, by frame number), overriding pose events: for rendering a "
                          "scripted path, every camera's frame of one instant warped for the same pose. Empty: "
                          "pose events steer the view",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_POSES_RECEIVED,
      g_param_spec_uint64("poses-received", "Poses received", "Pose events this element has received", 0,
                          G_MAXUINT64, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "View warp", "Filter/Effect/Video",
      "Warps one camera's video/x-rgbd stream (static layer with the prior depth, learners with live depth) to the "
      "virtual view of the latest vclassroom/pose event (within a session the highest seq wins, a new session "
      "steers from its first pose; the rig's reference camera until one arrives) as a triangle mesh with depth-edge rejection and bilinear colour. Output: video/x-rgbd of the "
      "virtual camera with planes color,depth,label,weight; camera-id stays the source camera's, virtual-view = "
      "true; each buffer carries the pose meta (seq, viewer time). Pose events are consumed, not forwarded. Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! learnerseg ! "
      "viewwarp reference-camera=0 ! rgbddemux name=d d.color ! videoconvert ! autovideosink",
      "gst-vclassroom developers");
  bt->transform_caps = GST_DEBUG_FUNCPTR(gst_view_warp_transform_caps);
  bt->set_caps = GST_DEBUG_FUNCPTR(gst_view_warp_set_caps);
  bt->get_unit_size = GST_DEBUG_FUNCPTR(gst_view_warp_get_unit_size);
  bt->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_view_warp_prepare_output_buffer);
  bt->transform = GST_DEBUG_FUNCPTR(gst_view_warp_transform);
  bt->start = GST_DEBUG_FUNCPTR(gst_view_warp_start);
  bt->src_event = GST_DEBUG_FUNCPTR(gst_view_warp_src_event);
  GST_DEBUG_CATEGORY_INIT(view_warp_debug, "viewwarp", 0, "view warp");
}

static void gst_view_warp_init(GstViewWarp* self) { self->st = new WarpState(); }
