/**
 * SECTION:element-whepviewsink
 * @title: whepviewsink
 *
 * Each lecturer joining over WHEP gets a view of their own: the prepared camera streams (cam_%u, after
 * learnerseg), each with its memory and warp preparation done once (viewprep), feed, per session, a viewwarp
 * per camera, a viewfuse steered by that lecturer's pose data channel only, and an H.264 encoder to their
 * webrtcbin; the views take turns to warp, and sessions come and go without disturbing the others. A camera
 * linked while lecturers watch joins every view. The classroom's sound (audio/x-opus on the request pad
 * `audio`) goes to every lecturer whose browser offers Opus; the request pad `voice` gives the lecturers'
 * microphones mixed, for the classroom's loudspeaker.
 *
 * ## Properties
 *
 * model: camera K's viewprep reads MODEL/prior-depth/camK.png and, with background-memory, starts its
 * memory of the room from MODEL/prior-color/camK.png (docs/vva.md); the memory is kept once for every view.
 * warp-sync: each view's cameras wait for each other two thirds of their frame interval, never longer
 * than this (viewfuse's warp-sync). longest-turn: the views take turns to warp, each view's cameras on all
 * cores while the others wait before reading their poses, so a frame's pose is as old as one view's warps,
 * not all views'; a view holding the turn longer than this loses it to the next (docs/lecturer.md).
 * The WHEP server's properties are whepserversink's; docs/lecturer.md describes them (bitrate,
 * playout-delay, lecturer-timeout, listen-addresses, http-timeout, stun-server, turn-server).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 whepviewsink name=w port=0 token=secret max-sessions=2 rgbdtestsrc camera-id=0 num-buffers=30 ! learnerseg ! w.cam_0
 * ]|
 */
// The views' elements are built in whep_view_branch.cpp; the WHEP server, signalling, data channel and echo
// are WhepEndpoint's (whep_endpoint.h).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/vva/view_turns.h>

#include <gst/vclassroom/core/limits.h>

#include "gstwhepviewsink.h"
#include "whep_endpoint.h"
#include "whep_view_branch.h"

using namespace vclassroom;

GST_DEBUG_CATEGORY_STATIC(whepview_debug);
#define GST_CAT_DEFAULT whepview_debug

struct _GstWhepViewSink {
  GstBin parent;
  WhepEndpoint* endpoint;
  std::mutex* lock;  // everything below
  WhepViewSettings* settings;
  std::vector<WhepCamera>* cameras;
  std::map<std::string, WhepView>* views;
  uint64_t last_view_id;
  ViewTurns* turns;  // thread-safe itself
};
typedef struct _GstWhepViewSink GstWhepViewSink;
struct GstWhepViewSinkClass {
  GstBinClass parent_class;
};

G_DEFINE_TYPE(GstWhepViewSink, gst_whep_view_sink, GST_TYPE_BIN)
GST_ELEMENT_REGISTER_DEFINE(whepviewsink, "whepviewsink", GST_RANK_NONE, GST_TYPE_WHEP_VIEW_SINK)
#define GST_WHEP_VIEW_SINK(o) ((GstWhepViewSink*)(o))

enum {
  PROP_0, PROP_RIG, PROP_NAVIGATION_RIG, PROP_MODEL, PROP_WIDTH, PROP_HEIGHT, PROP_FUSE_LATENCY, PROP_WARP_SYNC,
  PROP_BACKGROUND_MEMORY, PROP_LONGEST_TURN,
  PROP_ENDPOINT_FIRST
};

static GstStaticPadTemplate cam_template =
    GST_STATIC_PAD_TEMPLATE("cam_%u", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS("video/x-rgbd"));

