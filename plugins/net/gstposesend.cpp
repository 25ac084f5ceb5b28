/**
 * SECTION:element-posesend
 * @title: posesend
 *
 * Lecturer side of the pose back channel: video passes through; the vclassroom/pose events that reach it
 * from downstream (posenav) leave as RTP packets on the 'rtp' pad (link it to udpsink); the latest pose is
 * repeated with each frame so loss heals.
 *
 * ## Properties
 *
 * repeat: the latest pose goes again with every video frame, so a lost packet is made good at the next
 * frame. key-file: the key is 16 to 1024 raw bytes (e.g. head -c 32 /dev/urandom > pose.key); every pose
 * packet carries an HMAC-SHA256 tag made with it. trace-location: the trace (CSV: running time t in s,
 * position, orientation, seq; docs/pose.md) lets a recorded session be rendered again.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! viewwarp ! rgbddemux name=d d.color ! posesend name=s ! posenav ! videoconvert ! fakesink s.rtp ! udpsink host=127.0.0.1 port=5006
 * ]|
 */
// The rtp pad's thread, and why it has one: pose_rtp_task.h.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstposesend.h"

#include <gst/rtp/gstrtpbuffer.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <optional>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/net/pose_wire.h>
#include <gst/vclassroom/core/pose_trace.h>

#include "pose_rtp_task.h"
#include "poseback.h"

GST_DEBUG_CATEGORY(pose_send_debug);  // pose_rtp_task.cpp logs in it too
#define GST_CAT_DEFAULT pose_send_debug

using namespace vclassroom;

enum { PROP_0, PROP_PT, PROP_REPEAT, PROP_SENT, PROP_KEY_FILE, PROP_TRACE_LOCATION };

namespace {

struct SendState {
  explicit SendState(GstPad* rtppad) : rtp(rtppad) {}
  PoseRtpTask rtp;  // thread-safe itself; taken with the lock below held, never the other way round
  std::mutex lock;  // guards all below
  guint pt = 96;
  bool repeat = true;
  std::string key_file;
  PoseKey key;
  std::string trace_location;
  std::unique_ptr<PoseTraceWriter> trace;  // from READY to PAUSED on, when trace_location is set
  double trace_last_t = 0;
  guint16 rtp_seq = 0;
  guint32 ssrc = 0;
  guint64 session = 0;  // this run's number in every packet: a restarted lecturer is a new session
  guint64 packets = 0;  // packets of this session so far: each carries the next number (the replay window's)
  std::optional<Pose> latest;
};
}  // namespace

struct _GstPoseSend {
  GstElement parent;
  GstPad* sinkpad;
  GstPad* srcpad;
  GstPad* rtppad;
  SendState* st;
};

G_DEFINE_TYPE(GstPoseSend, gst_pose_send, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(posesend, "posesend", GST_RANK_NONE, GST_TYPE_POSE_SEND)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate rtp_template =
    GST_STATIC_PAD_TEMPLATE("rtp", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kPoseRtpCaps));

// Makes `pose` into one RTP packet for the rtp task; called with the lock held.
static void send_locked(GstPoseSend* self, const Pose& pose) {
  SendState* st = self->st;
  if (!st->rtp.accepting()) return;
  const PoseKey* key = st->key.empty() ? nullptr : &st->key;
  const guint size = key ? kPoseWireMaxSize : kPoseWireSize;
  GstBuffer* buf = gst_rtp_buffer_new_allocate(size, 0, 0);
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  gst_rtp_buffer_map(buf, GST_MAP_WRITE, &rtp);
  gst_rtp_buffer_set_payload_type(&rtp, static_cast<guint8>(st->pt));
  gst_rtp_buffer_set_ssrc(&rtp, st->ssrc);
  gst_rtp_buffer_set_seq(&rtp, st->rtp_seq++);
  const guint64 t = pose.viewer_time_ns >= 0 ? static_cast<guint64>(pose.viewer_time_ns) : gst_util_get_timestamp();
  gst_rtp_buffer_set_timestamp(&rtp, static_cast<guint32>(gst_util_uint64_scale(t, 90000, GST_SECOND)));
  gst_rtp_buffer_set_marker(&rtp, TRUE);
  // A repeat is a new packet: its number and sending time are fresh, so an authenticated receiver tells it
  // from a replay (docs/network.md, "Replayed packets").
  const PoseWireStamp stamp(st->session, ++st->packets, static_cast<int64_t>(gst_util_get_timestamp()));
  pose_to_wire(pose, static_cast<uint8_t*>(gst_rtp_buffer_get_payload(&rtp)), stamp, key);
  gst_rtp_buffer_unmap(&rtp);
  st->rtp.push(buf);
}

