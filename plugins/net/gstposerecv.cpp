/**
 * SECTION:element-poserecv
 * @title: poserecv
 *
 * Server side of the pose back channel: put it after viewfuse; video passes through, and pose packets
 * arriving on the 'rtp' pad (from udpsrc) go upstream as vclassroom/pose events. One lecturer's session at a
 * time, latest seq wins; damaged, unauthenticated (key-file), implausible (max-distance) and out-of-window
 * packets are dropped, counted and warned about (rate-limited).
 *
 * ## Properties
 *
 * key-file: the key is 16 to 1024 raw bytes (e.g. head -c 32 /dev/urandom > pose.key); only poses tagged
 * with it are obeyed, and unset any sender can steer the view. session-timeout: a lecturer's session that
 * sent nothing new nor a repeat for this long gives way to the next sender (a restarted lecturer).
 * rejected counts poses with a seq far ahead of the session's, or from another session while the obeyed
 * one is alive; replayed counts authenticated packets whose packet number was seen before, is below the
 * window, or was held back.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 udpsrc port=5006 caps=application/x-rtp,media=application,clock-rate=90000,encoding-name=X-VCLASSROOM-POSE ! r.rtp rgbdtestsrc num-buffers=300 ! viewwarp ! rgbddemux name=d d.color ! poserecv name=r ! videoconvert ! fakesink
 * ]|
 */
// Which packets are obeyed is library logic: the wire format and its tag (net/pose_wire.h), sessions, the
// seq window and the replay guard (net/pose_session.h); this element counts, warns and posts statistics.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstposerecv.h"

#include <gst/rtp/gstrtpbuffer.h>

#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/net/pose_wire.h>
#include <gst/vclassroom/net/pose_session.h>

#include "poseback.h"

GST_DEBUG_CATEGORY_STATIC(pose_recv_debug);
#define GST_CAT_DEFAULT pose_recv_debug

using namespace vclassroom;

enum {
  PROP_0, PROP_RECEIVED, PROP_INJECTED, PROP_LAST_SEQ, PROP_DAMAGED, PROP_UNAUTHENTICATED, PROP_IMPLAUSIBLE,
  PROP_REJECTED, PROP_REPLAYED, PROP_SESSION_SWITCHES, PROP_KEY_FILE, PROP_MAX_DISTANCE, PROP_SESSION_TIMEOUT, PROP_STATS_INTERVAL
};

namespace {
struct RecvState {
  std::mutex lock;
  std::string key_file;
  PoseKey key;
  double max_distance = 20.0;
  guint session_timeout_ms = 500;
  guint stats_interval = 0;
  PoseChannel channel;
};
}  // namespace

struct _GstPoseRecv {
  GstElement parent;
  GstPad* sinkpad;
  GstPad* srcpad;
  GstPad* rtppad;
  RecvState* st;
};

G_DEFINE_TYPE(GstPoseRecv, gst_pose_recv, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(poserecv, "poserecv", GST_RANK_NONE, GST_TYPE_POSE_RECV)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate rtp_template =
    GST_STATIC_PAD_TEMPLATE("rtp", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kPoseRtpCaps));

// The pipeline's clock when it has one (a test's GstTestClock too), else the
// system's monotonic clock: sessions time out on it.
static int64_t now_ns(GstPoseRecv* self) {
  if (GstClock* clock = gst_element_get_clock(GST_ELEMENT(self))) {
    const GstClockTime t = gst_clock_get_time(clock);
    gst_object_unref(clock);
    if (GST_CLOCK_TIME_IS_VALID(t)) return static_cast<int64_t>(t);
  }
  return g_get_monotonic_time() * 1000;
}

// Called with the lock held.
static GstMessage* stats_message_locked(GstPoseRecv* self) {
  const PoseChannelCounts c = self->st->channel.counts();
  GstStructure* s = gst_structure_new(
      "vclassroom-pose-stats", "received", G_TYPE_UINT64, c.received, "injected", G_TYPE_UINT64, c.injected,
      "damaged", G_TYPE_UINT64, c.damaged, "unauthenticated", G_TYPE_UINT64, c.unauthenticated, "implausible",
      G_TYPE_UINT64, c.implausible, "rejected", G_TYPE_UINT64, c.rejected, "replayed", G_TYPE_UINT64, c.replayed,
      "session-switches", G_TYPE_UINT64, c.session_switches, "last-seq", G_TYPE_UINT64, self->st->channel.last_seq(), nullptr);
  return gst_message_new_element(GST_OBJECT(self), s);
}

