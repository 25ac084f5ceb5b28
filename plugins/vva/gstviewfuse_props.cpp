// viewfuse's properties (docs/vva.md explains each at length; gst-inspect-1.0 gets one line).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewfuse_state.h"

namespace vclassroom {

namespace {

enum {
  PROP_0,
  PROP_POSE_TRACE,
  PROP_DEPTH_TOLERANCE,
  PROP_FILL_HOLES,
  PROP_FILL_TEXTURE,
  PROP_FILL_METHOD,
  PROP_FRAMES_FUSED,
  PROP_POSE_WINDOW,
  PROP_CAMERA_TIMEOUT,
  PROP_SHOW_MISSING,
  PROP_RIG,
  PROP_POSES_CLAMPED,
  PROP_UNSEEN_SHARE,
  PROP_STATS_INTERVAL,
  PROP_WARP_SYNC,
  PROP_ROOM_VIEW
};

// viewfuse's fill-method values (hole_fill.h: HoleFillMethod).
GType fill_method_get_type() {
  static gsize type = 0;
  static const GEnumValue values[] = {
      {int(HoleFillMethod::Pyramid), "Push-pull pyramid over each hole's background border (since issue 35)",
       "pyramid"},
      {int(HoleFillMethod::Rays), "Nearest background pixels along the row and column, blurred (before issue 35)",
       "rays"},
      {0, nullptr, nullptr}};
  if (g_once_init_enter(&type)) g_once_init_leave(&type, g_enum_register_static("GstViewFuseFillMethod", values));
  return GType(type);
}

}  // namespace

void view_fuse_install_properties(GObjectClass* klass) {
  const FuseParams d;
  const FuseInputsParams di;
  g_object_class_install_property(
      klass, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace (docs/pose.md) to send upstream, one pose per output frame (empty: none)",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      klass, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML with navigation bounds every pose sent upstream is moved into (empty: unbounded)",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      klass, PROP_POSES_CLAMPED,
      g_param_spec_uint64("poses-clamped", "Poses clamped",
                          "Poses moved into the navigation bounds since start", 0,
                          G_MAXUINT64, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      klass, PROP_UNSEEN_SHARE,
      g_param_spec_double("unseen-share", "Unseen share",
                          "Share of the last picture's pixels that no camera saw",
                          0, 1, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      klass, PROP_STATS_INTERVAL,
      g_param_spec_uint("stats-interval", "Stats interval",
                          "Output frames between vclassroom-view-stats messages (0: none)",
                        0, G_MAXUINT, 0, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      klass, PROP_DEPTH_TOLERANCE,
      g_param_spec_double("depth-tolerance", "Depth tolerance",
                          "Samples within this many mm (or 3%) of the nearest are blended, farther ones hidden",
                          0, 10000, d.depth_tol_mm,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_FILL_HOLES,
      g_param_spec_boolean("fill-holes", "Fill holes",
                          "Fill what no camera sees from its background side (else black)", d.fill_holes,
                           GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_FILL_TEXTURE,
      g_param_spec_double("fill-texture", "Fill texture",
                          "Share of the background's texture carried into filled holes (0: smooth; fill-method=rays only)",
                          0, 1, d.fill_texture,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_FILL_METHOD,
      g_param_spec_enum("fill-method", "Fill method",
                        "How holes are filled from their background: pyramid (smooth, 2-D) or rays (the fill before "
                        "issue 35, for comparison)",
                        fill_method_get_type(), int(d.fill_method),
                        GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_POSE_WINDOW,
      g_param_spec_uint64("pose-window", "Pose window",
                          "Live: frames of poses at most this many ns apart are fused together",
                          0, G_MAXINT64, guint64(di.pose_window_ns),
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_CAMERA_TIMEOUT,
      g_param_spec_uint64("camera-timeout", "Camera timeout",
                          "Live: ns without a frame before a camera is lost, at least the latency (0: never)",
                          0, G_MAXINT64, guint64(di.camera_timeout_ns),
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_SHOW_MISSING,
      g_param_spec_boolean("show-missing", "Show missing cameras",
                          "Draw a banner naming the lost cameras on the picture",
                           di.show_missing,
                           GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_WARP_SYNC,
      g_param_spec_uint64("warp-sync", "Warp sync",
                          "Live: longest wait (ns) of a camera's warp for the others' next frames (0: none)",
                          0, WarpStartParams::kLongestWaitNs, guint64(WarpStartParams().max_wait_ns),
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_ROOM_VIEW,
      g_param_spec_boolean("room-view", "Room view",
                           "Draw the room from every camera's mesh and packed room, the viewwarps upstream warping "
                           "only the learners (cameras with prior-depth; docs/vva.md)",
                           kRoomViewByDefault,
                           GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      klass, PROP_FRAMES_FUSED,
      g_param_spec_uint64("frames-fused", "Frames fused",
                          "Output frames produced since start", 0, G_MAXUINT64, 0,
                          GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
}

void view_fuse_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  ViewFuseState* st = GST_VIEW_FUSE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  FuseInputsParams inputs = st->inputs.params();
  switch (prop_id) {
    case PROP_POSE_TRACE:
      st->trace_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_DEPTH_TOLERANCE:
      st->params.depth_tol_mm = g_value_get_double(value);
      break;
    case PROP_FILL_HOLES:
      st->params.fill_holes = g_value_get_boolean(value);
      break;
    case PROP_FILL_TEXTURE:
      st->params.fill_texture = g_value_get_double(value);
      break;
    case PROP_FILL_METHOD:
      st->params.fill_method = HoleFillMethod(g_value_get_enum(value));
      break;
    case PROP_POSE_WINDOW:
      inputs.pose_window_ns = int64_t(g_value_get_uint64(value));
      break;
    case PROP_CAMERA_TIMEOUT:
      inputs.camera_timeout_ns = int64_t(g_value_get_uint64(value));
      break;
    case PROP_SHOW_MISSING:
      inputs.show_missing = g_value_get_boolean(value);
      break;
    case PROP_RIG:
      st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_STATS_INTERVAL:
      st->stats_interval = g_value_get_uint(value);
      break;
    case PROP_WARP_SYNC: {
      WarpStartParams w = st->warp_start.params();
      w.max_wait_ns = int64_t(g_value_get_uint64(value));
      st->warp_start.set_params(w);
      break;
    }
    case PROP_ROOM_VIEW:
      st->room_view = g_value_get_boolean(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
  st->inputs.set_params(inputs);
}

void view_fuse_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  ViewFuseState* st = GST_VIEW_FUSE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_POSE_TRACE:
      g_value_set_string(value, st->trace_path.c_str());
      break;
    case PROP_DEPTH_TOLERANCE:
      g_value_set_double(value, st->params.depth_tol_mm);
      break;
    case PROP_FILL_HOLES:
      g_value_set_boolean(value, st->params.fill_holes);
      break;
    case PROP_FILL_TEXTURE:
      g_value_set_double(value, st->params.fill_texture);
      break;
    case PROP_FILL_METHOD:
      g_value_set_enum(value, int(st->params.fill_method));
      break;
    case PROP_POSE_WINDOW:
      g_value_set_uint64(value, guint64(st->inputs.params().pose_window_ns));
      break;
    case PROP_CAMERA_TIMEOUT:
      g_value_set_uint64(value, guint64(st->inputs.params().camera_timeout_ns));
      break;
    case PROP_SHOW_MISSING:
      g_value_set_boolean(value, st->inputs.params().show_missing);
      break;
    case PROP_FRAMES_FUSED:
      g_value_set_uint64(value, st->frames);
      break;
    case PROP_RIG:
      g_value_set_string(value, st->rig_path.c_str());
      break;
    case PROP_POSES_CLAMPED:
      g_value_set_uint64(value, st->bounds.clamped());
      break;
    case PROP_UNSEEN_SHARE:
      g_value_set_double(value, st->unseen_share);
      break;
    case PROP_STATS_INTERVAL:
      g_value_set_uint(value, st->stats_interval);
      break;
    case PROP_WARP_SYNC:
      g_value_set_uint64(value, guint64(st->warp_start.params().max_wait_ns));
      break;
    case PROP_ROOM_VIEW:
      g_value_set_boolean(value, st->room_view);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

}  // namespace vclassroom
