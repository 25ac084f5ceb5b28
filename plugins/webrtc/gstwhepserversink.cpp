/**
 * SECTION:element-whepserversink
 * @title: whepserversink
 *
 * The rendered view to browsers over WebRTC (H.264 constrained baseline, DTLS-SRTP) with WHEP signalling
 * (POST /whep?token=..., DELETE the Location to leave); the pose comes back over a data channel as the
 * vclassroom/pose event upstream. Every lecturer sees the same view (whepviewsink: a view each). The
 * classroom's sound (audio/x-opus on the request pad `audio`) goes to every lecturer whose browser offers Opus;
 * the request pad `voice` gives the lecturers' microphones mixed, for the classroom's loudspeaker.
 *
 * ## Properties
 *
 * bitrate is the most a lecturer gets: each session's rate follows the losses its browser reports, posting
 * a vclassroom-lecturer-bitrate element message (session, kbit, fraction-lost) on each change; the shared
 * encoder takes the lowest. playout-delay is sent, with a minimum of 0, as the playout-delay RTP header
 * extension where the offer lists it, so the browser shows frames as soon as they are decoded instead of
 * growing a jitter buffer. A lecturer whose browser sends no receiver report for lecturer-timeout seconds
 * while their view is sent (a closed laptop, a lost network, a handshake never finished) is taken as gone:
 * the session ends with a warning and its place is freed. listen-addresses: 0.0.0.0 is every IPv4
 * interface, :: every IPv6 one (skipped where the system has no IPv6), or one interface's address such as
 * 192.168.1.10. http-timeout: the seconds from a connection's accept to the end of its request (headers
 * and body), and the longest a read or write on it may wait; slower or idle connections are closed.
 * stun-server: each session's ICE also gathers the address a NAT shows and the page is told to use it
 * (WHEP OPTIONS Link header). turn-server: a relay for lecturers behind NATs that let no direct path
 * through; the page gets it with its credentials. See docs/lecturer.md.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=30 ! video/x-raw,width=960,height=540 ! whepserversink port=0 token=secret
 * ]|
 */
// H.264 is encoded once (x264enc zerolatency) and teed to a webrtcbin per WHEP session; the HTTP server,
// signalling, the pose data channel and the per-frame echo are WhepEndpoint's (whep_endpoint.h); poses
// from all sessions steer the one view, latest wins (PoseSession).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>
#include <gst/video/video.h>

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/net/pose_session.h>

#include "gstwhepserversink.h"
#include "whep_endpoint.h"

using namespace vclassroom;

GST_DEBUG_CATEGORY_STATIC(whep_debug);
#define GST_CAT_DEFAULT whep_debug

struct _GstWhepServerSink {
  GstBin parent;
  GstPad* sinkpad;
  GstElement* encoder;
  GstElement* tee;
  WhepEndpoint* endpoint;
  std::mutex* lock;     // guards poses and rates
  // Held from a pose's verdict until its event has reached the cameras, so the renderers see the sessions'
  // poses in the order they were judged (never taken under `lock`).
  std::mutex* pose_order;
  PoseSession* poses;   // latest wins across the sessions
  std::map<std::string, int>* rates;  // each session's kbit/s after its losses (the one encoder takes the least)
};
typedef struct _GstWhepServerSink GstWhepServerSink;
struct GstWhepServerSinkClass {
  GstBinClass parent_class;
};

G_DEFINE_TYPE(GstWhepServerSink, gst_whep_server_sink, GST_TYPE_BIN)
GST_ELEMENT_REGISTER_DEFINE(whepserversink, "whepserversink", GST_RANK_NONE, GST_TYPE_WHEP_SERVER_SINK)
#define GST_WHEP_SERVER_SINK(o) ((GstWhepServerSink*)(o))

enum { PROP_0, PROP_ENDPOINT_FIRST };

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("video/x-raw"));

