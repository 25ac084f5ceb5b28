/**
 * SECTION:element-posenav
 * @title: posenav
 *
 * The lecturer's mouse interface: put it before the video sink. Dragging with the left button looks around,
 * the wheel and the arrow/WASD keys move (Q/E or PageUp/PageDown up and down), Home or R returns to the
 * start pose; each change goes upstream as a vclassroom/pose event. The navigation events it uses stop here.
 * Also drives the view from the six-slider notation or a pose trace.
 *
 * ## Properties
 *
 * rig: the sliders and navigation are relative to the rig's reference camera; empty, to the rig origin
 * looking level along -Z. With a navigation section (vclassroom-build-model writes one,
 * docs/navigation.md) the view and trace poses stay inside its bounds. sliders: the paper's six-slider
 * notation (docs/pose.md) gives the start pose; setting it while playing jumps there, and reading it gives
 * the current view. pose-trace: when set, each frame that passes sends the next pose of the trace (the
 * last one holds) and navigation is ignored (docs/pose.md). server-clamped: counted from the frame's pose
 * meta (the RTP pose header extension); the view moves to the edge the server clamped it to.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! viewwarp ! rgbddemux name=d d.color ! posenav ! videoconvert ! fakesink
 * ]|
 */
// How mouse and keys move the view is ViewNavigator's (core/view_navigator.h); this element parses the
// sink's navigation events, keeps the view inside the rig's bounds and sends it upstream.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstposenav.h"

#include <gst/video/navigation.h>

#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_navigator.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/vva/navigation.h>

GST_DEBUG_CATEGORY_STATIC(pose_nav_debug);
#define GST_CAT_DEFAULT pose_nav_debug

using namespace vclassroom;

enum { PROP_0, PROP_RIG, PROP_REFERENCE_CAMERA, PROP_SLIDERS, PROP_POSE_TRACE, PROP_MOVE_STEP, PROP_TURN_SPEED, PROP_FOV, PROP_SEQ, PROP_SERVER_CLAMPED };

namespace {

struct NavState {
  std::mutex lock;  // everything below: navigation, properties and streaming meet here
  std::string rig_path;
  int reference_id = 0;
  std::string sliders_text = "[50,50,50,50,50,50]";
  std::string trace_path;
  double fov = 0;

  CameraCalib reference;        // from the rig, or the rig origin looking level along -Z
  NavigationClamp bounds;       // the rig's navigation bounds, when it has them
  ViewNavigator nav;            // start and current view relative to the reference; move-step, turn-speed
  std::vector<PoseSample> trace;
  size_t trace_index = 0;
  bool started = false;         // the start pose has been sent
  uint64_t seq = 0;
  uint64_t session = new_pose_session_id();  // this element's poses are one session: seq counts on within it
  uint64_t server_clamped = 0;  // frames showing the latest pose as the server moved it into its bounds
};

}  // namespace

struct _GstPoseNav {
  GstBaseTransform parent;
  NavState* st;
};

G_DEFINE_TYPE(GstPoseNav, gst_pose_nav, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(posenav, "posenav", GST_RANK_NONE, GST_TYPE_POSE_NAV)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);

// Clamps to the rig's navigation bounds; a rate-limited warning says so.
static bool clamp_to_navigation_locked(GstPoseNav* self, Pose* pose, const char* source) {
  std::string warning;
  const bool clamped = self->st->bounds.apply(pose, int64_t(g_get_monotonic_time()) * 1000, source, &warning);
  if (!warning.empty()) GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("%s", warning.c_str()), (nullptr));
  return clamped;
}

// Builds the event for `pose` (called with the lock held); nullptr if invalid.
static GstEvent* make_pose_event_locked(GstPoseNav* self, Pose pose) {
  NavState* st = self->st;
  pose.seq = ++st->seq;
  pose.session = st->session;
  pose.viewer_time_ns = static_cast<int64_t>(gst_util_get_timestamp());
  if (st->fov > 0) pose.fov_deg = st->fov;
  try {
    return pose_event_new(pose);
  } catch (const Error& e) {
    GST_WARNING_OBJECT(self, "not sending pose: %s", e.what());
    return nullptr;
  }
}

static void send_upstream(GstPoseNav* self, GstEvent* event) {
  if (!event) return;
  GST_LOG_OBJECT(self, "sending %" GST_PTR_FORMAT, gst_event_get_structure(event));
  gst_pad_push_event(GST_BASE_TRANSFORM_SINK_PAD(self), event);
}

// The view as the lecturer steers it stops at the rig's navigation bounds: a
// drag or key beyond them leaves the view at the edge (not a jump), and the
// view kept is the clamped one, so moving back responds at once.
static GstEvent* view_event_locked(GstPoseNav* self) {
  NavState* st = self->st;
  Pose pose = offset_to_pose(st->nav.view, st->reference);
  if (clamp_to_navigation_locked(self, &pose, "the lecturer's navigation"))
    st->nav.view = pose_to_offset(pose, st->reference);
  return make_pose_event_locked(self, pose);
}