static GstFlowReturn gst_pose_recv_rtp_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  GstPoseRecv* self = GST_POSE_RECV(parent);
  RecvState* st = self->st;
  const int64_t now = now_ns(self);
  PoseChannel::Outcome out;
  GstMessage* stats = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    if (gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) {
      char ssrc[16];
      std::snprintf(ssrc, sizeof ssrc, "ssrc %08x", gst_rtp_buffer_get_ssrc(&rtp));
      out = st->channel.receive(static_cast<const uint8_t*>(gst_rtp_buffer_get_payload(&rtp)),
                                gst_rtp_buffer_get_payload_len(&rtp), ssrc, now);
      gst_rtp_buffer_unmap(&rtp);
    } else {
      out = st->channel.damaged("not an RTP packet", now);
    }
    const guint64 received = st->channel.counts().received;
    if (st->stats_interval > 0 && received % st->stats_interval == 0) stats = stats_message_locked(self);
  }
  gst_buffer_unref(buf);
  // Refused packets are not fatal: the next good pose replaces them.
  if (!out.warning.empty()) GST_ELEMENT_WARNING(self, STREAM, DECODE, ("%s", out.warning.c_str()), (nullptr));
  if (stats) gst_element_post_message(GST_ELEMENT(self), stats);
  if (out.obey) {
    GST_LOG_OBJECT(self, "injecting pose %" G_GUINT64_FORMAT, out.pose.seq);
    gst_pad_push_event(self->sinkpad, pose_event_new(out.pose));
  }
  return GST_FLOW_OK;
}

// The pose stream's own events (caps, EOS, ...) end here: the video goes on.
// At its end the refused packets not yet reported and the statistics are
// posted once more.
static gboolean gst_pose_recv_rtp_event(GstPad*, GstObject* parent, GstEvent* event) {
  GstPoseRecv* self = GST_POSE_RECV(parent);
  GstMessage* stats = nullptr;
  std::vector<std::string> warnings;
  if (GST_EVENT_TYPE(event) == GST_EVENT_EOS) {
    std::lock_guard<std::mutex> g(self->st->lock);
    warnings = self->st->channel.final_warnings();
    if (self->st->stats_interval > 0) stats = stats_message_locked(self);
  }
  for (const std::string& w : warnings) GST_ELEMENT_WARNING(self, STREAM, DECODE, ("%s", w.c_str()), (nullptr));
  if (stats) gst_element_post_message(GST_ELEMENT(self), stats);
  gst_event_unref(event);
  return TRUE;
}

static GstFlowReturn gst_pose_recv_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  return gst_pad_push(GST_POSE_RECV(parent)->srcpad, buf);
}

static GstIterator* gst_pose_recv_iterate_links(GstPad* pad, GstObject* parent) {
  GstPoseRecv* self = GST_POSE_RECV(parent);
  return iterate_video_link(pad, pad == self->sinkpad ? self->srcpad : self->sinkpad);
}

static GstStateChangeReturn gst_pose_recv_change_state(GstElement* element, GstStateChange transition) {
  GstPoseRecv* self = GST_POSE_RECV(element);
  RecvState* st = self->st;
  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {  // the key file as set now
    if (!load_key_file(element, st->lock, st->key_file, &st->key)) return GST_STATE_CHANGE_FAILURE;
    std::lock_guard<std::mutex> g(st->lock);
    PoseChannelConfig c;
    c.session.timeout_ns = static_cast<int64_t>(st->session_timeout_ms) * 1'000'000;
    c.max_distance_m = st->max_distance;
    c.key = st->key;
    st->channel = PoseChannel(c);
  }
  return GST_ELEMENT_CLASS(gst_pose_recv_parent_class)->change_state(element, transition);
}