static GstPad* gst_whep_server_sink_request_new_pad(GstElement* element, GstPadTemplate* templ, const gchar*,
                                                    const GstCaps*) {
  return GST_WHEP_SERVER_SINK(element)->endpoint->request_pad(templ);
}

static void gst_whep_server_sink_release_pad(GstElement* element, GstPad* pad) {
  GST_WHEP_SERVER_SINK(element)->endpoint->release_pad(pad);
}

// A session's video: a branch of the tee, and a key frame now (a joining
// browser cannot start before one).
static GstPad* attach_session(GstWhepServerSink* self) {
  GstPad* pad = gst_element_request_pad_simple(self->tee, "src_%u");
  GstPad* enc_src = gst_element_get_static_pad(self->encoder, "src");
  gst_pad_send_event(enc_src, gst_video_event_new_upstream_force_key_unit(GST_CLOCK_TIME_NONE, TRUE, 0));
  gst_object_unref(enc_src);
  return pad;
}

static void on_session_pose(GstWhepServerSink* self, const std::string& session, const Pose& pose) {
  std::lock_guard<std::mutex> order(*self->pose_order);
  GstEvent* event = nullptr;
  {
    std::lock_guard<std::mutex> g(*self->lock);
    const PoseVerdict v = self->poses->offer(session, pose.seq, pose.viewer_time_ns, g_get_monotonic_time() * 1000);
    GST_LOG_OBJECT(self, "session %s: pose %" G_GUINT64_FORMAT " %s", session.c_str(), pose.seq, pose_verdict_name(v));
    if (!pose_verdict_obeys(v)) return;
    Pose named = pose;
    named.session = pose_session_id("whep " + session);
    event = pose_event_new(named);
  }
  gst_pad_push_event(self->sinkpad, event);
}

// Every lecturer shares the encoder: it codes at the rate the most lossy link stands. `max_kbit`: the
// bitrate property (read before the lock: the endpoint's lock is never taken under ours).
static void set_shared_rate_locked(GstWhepServerSink* self, int max_kbit) {
  int kbit = max_kbit;
  for (const auto& kv : *self->rates) kbit = std::min(kbit, kv.second);
  g_object_set(self->encoder, "bitrate", guint(kbit), nullptr);
}

static GstStateChangeReturn gst_whep_server_sink_change_state(GstElement* element, GstStateChange transition) {
  GstWhepServerSink* self = GST_WHEP_SERVER_SINK(element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    g_object_set(self->encoder, "bitrate", self->endpoint->bitrate_kbit(), nullptr);
    if (!self->endpoint->start()) return GST_STATE_CHANGE_FAILURE;
  }
  GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_whep_server_sink_parent_class)->change_state(element, transition);
  if (transition == GST_STATE_CHANGE_READY_TO_NULL) {
    self->endpoint->stop();
    std::lock_guard<std::mutex> g(*self->lock);
    self->poses->reset();
    self->rates->clear();
  }
  return ret;
}