// Builds a session's view (lock held); its encoded source pad (a reference), or nullptr.
static GstPad* attach_view_locked(GstWhepViewSink* self, const std::string& session) {
  if (self->cameras->empty()) {
    GST_WARNING_OBJECT(self, "a lecturer joined before any camera was linked: refused");
    return nullptr;
  }
  if (!whep_view_elements_present(GST_ELEMENT(self))) return nullptr;
  WhepView& view = (*self->views)[session];
  view.id = ++self->last_view_id;
  GstPad* encoded = whep_view_build(GST_BIN(self), &view, *self->settings, self->endpoint->bitrate_kbit());
  for (const WhepCamera& cam : *self->cameras)
    whep_view_add_camera(GST_BIN(self), &view, *self->settings, cam, self->turns);
  GST_INFO_OBJECT(self, "session %s: a view of %zu cameras", session.c_str(), self->cameras->size());
  return encoded;
}

// The session's webrtcbin is linked: the cameras' frames may flow into its view.
static void start_view(GstWhepViewSink* self, const std::string& session) {
  std::lock_guard<std::mutex> g(*self->lock);
  auto it = self->views->find(session);
  if (it != self->views->end()) whep_view_start(&it->second);
}

// Takes a session's view out (the endpoint has unlinked its encoded pad).
static void detach_view(GstWhepViewSink* self, const std::string& session) {
  WhepView view;
  {
    std::lock_guard<std::mutex> g(*self->lock);
    auto it = self->views->find(session);
    if (it == self->views->end()) return;
    view = std::move(it->second);
    self->views->erase(it);
  }
  self->turns->forget(view.id);  // its cameras waiting for their turn go, and their threads can stop
  whep_view_remove(GST_BIN(self), &view);
  GST_INFO_OBJECT(self, "session %s: its view is gone", session.c_str());
}

// A lecturer's pose steers its own view only.
static void on_session_pose(GstWhepViewSink* self, const std::string& session, const Pose& pose) {
  GstPad* fuse_src = nullptr;
  {
    std::lock_guard<std::mutex> g(*self->lock);
    auto it = self->views->find(session);
    if (it == self->views->end()) return;
    const PoseVerdict v = it->second.poses.offer(session, pose.seq, pose.viewer_time_ns, g_get_monotonic_time() * 1000);
    if (!pose_verdict_obeys(v)) return;
    fuse_src = gst_element_get_static_pad(it->second.fuse, "src");
  }
  Pose named = pose;
  named.session = pose_session_id("whep " + session);
  gst_pad_send_event(fuse_src, pose_event_new(named));
  gst_object_unref(fuse_src);
}

// The sound pads are the endpoint's; a camera's pad goes as GstElement would take it without this.
static void gst_whep_view_sink_release_pad(GstElement* element, GstPad* pad) {
  if (!GST_WHEP_VIEW_SINK(element)->endpoint->release_pad(pad)) gst_element_remove_pad(element, pad);
}

static GstPad* gst_whep_view_sink_request_new_pad(GstElement* element, GstPadTemplate* templ, const gchar* name,
                                                  const GstCaps*) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(element);
  if (templ != gst_element_class_get_pad_template(GST_ELEMENT_GET_CLASS(element), "cam_%u"))
    return self->endpoint->request_pad(templ);
  std::lock_guard<std::mutex> g(*self->lock);
  int index = 0;
  if (name && sscanf(name, "cam_%d", &index) != 1) return nullptr;
  if (!name)
    while (std::any_of(self->cameras->begin(), self->cameras->end(), [&](const WhepCamera& c) { return c.index == index; }))
      ++index;
  for (const WhepCamera& c : *self->cameras)
    if (c.index == index) return nullptr;  // that camera is linked already
  WhepCamera camera;
  GstPad* target = whep_camera_add(GST_BIN(self), index, *self->settings, &camera);
  if (!target) return nullptr;
  const std::string pad_name = "cam_" + std::to_string(index);
  GstPad* pad = gst_ghost_pad_new_from_template(pad_name.c_str(), target, templ);
  gst_object_unref(target);
  gst_pad_set_active(pad, TRUE);
  gst_element_add_pad(element, pad);
  self->cameras->push_back(camera);
  // Lecturers already watching see the new camera too.
  for (auto& [session, view] : *self->views) {
    GST_INFO_OBJECT(self, "camera %d joins the view of session %s", index, session.c_str());
    whep_view_add_camera(GST_BIN(self), &view, *self->settings, camera, self->turns);
  }
  return pad;
}