static void gst_pose_recv_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  RecvState* st = GST_POSE_RECV(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_KEY_FILE: {
      const gchar* s = g_value_get_string(value);
      st->key_file = s ? s : "";
      break;
    }
    case PROP_MAX_DISTANCE:
      st->max_distance = g_value_get_double(value);
      st->channel.set_max_distance(st->max_distance);
      break;
    case PROP_SESSION_TIMEOUT: st->session_timeout_ms = g_value_get_uint(value); break;
    case PROP_STATS_INTERVAL: st->stats_interval = g_value_get_uint(value); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_recv_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  RecvState* st = GST_POSE_RECV(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_RECEIVED: g_value_set_uint64(value, st->channel.counts().received); break;
    case PROP_INJECTED: g_value_set_uint64(value, st->channel.counts().injected); break;
    case PROP_LAST_SEQ: g_value_set_uint64(value, st->channel.last_seq()); break;
    case PROP_DAMAGED: g_value_set_uint64(value, st->channel.counts().damaged); break;
    case PROP_UNAUTHENTICATED: g_value_set_uint64(value, st->channel.counts().unauthenticated); break;
    case PROP_IMPLAUSIBLE: g_value_set_uint64(value, st->channel.counts().implausible); break;
    case PROP_REJECTED: g_value_set_uint64(value, st->channel.counts().rejected); break;
    case PROP_REPLAYED: g_value_set_uint64(value, st->channel.counts().replayed); break;
    case PROP_SESSION_SWITCHES: g_value_set_uint64(value, st->channel.counts().session_switches); break;
    case PROP_KEY_FILE: g_value_set_string(value, st->key_file.c_str()); break;
    case PROP_MAX_DISTANCE: g_value_set_double(value, st->max_distance); break;
    case PROP_SESSION_TIMEOUT: g_value_set_uint(value, st->session_timeout_ms); break;
    case PROP_STATS_INTERVAL: g_value_set_uint(value, st->stats_interval); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_recv_finalize(GObject* object) {
  delete GST_POSE_RECV(object)->st;
  G_OBJECT_CLASS(gst_pose_recv_parent_class)->finalize(object);
}

static void install_count(GObjectClass* klass, guint id, const char* name, const char* nick, const char* blurb) {
  g_object_class_install_property(klass, id, g_param_spec_uint64(name, nick, blurb, 0, G_MAXUINT64, 0,
                                                                 GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
}

static void gst_pose_recv_class_init(GstPoseRecvClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->set_property = gst_pose_recv_set_property;
  gobject_class->get_property = gst_pose_recv_get_property;
  gobject_class->finalize = gst_pose_recv_finalize;
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_pose_recv_change_state);
  install_count(gobject_class, PROP_RECEIVED, "received", "Packets received", "Pose packets received, good or not");
  install_count(gobject_class, PROP_INJECTED, "injected", "Poses injected",
                "New poses sent upstream (repeats and late ones are not)");
  install_count(gobject_class, PROP_LAST_SEQ, "last-seq", "Last sequence number", "seq of the newest pose obeyed");
  install_count(gobject_class, PROP_DAMAGED, "damaged", "Damaged packets",
                "Packets dropped for a wrong size, version or checksum");
  install_count(gobject_class, PROP_UNAUTHENTICATED, "unauthenticated", "Unauthenticated packets",
                "Packets dropped for a missing or wrong authentication tag (with key-file set)");
  install_count(gobject_class, PROP_IMPLAUSIBLE, "implausible", "Implausible poses",
                "Poses dropped as invalid (NaN, not a unit quaternion) or farther than max-distance");
  install_count(gobject_class, PROP_REJECTED, "rejected", "Rejected poses",
                "Poses dropped for a far-ahead seq or from a session other than the obeyed one");
  install_count(gobject_class, PROP_REPLAYED, "replayed", "Replayed packets",
                "Authenticated packets dropped as replays (with key-file set)");
  install_count(gobject_class, PROP_SESSION_SWITCHES, "session-switches", "Session switches",
                "Times a new or restarted lecturer's session took over");
  const auto rw_ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_KEY_FILE,
      g_param_spec_string("key-file", "Key file",
                          "File of the shared pose key, 16 to 1024 raw bytes (unset = poses are not authenticated)",
                          nullptr, rw_ready));
  g_object_class_install_property(
      gobject_class, PROP_MAX_DISTANCE,
      g_param_spec_double("max-distance", "Maximum distance",
                          "Poses farther than this from the rig origin (metres) are dropped as implausible", 0.0,
                          kMaxPoseDistance, 20.0,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_SESSION_TIMEOUT,
      g_param_spec_uint("session-timeout", "Session timeout",
                        "Silence in ms after which a lecturer's session gives way to the next sender",
                        1, 60000, 500, rw_ready));
  g_object_class_install_property(
      gobject_class, PROP_STATS_INTERVAL,
      g_param_spec_uint("stats-interval", "Statistics interval",
                        "Post a vclassroom-pose-stats message every N packets and at the end (0 = never)",
                        0, G_MAXUINT, 0,
                        GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_add_static_pad_template(element_class, &rtp_template);
  gst_element_class_set_static_metadata(element_class, "Pose back-channel receiver", "Network/Filter",
      "Turns pose packets from the lecturer into pose events sent upstream", "gst-vclassroom developers");
  GST_DEBUG_CATEGORY_INIT(pose_recv_debug, "poserecv", 0, "pose back-channel receiver");
}

static void gst_pose_recv_init(GstPoseRecv* self) {
  self->st = new RecvState();
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_pose_recv_chain));
  gst_pad_set_iterate_internal_links_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_pose_recv_iterate_links));
  GST_PAD_SET_PROXY_CAPS(self->sinkpad);
  GST_PAD_SET_PROXY_ALLOCATION(self->sinkpad);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
  gst_pad_set_iterate_internal_links_function(self->srcpad, GST_DEBUG_FUNCPTR(gst_pose_recv_iterate_links));
  GST_PAD_SET_PROXY_CAPS(self->srcpad);
  gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
  self->rtppad = gst_pad_new_from_static_template(&rtp_template, "rtp");
  gst_pad_set_chain_function(self->rtppad, GST_DEBUG_FUNCPTR(gst_pose_recv_rtp_chain));
  gst_pad_set_event_function(self->rtppad, GST_DEBUG_FUNCPTR(gst_pose_recv_rtp_event));
  gst_element_add_pad(GST_ELEMENT(self), self->rtppad);
}