// Applies one navigation event; true when posenav used (and so swallows) it.
static bool navigate_locked(GstPoseNav* self, GstEvent* event, GstEvent** pose_out) {
  NavState* st = self->st;
  if (!st->trace.empty()) return false;  // a trace drives the view
  ViewNavigator& nav = st->nav;
  Navigated result = Navigated::kNotOurs;
  double x, y, dx, dy;
  gint button;
  const char* key = nullptr;
  switch (gst_navigation_event_get_type(event)) {
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_PRESS:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y)) result = nav.press(button, x, y);
      break;
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_RELEASE:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y)) result = nav.release(button);
      break;
    case GST_NAVIGATION_EVENT_MOUSE_MOVE:
      if (gst_navigation_event_parse_mouse_move_event(event, &x, &y)) result = nav.pointer_move(x, y);
      break;
    case GST_NAVIGATION_EVENT_MOUSE_SCROLL:
      if (gst_navigation_event_parse_mouse_scroll_event(event, &x, &y, &dx, &dy)) result = nav.scroll(dy);
      break;
    case GST_NAVIGATION_EVENT_KEY_PRESS:
      if (gst_navigation_event_parse_key_event(event, &key) && key) result = nav.key_press(key);
      break;
    case GST_NAVIGATION_EVENT_KEY_RELEASE:
      if (gst_navigation_event_parse_key_event(event, &key) && key) result = nav.key_release(key);
      break;
    default:
      break;
  }
  if (result == Navigated::kMoved) *pose_out = view_event_locked(self);
  return result != Navigated::kNotOurs;
}

static gboolean gst_pose_nav_src_event(GstBaseTransform* trans, GstEvent* event) {
  GstPoseNav* self = GST_POSE_NAV(trans);
  if (GST_EVENT_TYPE(event) == GST_EVENT_NAVIGATION) {
    GstEvent* pose = nullptr;
    bool used;
    {
      std::lock_guard<std::mutex> g(self->st->lock);
      used = navigate_locked(self, event, &pose);
    }
    if (used) {
      gst_event_unref(event);
      send_upstream(self, pose);
      return TRUE;
    }
  }
  return GST_BASE_TRANSFORM_CLASS(gst_pose_nav_parent_class)->src_event(trans, event);
}

static GstFlowReturn gst_pose_nav_transform_ip(GstBaseTransform* trans, GstBuffer* buf) {
  GstPoseNav* self = GST_POSE_NAV(trans);
  GstEvent* pose = nullptr;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    NavState* st = self->st;
    if (!st->trace.empty()) {
      // One trace pose per frame, for reproducible runs; the last one holds.
      Pose p = st->trace[std::min(st->trace_index, st->trace.size() - 1)].pose;
      st->trace_index++;
      clamp_to_navigation_locked(self, &p, "the pose trace");
      pose = make_pose_event_locked(self, p);
    } else if (!st->started) {
      pose = view_event_locked(self);
    } else if (const PoseMeta* m = buffer_get_pose_meta(buf); m && m->rendered.clamped && m->seq == st->seq) {
      // The server moved the latest pose into its navigation bounds (bounds this posenav may not know): the
      // view moves to that edge too, so steering back responds at once.
      st->nav.view = pose_to_offset(pose_of(m->rendered), st->reference);
      st->server_clamped++;
    }
    st->started = true;
  }
  send_upstream(self, pose);
  return GST_FLOW_OK;
}

static gboolean gst_pose_nav_start(GstBaseTransform* trans) {
  GstPoseNav* self = GST_POSE_NAV(trans);
  NavState* st = self->st;
  std::lock_guard<std::mutex> g(st->lock);
  try {
    const Rig rig = st->rig_path.empty() ? Rig() : load_rig(st->rig_path);
    st->reference = st->rig_path.empty() ? rig_origin_reference() : rig.camera(st->reference_id);
    st->bounds = NavigationClamp(rig);
    st->nav.start = sliders_to_offset(parse_sliders(st->sliders_text));
    st->trace = st->trace_path.empty() ? std::vector<PoseSample>() : load_pose_trace(st->trace_path);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("%s", e.what()), ("posenav properties"));
    return FALSE;
  }
  st->nav.view = st->nav.start;
  st->nav.end_drag();
  st->trace_index = 0;
  st->started = false;
  return TRUE;
}

static void gst_pose_nav_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  GstPoseNav* self = GST_POSE_NAV(object);
  NavState* st = self->st;
  GstEvent* pose = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
    switch (prop_id) {
      case PROP_RIG: st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
      case PROP_REFERENCE_CAMERA: st->reference_id = g_value_get_int(value); break;
      case PROP_SLIDERS: {
        const std::string text = g_value_get_string(value) ? g_value_get_string(value) : "";
        try {
          const ViewOffset start = sliders_to_offset(parse_sliders(text));
          st->sliders_text = text;
          // While running, a new slider setting moves the view there at once.
          if (GST_STATE(self) >= GST_STATE_PAUSED && st->trace.empty()) {
            st->nav.start = st->nav.view = start;
            pose = view_event_locked(self);
          }
        } catch (const Error& e) {
          g_warning("posenav: %s", e.what());
        }
        break;
      }
      case PROP_POSE_TRACE: st->trace_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
      case PROP_MOVE_STEP: st->nav.move_step = g_value_get_double(value); break;
      case PROP_TURN_SPEED: st->nav.turn_speed = g_value_get_double(value); break;
      case PROP_FOV: st->fov = g_value_get_double(value); break;
      default:
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
    }
  }
  send_upstream(self, pose);
}