static GstStateChangeReturn gst_whep_view_sink_change_state(GstElement* element, GstStateChange transition) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY && !self->endpoint->start()) return GST_STATE_CHANGE_FAILURE;
  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) self->turns->resume();
  if (transition == GST_STATE_CHANGE_PAUSED_TO_READY) self->turns->release();  // before the streaming threads stop
  GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_whep_view_sink_parent_class)->change_state(element, transition);
  if (transition == GST_STATE_CHANGE_READY_TO_NULL) self->endpoint->stop();
  return ret;
}

static void gst_whep_view_sink_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(object);
  if (id >= PROP_ENDPOINT_FIRST) {
    if (!self->endpoint->set_property(id - PROP_ENDPOINT_FIRST, value)) G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
    return;
  }
  std::lock_guard<std::mutex> g(*self->lock);
  WhepViewSettings& s = *self->settings;
  auto str = [&] { const char* v = g_value_get_string(value); return std::string(v ? v : ""); };
  switch (id) {
    case PROP_RIG: s.rig = str(); break;
    case PROP_NAVIGATION_RIG: s.navigation_rig = str(); break;
    case PROP_MODEL: s.model = str(); break;
    case PROP_WIDTH: s.width = g_value_get_int(value); break;
    case PROP_HEIGHT: s.height = g_value_get_int(value); break;
    case PROP_FUSE_LATENCY: s.fuse_latency = g_value_get_uint64(value); break;
    case PROP_WARP_SYNC: s.warp_sync = g_value_get_uint64(value); break;
    case PROP_BACKGROUND_MEMORY: s.background_memory = g_value_get_int(value); break;
    case PROP_LONGEST_TURN: {
      s.longest_turn = g_value_get_uint64(value);
      ViewTurnsParams p;
      p.longest_turn_ns = int64_t(s.longest_turn);
      self->turns->set_params(p);
      break;
    }
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_whep_view_sink_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(object);
  if (id >= PROP_ENDPOINT_FIRST) {
    if (!self->endpoint->get_property(id - PROP_ENDPOINT_FIRST, value)) G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
    return;
  }
  std::lock_guard<std::mutex> g(*self->lock);
  const WhepViewSettings& s = *self->settings;
  switch (id) {
    case PROP_RIG: g_value_set_string(value, s.rig.c_str()); break;
    case PROP_NAVIGATION_RIG: g_value_set_string(value, s.navigation_rig.c_str()); break;
    case PROP_MODEL: g_value_set_string(value, s.model.c_str()); break;
    case PROP_WIDTH: g_value_set_int(value, s.width); break;
    case PROP_HEIGHT: g_value_set_int(value, s.height); break;
    case PROP_FUSE_LATENCY: g_value_set_uint64(value, s.fuse_latency); break;
    case PROP_WARP_SYNC: g_value_set_uint64(value, s.warp_sync); break;
    case PROP_BACKGROUND_MEMORY: g_value_set_int(value, s.background_memory); break;
    case PROP_LONGEST_TURN: g_value_set_uint64(value, s.longest_turn); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_whep_view_sink_init(GstWhepViewSink* self) {
  self->lock = new std::mutex;
  self->settings = new WhepViewSettings;
  self->cameras = new std::vector<WhepCamera>;
  self->views = new std::map<std::string, WhepView>;
  self->last_view_id = 0;
  self->turns = new ViewTurns;
  WhepEndpointHooks hooks;
  hooks.attach = [self](const std::string& session) {
    std::lock_guard<std::mutex> g(*self->lock);
    return attach_view_locked(self, session);
  };
  hooks.start = [self](const std::string& session) { start_view(self, session); };
  hooks.detach = [self](const std::string& session, GstPad*) { detach_view(self, session); };
  hooks.pose = [self](const std::string& session, const Pose& pose) { on_session_pose(self, session, pose); };
  hooks.rate = [self](const std::string& session, int kbit) {
    std::lock_guard<std::mutex> g(*self->lock);
    auto it = self->views->find(session);
    if (it != self->views->end() && it->second.encoder)
      g_object_set(it->second.encoder, "bitrate", guint(kbit), nullptr);
  };
  self->endpoint = new WhepEndpoint(GST_BIN(self), "whepviewsink", std::move(hooks));
}

static void gst_whep_view_sink_finalize(GObject* object) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(object);
  delete self->endpoint;
  delete self->views;
  delete self->turns;
  delete self->cameras;
  delete self->settings;
  delete self->lock;
  G_OBJECT_CLASS(gst_whep_view_sink_parent_class)->finalize(object);
}

static void gst_whep_view_sink_class_init(GstWhepViewSinkClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GST_DEBUG_CATEGORY_INIT(whepview_debug, "whepviewsink", 0, "A view per WebRTC lecturer");
  gobject_class->set_property = gst_whep_view_sink_set_property;
  gobject_class->get_property = gst_whep_view_sink_get_property;
  gobject_class->finalize = gst_whep_view_sink_finalize;
  element_class->change_state = gst_whep_view_sink_change_state;
  element_class->request_new_pad = gst_whep_view_sink_request_new_pad;
  element_class->release_pad = gst_whep_view_sink_release_pad;
  const GParamFlags rw = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig", "Rig YAML of the cameras, for every view's viewwarp (empty: the caps' calibration)", "", rw));
  g_object_class_install_property(gobject_class, PROP_NAVIGATION_RIG,
      g_param_spec_string("navigation-rig", "Navigation rig",
                          "Rig YAML with navigation bounds, for every view's viewfuse (docs/navigation.md; empty: unbounded)", "", rw));
  g_object_class_install_property(gobject_class, PROP_MODEL,
      g_param_spec_string("model", "Model", "Static model folder of vclassroom-build-model for the viewpreps (empty = none)", "",
                          rw));
  g_object_class_install_property(gobject_class, PROP_WIDTH,
      g_param_spec_int("width", "Width", "Width of every view (0: the cameras')", 0, kMaxImageSide, 0, rw));
  g_object_class_install_property(gobject_class, PROP_HEIGHT,
      g_param_spec_int("height", "Height", "Height of every view (0: the cameras')", 0, kMaxImageSide, 0, rw));
  g_object_class_install_property(gobject_class, PROP_FUSE_LATENCY,
      g_param_spec_uint64("fuse-latency", "Fuse latency", "Each view's viewfuse waits this long (ns) for a late camera",
                          0, G_MAXUINT64, 100 * GST_MSECOND, rw));
  g_object_class_install_property(gobject_class, PROP_WARP_SYNC,
      g_param_spec_uint64("warp-sync", "Warp sync",
                          "Longest wait of a view's cameras for each other before reading the pose, in ns (0 = no wait)",
                          0, 60 * GST_SECOND, 100 * GST_MSECOND, rw));
  g_object_class_install_property(gobject_class, PROP_BACKGROUND_MEMORY,
      g_param_spec_int("background-memory", "Background memory",
                       "Frames in each camera's background memory of the room (0 = off)", 0, 64, 0, rw));
  g_object_class_install_property(gobject_class, PROP_LONGEST_TURN,
      g_param_spec_uint64("longest-turn", "Longest turn",
                          "Longest a view may hold its turn to warp, in ns (0 = every view warps at once)", 0, ViewTurnsParams::kLongestTurnNs, 100 * GST_MSECOND,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  WhepEndpoint::install_properties(gobject_class, PROP_ENDPOINT_FIRST);
  gst_element_class_add_static_pad_template(element_class, &cam_template);
  WhepEndpoint::add_sound_pad_templates(element_class);
  gst_element_class_set_static_metadata(element_class, "WHEP view-per-lecturer sink", "Sink/Network",
      "Renders and sends each lecturer a view of their own over WebRTC with WHEP", "gst-vclassroom");
}
