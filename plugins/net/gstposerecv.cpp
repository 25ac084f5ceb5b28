// poserecv: on the server, pose packets arriving on its `rtp` pad (from
// udpsrc) become vclassroom/pose events again, sent upstream from its video
// sink pad towards viewfuse and every viewwarp. Latest seq wins: repeats,
// late and reordered packets are dropped; damaged ones are counted.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstposerecv.h"

#include <gst/rtp/gstrtpbuffer.h>

#include <mutex>

#include <gst/vclassroom/pose.h>

#include "poseback.h"

GST_DEBUG_CATEGORY_STATIC(pose_recv_debug);
#define GST_CAT_DEFAULT pose_recv_debug

using namespace vclassroom;

enum { PROP_0, PROP_RECEIVED, PROP_INJECTED, PROP_LAST_SEQ };

namespace {
struct RecvState {
  std::mutex lock;
  bool have_last = false;
  guint64 last_seq = 0;
  guint64 received = 0, injected = 0, bad = 0;
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

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate rtp_template =
    GST_STATIC_PAD_TEMPLATE("rtp", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kPoseRtpCaps));

static GstFlowReturn gst_pose_recv_rtp_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  GstPoseRecv* self = GST_POSE_RECV(parent);
  RecvState* st = self->st;
  Pose pose;
  std::string err = "not an RTP packet";
  bool ok = false;
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) {
    ok = pose_from_wire(static_cast<const uint8_t*>(gst_rtp_buffer_get_payload(&rtp)),
                        gst_rtp_buffer_get_payload_len(&rtp), &pose, &err);
    gst_rtp_buffer_unmap(&rtp);
  }
  gst_buffer_unref(buf);
  {
    std::lock_guard<std::mutex> g(st->lock);
    st->received++;
    if (!ok) {
      // A damaged packet on a lossy link is not fatal: the next pose replaces it.
      if (st->bad++ == 0)
        GST_ELEMENT_WARNING(self, STREAM, DECODE, ("dropping a damaged pose packet: %s", err.c_str()), (nullptr));
      return GST_FLOW_OK;
    }
    if (st->have_last && pose.seq <= st->last_seq) return GST_FLOW_OK;  // a repeat or late
    st->have_last = true;
    st->last_seq = pose.seq;
    st->injected++;
  }
  GST_LOG_OBJECT(self, "injecting pose %" G_GUINT64_FORMAT, pose.seq);
  gst_pad_push_event(self->sinkpad, pose_event_new(pose));
  return GST_FLOW_OK;
}

// The pose stream's own events (caps, EOS, ...) end here: the video goes on.
static gboolean gst_pose_recv_rtp_event(GstPad*, GstObject*, GstEvent* event) {
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
  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {
    RecvState* st = self->st;
    std::lock_guard<std::mutex> g(st->lock);
    st->have_last = false;
    st->last_seq = st->received = st->injected = st->bad = 0;
  }
  return GST_ELEMENT_CLASS(gst_pose_recv_parent_class)->change_state(element, transition);
}

static void gst_pose_recv_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  RecvState* st = GST_POSE_RECV(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_RECEIVED:
      g_value_set_uint64(value, st->received);
      break;
    case PROP_INJECTED:
      g_value_set_uint64(value, st->injected);
      break;
    case PROP_LAST_SEQ:
      g_value_set_uint64(value, st->last_seq);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_pose_recv_finalize(GObject* object) {
  delete GST_POSE_RECV(object)->st;
  G_OBJECT_CLASS(gst_pose_recv_parent_class)->finalize(object);
}

static void gst_pose_recv_class_init(GstPoseRecvClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->get_property = gst_pose_recv_get_property;
  gobject_class->finalize = gst_pose_recv_finalize;
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_pose_recv_change_state);
  const auto ro = GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  g_object_class_install_property(gobject_class, PROP_RECEIVED,
                                  g_param_spec_uint64("received", "Packets received",
                                                      "Pose packets received, good or not", 0, G_MAXUINT64, 0, ro));
  g_object_class_install_property(gobject_class, PROP_INJECTED,
                                  g_param_spec_uint64("injected", "Poses injected",
                                                      "New poses sent upstream (repeats and late ones are not)", 0,
                                                      G_MAXUINT64, 0, ro));
  g_object_class_install_property(gobject_class, PROP_LAST_SEQ,
                                  g_param_spec_uint64("last-seq", "Last sequence number",
                                                      "seq of the newest pose sent upstream", 0, G_MAXUINT64, 0, ro));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_add_static_pad_template(element_class, &rtp_template);
  gst_element_class_set_static_metadata(
      element_class, "Pose back-channel receiver", "Network/Filter",
      "Server side of the pose back channel: put it after viewfuse; video passes through, and pose packets "
      "arriving on the 'rtp' pad (from udpsrc) go upstream as vclassroom/pose events. Latest seq wins; repeats, "
      "late and damaged packets are dropped. Example: "
      "gst-launch-1.0 udpsrc port=5006 "
      "caps=application/x-rtp,media=application,clock-rate=90000,encoding-name=X-VCLASSROOM-POSE ! "
      "r.rtp rgbdtestsrc num-buffers=300 ! viewwarp ! rgbddemux name=d d.color ! poserecv name=r ! "
      "videoconvert ! autovideosink",
      "gst-vclassroom developers");
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