static void gst_pose_nav_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  NavState* st = GST_POSE_NAV(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_RIG: g_value_set_string(value, st->rig_path.c_str()); break;
    case PROP_REFERENCE_CAMERA: g_value_set_int(value, st->reference_id); break;
    case PROP_SLIDERS:
      // The current view in the slider notation (it may lie outside 0..100 after free navigation).
      g_value_set_string(value, GST_STATE(object) >= GST_STATE_PAUSED
                                    ? format_sliders(offset_to_sliders(st->nav.view)).c_str()
                                    : st->sliders_text.c_str());
      break;
    case PROP_POSE_TRACE: g_value_set_string(value, st->trace_path.c_str()); break;
    case PROP_MOVE_STEP: g_value_set_double(value, st->nav.move_step); break;
    case PROP_TURN_SPEED: g_value_set_double(value, st->nav.turn_speed); break;
    case PROP_FOV: g_value_set_double(value, st->fov); break;
    case PROP_SEQ: g_value_set_uint64(value, st->seq); break;
    case PROP_SERVER_CLAMPED: g_value_set_uint64(value, st->server_clamped); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_nav_finalize(GObject* object) {
  delete GST_POSE_NAV(object)->st;
  G_OBJECT_CLASS(gst_pose_nav_parent_class)->finalize(object);
}

static void gst_pose_nav_class_init(GstPoseNavClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_pose_nav_set_property;
  gobject_class->get_property = gst_pose_nav_get_property;
  gobject_class->finalize = gst_pose_nav_finalize;
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto playing = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML file the sliders and navigation are relative to (empty = the rig origin)",
                          "", ready));
  g_object_class_install_property(gobject_class, PROP_REFERENCE_CAMERA,
                                  g_param_spec_int("reference-camera", "Reference camera",
                                                   "Id of the rig camera that [50,50,50,50,50,50] stands for", 0,
                                                   G_MAXINT, 0, ready));
  g_object_class_install_property(
      gobject_class, PROP_SLIDERS,
      g_param_spec_string("sliders", "Sliders",
                          "Six-slider view [right,up,forward,yaw,pitch,roll], each 0..100 (50 = the reference camera)",
                          "[50,50,50,50,50,50]", playing));
  g_object_class_install_property(
      gobject_class, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace file to play, one pose per frame (empty = navigate with the mouse and keys)",
                          "", ready));
  g_object_class_install_property(gobject_class, PROP_MOVE_STEP,
                                  g_param_spec_double("move-step", "Move step",
                                                      "Metres moved per key press or wheel notch", 0.001, 10,
                                                      ViewNavigator::kDefaultMoveStep, playing));
  g_object_class_install_property(gobject_class, PROP_TURN_SPEED,
                                  g_param_spec_double("turn-speed", "Turn speed",
                                                      "Degrees turned per pixel dragged with the left button", 0.001,
                                                      10, ViewNavigator::kDefaultTurnSpeed, playing));
  g_object_class_install_property(
      gobject_class, PROP_FOV,
      g_param_spec_double("fov", "Field of view",
                          "Horizontal field of view (degrees) asked of the server; 0 = the server's default", 0, 179,
                          0, playing));
  g_object_class_install_property(
      gobject_class, PROP_SEQ,
      g_param_spec_uint64("seq", "Last sequence number", "seq of the last pose event sent", 0, G_MAXUINT64, 0,
                          GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      gobject_class, PROP_SERVER_CLAMPED,
      g_param_spec_uint64("server-clamped", "Frames clamped by the server",
                          "Frames showing the latest pose clamped by the server into its navigation bounds",
                          0, G_MAXUINT64, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Lecturer pose navigation", "Filter/Video",
      "Turns the lecturer's mouse and keys into pose events sent upstream", "gst-vclassroom developers");
  trans_class->src_event = GST_DEBUG_FUNCPTR(gst_pose_nav_src_event);
  trans_class->transform_ip = GST_DEBUG_FUNCPTR(gst_pose_nav_transform_ip);
  trans_class->start = GST_DEBUG_FUNCPTR(gst_pose_nav_start);
  trans_class->transform_ip_on_passthrough = TRUE;
  GST_DEBUG_CATEGORY_INIT(pose_nav_debug, "posenav", 0, "lecturer pose navigation");
}

static void gst_pose_nav_init(GstPoseNav* self) {
  self->st = new NavState();
  self->st->reference = rig_origin_reference();
  gst_base_transform_set_passthrough(GST_BASE_TRANSFORM(self), TRUE);
}