static void gst_whep_server_sink_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  if (!GST_WHEP_SERVER_SINK(object)->endpoint->set_property(id - PROP_ENDPOINT_FIRST, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
}

static void gst_whep_server_sink_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  if (!GST_WHEP_SERVER_SINK(object)->endpoint->get_property(id - PROP_ENDPOINT_FIRST, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
}

static void gst_whep_server_sink_init(GstWhepServerSink* self) {
  self->lock = new std::mutex;
  self->pose_order = new std::mutex;
  self->poses = new PoseSession;
  self->rates = new std::map<std::string, int>;
  WhepEndpointHooks hooks;
  hooks.attach = [self](const std::string&) { return attach_session(self); };
  hooks.detach = [self](const std::string& session, GstPad* pad) {
    gst_element_release_request_pad(self->tee, pad);
    const int max_kbit = int(self->endpoint->bitrate_kbit());
    std::lock_guard<std::mutex> g(*self->lock);
    if (self->rates->erase(session)) set_shared_rate_locked(self, max_kbit);
  };
  hooks.rate = [self](const std::string& session, int kbit) {
    const int max_kbit = int(self->endpoint->bitrate_kbit());
    std::lock_guard<std::mutex> g(*self->lock);
    (*self->rates)[session] = kbit;
    set_shared_rate_locked(self, max_kbit);
  };
  hooks.pose = [self](const std::string& session, const Pose& pose) { on_session_pose(self, session, pose); };
  self->endpoint = new WhepEndpoint(GST_BIN(self), "whepserversink", std::move(hooks));
  GstElement* queue = gst_element_factory_make("queue", nullptr);
  g_object_set(queue, "max-size-buffers", 2, "max-size-time", (guint64)0, "max-size-bytes", 0, "leaky", 2, nullptr);
  GstElement* convert = gst_element_factory_make("videoconvert", nullptr);
  self->encoder = gst_element_factory_make("x264enc", nullptr);
  // Low latency: no B-frames nor lookahead, one slice per frame, a key frame
  // at least every 2 s besides those on join and on the browser's request.
  gst_util_set_object_arg(G_OBJECT(self->encoder), "tune", "zerolatency");
  gst_util_set_object_arg(G_OBJECT(self->encoder), "speed-preset", "ultrafast");
  g_object_set(self->encoder, "key-int-max", 60, nullptr);
  GstElement* caps = gst_element_factory_make("capsfilter", nullptr);
  GstCaps* c = gst_caps_from_string("video/x-h264,profile=constrained-baseline,stream-format=byte-stream");
  g_object_set(caps, "caps", c, nullptr);
  gst_caps_unref(c);
  self->tee = gst_element_factory_make("tee", nullptr);
  g_object_set(self->tee, "allow-not-linked", TRUE, nullptr);
  // The tee's one permanent branch: a sink, so the bin posts EOS (and ends a
  // gst-launch-1.0 at the end of the stream) whether or not anyone watches.
  GstElement* drain = gst_element_factory_make("fakesink", nullptr);
  g_object_set(drain, "sync", FALSE, "async", FALSE, nullptr);
  gst_bin_add_many(GST_BIN(self), queue, convert, self->encoder, caps, self->tee, drain, nullptr);
  gst_element_link_many(queue, convert, self->encoder, caps, self->tee, drain, nullptr);
  GstPad* target = gst_element_get_static_pad(queue, "sink");
  self->sinkpad = gst_ghost_pad_new_from_template("sink", target, gst_static_pad_template_get(&sink_template));
  gst_object_unref(target);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
}

static void gst_whep_server_sink_finalize(GObject* object) {
  GstWhepServerSink* self = GST_WHEP_SERVER_SINK(object);
  delete self->endpoint;
  delete self->poses;
  delete self->rates;
  delete self->lock;
  delete self->pose_order;
  G_OBJECT_CLASS(gst_whep_server_sink_parent_class)->finalize(object);
}

static void gst_whep_server_sink_class_init(GstWhepServerSinkClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GST_DEBUG_CATEGORY_INIT(whep_debug, "whepserversink", 0, "WebRTC lecturer output with WHEP");
  gobject_class->set_property = gst_whep_server_sink_set_property;
  gobject_class->get_property = gst_whep_server_sink_get_property;
  gobject_class->finalize = gst_whep_server_sink_finalize;
  element_class->change_state = gst_whep_server_sink_change_state;
  WhepEndpoint::install_properties(gobject_class, PROP_ENDPOINT_FIRST);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  WhepEndpoint::add_sound_pad_templates(element_class);
  element_class->request_new_pad = gst_whep_server_sink_request_new_pad;
  element_class->release_pad = gst_whep_server_sink_release_pad;
  gst_element_class_set_static_metadata(element_class, "WHEP server sink", "Sink/Network",
      "Sends one view to every lecturer over WebRTC with WHEP", "gst-vclassroom");
}