static gboolean gst_pose_send_rtp_activate_mode(GstPad*, GstObject* parent, GstPadMode mode, gboolean active) {
  return GST_POSE_SEND(parent)->st->rtp.activate(mode, active);
}

// Adds the pose to the trace at the pipeline's running time; a trace that
// cannot be written is given up with a warning, and the lecturer goes on.
static void record_pose_locked(GstPoseSend* self, const Pose& pose) {
  PoseSample sample;
  sample.pose = pose;
  // Before the pipeline plays (a pose sent while prerolling) its running time is 0; a trace's times never
  // go back.
  double t = 0;
  GstClock* clock = GST_STATE(self) == GST_STATE_PLAYING ? gst_element_get_clock(GST_ELEMENT(self)) : nullptr;
  if (clock) {
    const GstClockTime now = gst_clock_get_time(clock);
    gst_object_unref(clock);
    t = std::max(0.0, double(GST_CLOCK_DIFF(gst_element_get_base_time(GST_ELEMENT(self)), now)) / GST_SECOND);
  }
  sample.t = std::max(t, self->st->trace_last_t);
  self->st->trace_last_t = sample.t;
  try {
    self->st->trace->append(sample);
  } catch (const Error& e) {
    GST_ELEMENT_WARNING(self, RESOURCE, WRITE, ("%s", e.what()), ("the poses are sent on, but no longer recorded"));
    self->st->trace.reset();
  }
}

static gboolean gst_pose_send_src_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  GstPoseSend* self = GST_POSE_SEND(parent);
  if (is_pose_event(event)) {
    Pose pose;
    std::string err;
    const bool ok = pose_event_parse(event, &pose, &err);
    gst_event_unref(event);
    if (!ok) {
      GST_WARNING_OBJECT(self, "ignoring a bad pose event: %s", err.c_str());
      return FALSE;
    }
    std::lock_guard<std::mutex> g(self->st->lock);
    self->st->latest = pose;
    send_locked(self, pose);
    if (self->st->trace) record_pose_locked(self, pose);
    return TRUE;  // it goes on over the network, not to the lecturer's source
  }
  return gst_pad_event_default(pad, parent, event);
}

static GstFlowReturn gst_pose_send_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  GstPoseSend* self = GST_POSE_SEND(parent);
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    if (self->st->repeat && self->st->latest) send_locked(self, *self->st->latest);
  }
  return gst_pad_push(self->srcpad, buf);
}

static gboolean gst_pose_send_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  GstPoseSend* self = GST_POSE_SEND(parent);
  if (GST_EVENT_TYPE(event) == GST_EVENT_EOS) {
    // The pose stream ends with the video, whether or not a pose was sent
    // (a sink waiting for it would keep the pipeline from ending).
    self->st->rtp.end();
  }
  return gst_pad_event_default(pad, parent, event);
}

static GstIterator* gst_pose_send_iterate_links(GstPad* pad, GstObject* parent) {
  GstPoseSend* self = GST_POSE_SEND(parent);
  return iterate_video_link(pad, pad == self->sinkpad ? self->srcpad : self->sinkpad);
}

static GstStateChangeReturn gst_pose_send_change_state(GstElement* element, GstStateChange transition) {
  GstPoseSend* self = GST_POSE_SEND(element);
  SendState* st = self->st;
  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {  // the key file as set now
    if (!load_key_file(element, st->lock, st->key_file, &st->key)) return GST_STATE_CHANGE_FAILURE;
    std::lock_guard<std::mutex> g(st->lock);
    st->trace.reset();
    st->trace_last_t = 0;
    if (!st->trace_location.empty()) {
      try {
        st->trace = std::make_unique<PoseTraceWriter>(st->trace_location);
      } catch (const Error& e) {
        GST_ELEMENT_ERROR(element, RESOURCE, OPEN_WRITE, ("%s", e.what()), ("posesend trace-location"));
        return GST_STATE_CHANGE_FAILURE;
      }
    }
    // A new session each start: the server tells a restarted lecturer by it.
    st->latest.reset();
    st->ssrc = g_random_int();
    st->session = new_pose_session_id();
    st->packets = 0;
    st->rtp_seq = static_cast<guint16>(g_random_int());
    st->rtp.set_stream(st->pt, st->ssrc);
  }
  return GST_ELEMENT_CLASS(gst_pose_send_parent_class)->change_state(element, transition);
}

