/**
 * SECTION:element-whepviewsink
 * @title: whepviewsink
 *
 * Each lecturer joining over WHEP gets a view of their own: the prepared camera streams (cam_%u, after
 * learnerseg), each with its memory and warp preparation done once (viewprep), feed, per session, a viewwarp
 * per camera, a viewfuse steered by that lecturer's pose data channel only, and an H.264 encoder to their
 * webrtcbin; the views take turns to warp, and sessions come and go without disturbing the others.
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
// whepviewsink: a view per lecturer. Each camera's prepared stream (after
// decoding, V-DA and learnerseg, which run once per camera) comes in on a cam_%u
// pad, gets its memory and the warp's first half once (viewprep) and is teed;
// each WHEP session gets its own branch, a viewwarp per camera and a viewfuse
// steered by that session's poses only, encoded by its own x264enc. The views
// take turns to warp (ViewTurns). Sessions join and leave without touching the
// others' branches, and a camera linked while lecturers watch joins every view;
// the WHEP server, signalling, data channel and echo are WhepEndpoint's.
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
#include <gst/vclassroom/vva/warp_start.h>

#include <gst/vclassroom/core/limits.h>

#include "gstwhepviewsink.h"
#include "whep_endpoint.h"

using namespace vclassroom;

GST_DEBUG_CATEGORY_STATIC(whepview_debug);
#define GST_CAT_DEFAULT whepview_debug

namespace {

struct Camera {
  int index;             // K of the cam_K pad: the viewfuse pad, and cam<K>.png among the model's priors
  GstElement* tee;
};

// A camera's tee and a pad on one side of it: a view's branch input not linked yet, or the tee's request pad.
struct TeeLink {
  GstElement* tee;
  GstPad* pad;  // a reference
};

// One lecturer's view: per camera tee pad -> queue -> viewwarp -> fuse; fuse -> convert -> x264enc -> caps.
// The camera's viewprep before its tee has done the memory and the warp's first half once for all views.
struct View {
  uint64_t id = 0;                   // its number among the views taking turns
  bool started = false;              // its webrtcbin is linked: camera branches are fed at once
  std::vector<TeeLink> unlinked;     // branch inputs until start_view links them to their tees
  std::vector<TeeLink> tee_pads;
  std::vector<GstElement*> elements;
  GstElement* fuse = nullptr;
  GstElement* encoder = nullptr;  // its bitrate follows this lecturer's losses
  PoseSession poses;  // this lecturer's: latest wins
};

struct ViewSettings {
  std::string rig, navigation_rig, model;
  int width = 0, height = 0;
  guint64 fuse_latency = 100 * GST_MSECOND;
  guint64 warp_sync = 100 * GST_MSECOND;
  guint64 longest_turn = 100 * GST_MSECOND;
  int background_memory = 0;  // frames; 0: off
};

}  // namespace

struct _GstWhepViewSink {
  GstBin parent;
  WhepEndpoint* endpoint;
  std::mutex* lock;  // everything below
  ViewSettings* settings;
  std::vector<Camera>* cameras;
  std::map<std::string, View>* views;
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

static GstElement* add_element(GstWhepViewSink* self, View* view, const char* factory) {
  GstElement* e = gst_element_factory_make(factory, nullptr);
  if (!e) return nullptr;
  gst_bin_add(GST_BIN(self), e);
  view->elements.push_back(e);
  return e;
}

// A view's viewwarp takes its turn once viewfuse has let it start (the warp-start query's answer, which
// names the round of the view's cameras), and ends it when its frame is out.
struct TurnTaker {
  ViewTurns* turns;
  uint64_t view;
};

static GstPadProbeReturn take_turn(GstPad*, GstPadProbeInfo* info, gpointer data) {
  const TurnTaker* taker = static_cast<const TurnTaker*>(data);
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
    taker->turns->end(taker->view);
    return GST_PAD_PROBE_OK;
  }
  if (!(GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_PULL)) return GST_PAD_PROBE_OK;  // not answered yet
  GstQuery* query = GST_PAD_PROBE_INFO_QUERY(info);
  const GstStructure* s = GST_QUERY_TYPE(query) == GST_QUERY_CUSTOM ? gst_query_get_structure(query) : nullptr;
  guint64 group;
  if (s && gst_structure_has_name(s, kWarpStartQueryName) && gst_structure_get_uint64(s, "group", &group))
    taker->turns->begin(taker->view, group);
  return GST_PAD_PROBE_OK;
}

// Camera `cam`'s branch of a view (lock held): queue -> viewwarp -> the fuse's cam_K pad, fed from the
// camera's tee at once when the view has started (a camera linked while lecturers watch), else when it does.
static void add_camera_branch_locked(GstWhepViewSink* self, View* view, const Camera& cam) {
  const ViewSettings& s = *self->settings;
  GstElement* queue = add_element(self, view, "queue");
  GstElement* warp = add_element(self, view, "viewwarp");
  g_object_set(queue, "max-size-buffers", 1, "max-size-time", guint64(0), "max-size-bytes", 0, nullptr);
  gst_util_set_object_arg(G_OBJECT(queue), "leaky", "downstream");
  g_object_set(warp, "width", s.width, "height", s.height, nullptr);
  if (!s.rig.empty()) g_object_set(warp, "rig", s.rig.c_str(), nullptr);
  gst_element_link(queue, warp);
  GstPad* warp_src = gst_element_get_static_pad(warp, "src");
  gst_pad_add_probe(warp_src, GstPadProbeType(GST_PAD_PROBE_TYPE_QUERY_DOWNSTREAM | GST_PAD_PROBE_TYPE_BUFFER), take_turn,
                    new TurnTaker{self->turns, view->id}, [](gpointer p) { delete static_cast<TurnTaker*>(p); });
  gst_object_unref(warp_src);
  const std::string fuse_pad = "cam_" + std::to_string(cam.index);
  gst_element_link_pads(warp, "src", view->fuse, fuse_pad.c_str());
  gst_element_sync_state_with_parent(warp);
  gst_element_sync_state_with_parent(queue);
  TeeLink input{cam.tee, gst_element_get_static_pad(queue, "sink")};
  if (!view->started) {
    view->unlinked.push_back(input);
    return;
  }
  GstPad* tee_pad = gst_element_request_pad_simple(cam.tee, "src_%u");
  gst_pad_link(tee_pad, input.pad);
  gst_object_unref(input.pad);
  view->tee_pads.push_back(TeeLink{cam.tee, tee_pad});
}

// Builds a session's view branch (lock held); its encoded source pad (a reference), or nullptr.
static GstPad* attach_view_locked(GstWhepViewSink* self, const std::string& session) {
  const ViewSettings& s = *self->settings;
  if (self->cameras->empty()) {
    GST_WARNING_OBJECT(self, "a lecturer joined before any camera was linked: refused");
    return nullptr;
  }
  for (const char* factory : {"queue", "viewwarp", "viewfuse", "videoconvert", "x264enc", "capsfilter"})
    if (GstElementFactory* f = gst_element_factory_find(factory)) {
      gst_object_unref(f);
    } else {
      GST_ELEMENT_WARNING(self, CORE, MISSING_PLUGIN, ("no %s element: a lecturer's view cannot be made", factory),
                          ("x264enc is in gstreamer1.0-plugins-ugly"));
      return nullptr;
    }
  View& view = (*self->views)[session];
  view.id = ++self->last_view_id;
  view.fuse = add_element(self, &view, "viewfuse");
  GstElement* convert = add_element(self, &view, "videoconvert");
  GstElement* encoder = view.encoder = add_element(self, &view, "x264enc");
  GstElement* caps = add_element(self, &view, "capsfilter");
  // Started late in a live pipeline: the fused output starts at the first frame, not at running time 0.
  gst_util_set_object_arg(G_OBJECT(view.fuse), "start-time-selection", "first");
  g_object_set(view.fuse, "latency", s.fuse_latency, "warp-sync", s.warp_sync, nullptr);
  if (!s.navigation_rig.empty()) g_object_set(view.fuse, "rig", s.navigation_rig.c_str(), nullptr);
  gst_util_set_object_arg(G_OBJECT(encoder), "tune", "zerolatency");
  gst_util_set_object_arg(G_OBJECT(encoder), "speed-preset", "ultrafast");
  g_object_set(encoder, "key-int-max", 60, "bitrate", self->endpoint->bitrate_kbit(), nullptr);
  GstCaps* c = gst_caps_from_string("video/x-h264,profile=constrained-baseline,stream-format=byte-stream");
  g_object_set(caps, "caps", c, nullptr);
  gst_caps_unref(c);
  gst_element_link_many(view.fuse, convert, encoder, caps, nullptr);
  for (auto it = view.elements.rbegin(); it != view.elements.rend(); ++it) gst_element_sync_state_with_parent(*it);
  for (const Camera& cam : *self->cameras) add_camera_branch_locked(self, &view, cam);
  GST_INFO_OBJECT(self, "session %s: a view of %zu cameras", session.c_str(), self->cameras->size());
  return gst_element_get_static_pad(caps, "src");
}

// The session's webrtcbin is linked: the cameras' frames may flow into its view.
static void start_view(GstWhepViewSink* self, const std::string& session) {
  std::lock_guard<std::mutex> g(*self->lock);
  auto it = self->views->find(session);
  if (it == self->views->end()) return;
  View& view = it->second;
  for (const TeeLink& input : view.unlinked) {
    GstPad* tee_pad = gst_element_request_pad_simple(input.tee, "src_%u");
    gst_pad_link(tee_pad, input.pad);
    gst_object_unref(input.pad);
    view.tee_pads.push_back(TeeLink{input.tee, tee_pad});
  }
  view.unlinked.clear();
  view.started = true;
}

// Takes a session's view out (the endpoint has unlinked its encoded pad).
static void detach_view(GstWhepViewSink* self, const std::string& session) {
  View view;
  {
    std::lock_guard<std::mutex> g(*self->lock);
    auto it = self->views->find(session);
    if (it == self->views->end()) return;
    view = std::move(it->second);
    self->views->erase(it);
  }
  self->turns->forget(view.id);  // its cameras waiting for their turn go, and their threads can stop
  for (const TeeLink& input : view.unlinked) gst_object_unref(input.pad);  // never started
  for (const TeeLink& link : view.tee_pads) {
    GstPad* peer = gst_pad_get_peer(link.pad);
    if (peer) {
      gst_pad_unlink(link.pad, peer);
      gst_object_unref(peer);
    }
    gst_element_release_request_pad(link.tee, link.pad);
    gst_object_unref(link.pad);
  }
  for (GstElement* e : view.elements) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(GST_BIN(self), e);
  }
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

static GstPad* gst_whep_view_sink_request_new_pad(GstElement* element, GstPadTemplate* templ, const gchar* name,
                                                  const GstCaps*) {
  GstWhepViewSink* self = GST_WHEP_VIEW_SINK(element);
  std::lock_guard<std::mutex> g(*self->lock);
  int index = 0;
  if (name && sscanf(name, "cam_%d", &index) != 1) return nullptr;
  if (!name)
    while (std::any_of(self->cameras->begin(), self->cameras->end(), [&](const Camera& c) { return c.index == index; }))
      ++index;
  for (const Camera& c : *self->cameras)
    if (c.index == index) return nullptr;  // that camera is linked already
  GstElement* prep = gst_element_factory_make("viewprep", nullptr);
  GstElement* tee = gst_element_factory_make("tee", nullptr);
  if (!prep || !tee) {
    if (prep) gst_object_unref(prep);
    if (tee) gst_object_unref(tee);
    return nullptr;
  }
  // The memory and the warp's first half, once for every view of this camera.
  const ViewSettings& s = *self->settings;
  const std::string camera = "cam" + std::to_string(index) + ".png";
  if (!s.model.empty()) g_object_set(prep, "prior-depth", (s.model + "/prior-depth/" + camera).c_str(), nullptr);
  if (s.background_memory > 0) {
    g_object_set(prep, "background-memory", s.background_memory, nullptr);
    if (!s.model.empty()) g_object_set(prep, "empty-room", (s.model + "/prior-color/" + camera).c_str(), nullptr);
  }
  g_object_set(tee, "allow-not-linked", TRUE, nullptr);
  // The camera's one permanent branch: a sink, so the bin posts EOS whether or not anyone watches.
  GstElement* drain = gst_element_factory_make("fakesink", nullptr);
  g_object_set(drain, "sync", FALSE, "async", FALSE, nullptr);
  gst_bin_add_many(GST_BIN(self), prep, tee, drain, nullptr);
  gst_element_link_many(prep, tee, drain, nullptr);
  gst_element_sync_state_with_parent(drain);
  gst_element_sync_state_with_parent(tee);
  gst_element_sync_state_with_parent(prep);
  GstPad* target = gst_element_get_static_pad(prep, "sink");
  const std::string pad_name = "cam_" + std::to_string(index);
  GstPad* pad = gst_ghost_pad_new_from_template(pad_name.c_str(), target, templ);
  gst_object_unref(target);
  gst_pad_set_active(pad, TRUE);
  gst_element_add_pad(element, pad);
  self->cameras->push_back(Camera{index, tee});
  // Lecturers already watching see the new camera too.
  for (auto& [session, view] : *self->views) {
    GST_INFO_OBJECT(self, "camera %d joins the view of session %s", index, session.c_str());
    add_camera_branch_locked(self, &view, self->cameras->back());
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
  ViewSettings& s = *self->settings;
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
  const ViewSettings& s = *self->settings;
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
  self->settings = new ViewSettings;
  self->cameras = new std::vector<Camera>;
  self->views = new std::map<std::string, View>;
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
  gst_element_class_set_static_metadata(element_class, "WHEP view-per-lecturer sink", "Sink/Network",
      "Renders and sends each lecturer a view of their own over WebRTC with WHEP", "gst-vclassroom");
}