static void gst_pose_send_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  SendState* st = GST_POSE_SEND(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_PT: st->pt = g_value_get_uint(value); break;
    case PROP_REPEAT: st->repeat = g_value_get_boolean(value); break;
    case PROP_KEY_FILE: {
      const gchar* f = g_value_get_string(value);
      st->key_file = f ? f : "";
      break;
    }
    case PROP_TRACE_LOCATION: {
      const gchar* f = g_value_get_string(value);
      st->trace_location = f ? f : "";
      break;
    }
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_send_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  SendState* st = GST_POSE_SEND(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_PT: g_value_set_uint(value, st->pt); break;
    case PROP_REPEAT: g_value_set_boolean(value, st->repeat); break;
    case PROP_SENT: g_value_set_uint64(value, st->rtp.sent()); break;
    case PROP_KEY_FILE: g_value_set_string(value, st->key_file.c_str()); break;
    case PROP_TRACE_LOCATION: g_value_set_string(value, st->trace_location.c_str()); break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_send_finalize(GObject* object) {
  delete GST_POSE_SEND(object)->st;
  G_OBJECT_CLASS(gst_pose_send_parent_class)->finalize(object);
}

static void gst_pose_send_class_init(GstPoseSendClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->set_property = gst_pose_send_set_property;
  gobject_class->get_property = gst_pose_send_get_property;
  gobject_class->finalize = gst_pose_send_finalize;
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_pose_send_change_state);
  g_object_class_install_property(
      gobject_class, PROP_PT,
      g_param_spec_uint("pt", "Payload type", "RTP payload type of the pose packets", 96, 127, 96,
                        GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_REPEAT,
      g_param_spec_boolean("repeat", "Repeat", "Send the latest pose again with every video frame",
                           TRUE, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(gobject_class, PROP_SENT,
                                  g_param_spec_uint64("sent", "Packets sent", "Pose packets sent so far", 0,
                                                      G_MAXUINT64, 0,
                                                      GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      gobject_class, PROP_KEY_FILE,
      g_param_spec_string("key-file", "Key file",
                          "File of the shared pose key, 16 to 1024 raw bytes, to tag packets with (unset = untagged)",
                          nullptr, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_TRACE_LOCATION,
      g_param_spec_string("trace-location", "Trace file",
                          "CSV pose trace file to write every pose sent to (unset = none)",
                          nullptr, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_add_static_pad_template(element_class, &rtp_template);
  gst_element_class_set_static_metadata(element_class, "Pose back-channel sender", "Network/Filter",
      "Sends the lecturer's pose events to the server as RTP packets", "gst-vclassroom developers");
  GST_DEBUG_CATEGORY_INIT(pose_send_debug, "posesend", 0, "pose back-channel sender");
}

static void gst_pose_send_init(GstPoseSend* self) {
  self->rtppad = gst_pad_new_from_static_template(&rtp_template, "rtp");
  self->st = new SendState(self->rtppad);
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_pose_send_chain));
  gst_pad_set_event_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_pose_send_sink_event));
  gst_pad_set_iterate_internal_links_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_pose_send_iterate_links));
  GST_PAD_SET_PROXY_CAPS(self->sinkpad);
  GST_PAD_SET_PROXY_ALLOCATION(self->sinkpad);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
  gst_pad_set_event_function(self->srcpad, GST_DEBUG_FUNCPTR(gst_pose_send_src_event));
  gst_pad_set_iterate_internal_links_function(self->srcpad, GST_DEBUG_FUNCPTR(gst_pose_send_iterate_links));
  GST_PAD_SET_PROXY_CAPS(self->srcpad);
  gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
  gst_pad_use_fixed_caps(self->rtppad);
  gst_pad_set_activatemode_function(self->rtppad, GST_DEBUG_FUNCPTR(gst_pose_send_rtp_activate_mode));
  gst_element_add_pad(GST_ELEMENT(self), self->rtppad);
}
