#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "whep_send_branch.h"

#include <gst/rtp/rtp.h>
#include <gst/video/video.h>

#include <map>
#include <mutex>

#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/webrtc/lecturer_silence.h>
#include <gst/vclassroom/webrtc/loss_rate.h>
#include <gst/vclassroom/webrtc/send_gate.h>

#include "gstrtphdrextplayoutdelay.h"

#include <gst/vclassroom/webrtc/playout_delay.h>

GST_DEBUG_CATEGORY_STATIC(whep_send_debug);
#define GST_CAT_DEFAULT whep_send_debug

namespace vclassroom {

namespace {

// Encoded frames a session's send queue holds (about 130 ms at 30 fps) before its GopSendGate drops.
constexpr guint kSendQueueFrames = 4;

struct FramePose {
  uint64_t seq;
  int64_t viewer_time_ns;
  RenderedPose rendered;  // after the navigation bounds: where the lecturer's view really is
};

}  // namespace

struct WhepSendBranch::State {
  GstBin* owner = nullptr;
  std::string session;
  GstElement* queue = nullptr;  // never leaks nor blocks: `gate` drops whole rests of GOPs before it fills
  GstElement* pay = nullptr;
  GstElement* webrtc = nullptr;
  GstPad* sink = nullptr;
  GstElement* audio_queue = nullptr;  // the classroom's sound, where the offer takes it (else null)
  GstElement* audio_pay = nullptr;
  GstPad* audio_sink = nullptr;
  std::function<bool(GstPad*)> on_incoming;
  std::mutex drains_lock;
  std::vector<GstElement*> drains;  // sinks of received streams nobody takes (WhepSendBranch::drain)
  GopSendGate gate;                                   // the queue's upstream thread's only (on_frame_in)
  GstClockTime last_sent_pts = GST_CLOCK_TIME_NONE;   // the payloader's thread's only (on_frame_out)
  guint ssrc = 0;                                      // the video's; webrtcbin's resent packets have another
  RetransmitBudget resend_budget;                      // the resending thread's only (on_resent)
  WhepSendBranch::ReportWatch* reports = nullptr;     // the branch's (its own lock), for the frames offered
  std::mutex lock;                                    // what follows
  GstWebRTCDataChannel* channel = nullptr;
  GstClockTime last_echoed_pts = GST_CLOCK_TIME_NONE;
  std::map<GstClockTime, FramePose> frame_poses;  // recent frames' poses by PTS (bounded)
};

// The browser's receiver reports, fed by webrtcbin's statistics answers (which may come after the branch is
// gone): the session's rate, and whether its lecturer is still there.
struct WhepSendBranch::ReportWatch {
  std::mutex lock;
  bool alive = true;  // false once the branch is gone: no more on_rate
  std::string session;
  LossBasedRate rate;
  LecturerSilence silence{0};
  std::string last_report;  // the last receiver report seen, as text without its timestamp
  // The browser's NACKs and the packets sent, at the last report: a retransmitted packet was lost on the link
  // even though the report, which counts it received once resent, may not say so.
  guint64 last_nacks = 0, last_sent = 0;
  std::function<void(int, double)> on_rate;
};

namespace {

using State = WhepSendBranch::State;
using ReportWatch = WhepSendBranch::ReportWatch;

// webrtcbin's statistics: the browser's latest receiver report (remote-inbound-rtp), if it is a new one, and the
// NACKs it sent since the last (outbound-rtp): the link's loss (link_loss).
void on_stats(GstPromise* promise, gpointer user_data) {
  const std::shared_ptr<ReportWatch>& watch = *static_cast<std::shared_ptr<ReportWatch>*>(user_data);
  if (gst_promise_wait(promise) != GST_PROMISE_RESULT_REPLIED) return;
  const GstStructure* reply = gst_promise_get_reply(promise);
  if (!reply) return;
  double lost = -1;
  std::string text;
  guint64 nacks = 0, sent = 0;
  for (int i = 0; i < gst_structure_n_fields(reply); ++i) {
    const GValue* v = gst_structure_get_value(reply, gst_structure_nth_field_name(reply, i));
    if (!GST_VALUE_HOLDS_STRUCTURE(v)) continue;
    const GstStructure* stats = gst_value_get_structure(v);
    GstWebRTCStatsType type;
    if (!gst_structure_get(stats, "type", GST_TYPE_WEBRTC_STATS_TYPE, &type, nullptr)) continue;
    if (type == GST_WEBRTC_STATS_OUTBOUND_RTP) {
      guint count = 0;
      if (gst_structure_get_uint(stats, "nack-count", &count)) nacks += count;
      guint64 packets = 0;
      if (gst_structure_get_uint64(stats, "packets-sent", &packets)) sent += packets;
      continue;
    }
    if (type != GST_WEBRTC_STATS_REMOTE_INBOUND_RTP || lost >= 0 || !gst_structure_get_double(stats, "fraction-lost", &lost))
      continue;
    // The same report comes back until the browser sends the next one: only a new one counts.
    GstStructure* report = gst_structure_copy(stats);
    gst_structure_remove_field(report, "timestamp");
    gchar* t = gst_structure_to_string(report);
    text = t;
    g_free(t);
    gst_structure_free(report);
  }
  if (lost < 0) return;
  std::lock_guard<std::mutex> g(watch->lock);
  const bool fresh = watch->alive && watch->last_report != text;
  watch->last_report = text;
  if (!fresh) return;
  if (sent >= watch->last_sent && nacks >= watch->last_nacks)
    lost = link_loss(lost, nacks - watch->last_nacks, sent - watch->last_sent);
  watch->last_nacks = nacks;
  watch->last_sent = sent;
  watch->silence.on_report(g_get_monotonic_time() * 1000);
  const int before = watch->rate.kbit(), now = watch->rate.on_report(lost);
  GST_LOG("session %s: receiver report, %.1f %% lost: %d kbit/s", watch->session.c_str(), 100 * lost, now);
  if (now != before && watch->on_rate) watch->on_rate(now, lost);
}

// Every encoded frame entering the branch: the send gate (a full queue drops the rest of the GOP and asks
// the encoder for a key frame).
GstPadProbeReturn on_frame_in(GstPad* pad, GstPadProbeInfo* info, gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf) return GST_PAD_PROBE_OK;
  {
    std::lock_guard<std::mutex> g(st->reports->lock);
    st->reports->silence.on_frame();
  }
  guint queued = 0;
  g_object_get(st->queue, "current-level-buffers", &queued, nullptr);
  if (st->gate.admit(!GST_BUFFER_FLAG_IS_SET(buf, GST_BUFFER_FLAG_DELTA_UNIT), queued >= kSendQueueFrames))
    return GST_PAD_PROBE_OK;
  if (st->gate.take_key_frame_request()) {
    GST_INFO_OBJECT(st->owner, "session %s: sending fell behind (%" G_GUINT64_FORMAT " frames dropped so far): "
                    "dropping to the next key frame, which is asked for", st->session.c_str(), st->gate.dropped());
    gst_pad_push_event(pad, gst_video_event_new_upstream_force_key_unit(GST_CLOCK_TIME_NONE, TRUE, 0));
  }
  return GST_PAD_PROBE_DROP;
}

// A serialized query (the encoder's ALLOCATION query when it negotiates, a DRAIN) would wait in the send
// queue until the queue is empty, and a session whose link is not up (webrtcbin holds the first packet until
// the DTLS handshake, which a dead or hostile peer never finishes) never empties it: the encoder, which the
// sessions may share, would stop. Such queries are answered here instead: the encoder then allocates alone.
GstPadProbeReturn on_serialized_query(GstPad*, GstPadProbeInfo* info, gpointer) {
  GstQuery* query = GST_PAD_PROBE_INFO_QUERY(info);
  return query && GST_QUERY_IS_SERIALIZED(query) ? GST_PAD_PROBE_HANDLED : GST_PAD_PROBE_OK;
}

// Each frame leaving the send queue is stamped with the time it is sent, so its RTP timestamp says when it
// left rather than when its cameras saw it: a browser sizes its jitter buffer by how unevenly frames arrive
// against their timestamps, and the server's uneven render time would otherwise count as network jitter,
// buffered at the cost of pose-to-photon latency. Then its pose (the pose meta the encoder keeps) is noted
// under that stamp, which the payloader's packets carry, so the echo can name it.
GstPadProbeReturn on_frame_out(GstPad* pad, GstPadProbeInfo* info, gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf || !GST_BUFFER_PTS_IS_VALID(buf)) return GST_PAD_PROBE_OK;
  GstEvent* segment_event = gst_pad_get_sticky_event(pad, GST_EVENT_SEGMENT, 0);
  GstClock* clock = gst_element_get_clock(st->pay);
  GstClockTime sent = GST_CLOCK_TIME_NONE;
  if (segment_event && clock) {
    const GstSegment* segment = nullptr;
    gst_event_parse_segment(segment_event, &segment);
    const GstClockTime now = gst_clock_get_time(clock), base = gst_element_get_base_time(st->pay);
    if (segment->format == GST_FORMAT_TIME && now >= base)
      sent = gst_segment_position_from_running_time(segment, GST_FORMAT_TIME, now - base);
  }
  if (segment_event) gst_event_unref(segment_event);
  if (clock) gst_object_unref(clock);
  if (GST_CLOCK_TIME_IS_VALID(sent)) {
    if (GST_CLOCK_TIME_IS_VALID(st->last_sent_pts) && sent <= st->last_sent_pts) sent = st->last_sent_pts + 1;
    st->last_sent_pts = sent;
    buf = gst_buffer_make_writable(buf);
    GST_PAD_PROBE_INFO_DATA(info) = buf;
    GST_BUFFER_PTS(buf) = sent;
    GST_BUFFER_DTS(buf) = GST_CLOCK_TIME_NONE;
  }
  const PoseMeta* meta = buffer_get_pose_meta(buf);
  if (!meta) return GST_PAD_PROBE_OK;
  std::lock_guard<std::mutex> g(st->lock);
  st->frame_poses[GST_BUFFER_PTS(buf)] = FramePose{meta->seq, meta->viewer_time_ns, meta->rendered};
  while (st->frame_poses.size() > 64) st->frame_poses.erase(st->frame_poses.begin());
  return GST_PAD_PROBE_OK;
}

// Each RTP packet leaving the payloader: the first of each frame sends the echo of the pose that frame was
// rendered for.
GstPadProbeReturn on_rtp_out(GstPad*, GstPadProbeInfo* info, gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  GstBuffer* buf = (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST)
                       ? gst_buffer_list_get(GST_PAD_PROBE_INFO_BUFFER_LIST(info), 0)
                       : GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf) return GST_PAD_PROBE_OK;
  std::string echo;
  GstWebRTCDataChannel* channel = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
    const GstClockTime pts = GST_BUFFER_PTS(buf);
    if (!st->channel || pts == st->last_echoed_pts) return GST_PAD_PROBE_OK;
    st->last_echoed_pts = pts;
    auto it = st->frame_poses.find(pts);
    GST_LOG_OBJECT(st->owner, "session %s: frame %" GST_TIME_FORMAT " out: %s", st->session.c_str(),
                   GST_TIME_ARGS(pts), it == st->frame_poses.end() ? "no pose known" : "echo");
    if (it == st->frame_poses.end()) return GST_PAD_PROBE_OK;
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    if (!gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return GST_PAD_PROBE_OK;
    echo = format_frame_echo(gst_rtp_buffer_get_timestamp(&rtp), it->second.seq, it->second.viewer_time_ns,
                             it->second.rendered);
    gst_rtp_buffer_unmap(&rtp);
    channel = GST_WEBRTC_DATA_CHANNEL(gst_object_ref(st->channel));
  }
  GstWebRTCDataChannelState state;
  g_object_get(channel, "ready-state", &state, nullptr);
  if (state == GST_WEBRTC_DATA_CHANNEL_STATE_OPEN) gst_webrtc_data_channel_send_string(channel, echo.c_str());
  gst_object_unref(channel);
  return GST_PAD_PROBE_OK;
}

// A packet resent on the browser's NACK (another SSRC than the video's) goes only within the retransmission
// budget of the session's current rate.
GstPadProbeReturn on_resent(GstPad*, GstPadProbeInfo* info, gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (!buf || !gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return GST_PAD_PROBE_OK;
  const guint ssrc = gst_rtp_buffer_get_ssrc(&rtp);
  gst_rtp_buffer_unmap(&rtp);
  if (ssrc == st->ssrc) return GST_PAD_PROBE_OK;
  int kbit = 0;
  {
    std::lock_guard<std::mutex> g(st->reports->lock);
    kbit = st->reports->rate.kbit();
  }
  return st->resend_budget.admit(gst_buffer_get_size(buf), g_get_monotonic_time() * 1000, kbit) ? GST_PAD_PROBE_OK
                                                                                                  : GST_PAD_PROBE_DROP;
}

// webrtcbin's clocksync and nicesink sync on the clock: they hold every packet until its frame's running
// time plus the pipeline's latency (which includes viewfuse's wait for late cameras), while a live view
// should leave the moment it is encoded. Its rtprtxsend resends within the budget (on_resent).
void on_webrtc_element_added(GstBin*, GstBin*, GstElement* element, gpointer user_data) {
  GstElementFactory* factory = gst_element_get_factory(element);
  const char* name = factory ? GST_OBJECT_NAME(factory) : "";
  if (g_strcmp0(name, "nicesink") == 0 || g_strcmp0(name, "clocksync") == 0) g_object_set(element, "sync", FALSE, nullptr);
  if (g_strcmp0(name, "rtprtxsend") == 0) {
    GstPad* src = gst_element_get_static_pad(element, "src");
    gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_BUFFER, on_resent, user_data, nullptr);
    gst_object_unref(src);
  }
}

}  // namespace

namespace {

// The session's audio section: the classroom's sound on its way to the lecturer (`send`: a leaky queue, sound
// that cannot leave in time is dropped, never held: the view must not wait for it ! rtpopuspay on the
// offer's payload ! webrtcbin) and the lecturer's voice back (`receive`).
void add_audio(State* st, int payload, bool send, bool receive) {
  if (!send) {
    // Receiving only; or neither (the element has no sound pads): the section is answered inactive, so the
    // browser sends nothing there.
    GstCaps* caps = gst_caps_new_simple("application/x-rtp", "media", G_TYPE_STRING, "audio", "encoding-name",
                                        G_TYPE_STRING, "OPUS", "clock-rate", G_TYPE_INT, 48000, "payload", G_TYPE_INT,
                                        payload, nullptr);
    GstWebRTCRTPTransceiver* transceiver = nullptr;
    g_signal_emit_by_name(st->webrtc, "add-transceiver",
                          receive ? GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_RECVONLY
                                  : GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_INACTIVE,
                          caps, &transceiver);
    gst_caps_unref(caps);
    if (transceiver) gst_object_unref(transceiver);
    return;
  }
  st->audio_queue = gst_element_factory_make("queue", nullptr);
  g_object_set(st->audio_queue, "leaky", 2 /* downstream */, "max-size-buffers", 0, "max-size-bytes", 0,
               "max-size-time", guint64(200 * GST_MSECOND), nullptr);
  st->audio_pay = gst_element_factory_make("rtpopuspay", nullptr);
  const guint ssrc = g_random_int();
  g_object_set(st->audio_pay, "pt", payload, "ssrc", ssrc, nullptr);
  gst_bin_add_many(st->owner, st->audio_queue, st->audio_pay, nullptr);
  gst_element_link(st->audio_queue, st->audio_pay);
  GstPad* pay_src = gst_element_get_static_pad(st->audio_pay, "src");
  GstPad* rtc_sink = gst_element_request_pad_simple(st->webrtc, "sink_%u");
  gst_pad_link(pay_src, rtc_sink);
  GstWebRTCRTPTransceiver* transceiver = nullptr;
  g_object_get(rtc_sink, "transceiver", &transceiver, nullptr);
  if (transceiver) {
    // As for the video: the answer names the offer's payload and the stream's SSRC before the first packet.
    GstCaps* preferences = gst_caps_new_simple("application/x-rtp", "media", G_TYPE_STRING, "audio", "encoding-name",
                                               G_TYPE_STRING, "OPUS", "clock-rate", G_TYPE_INT, 48000, "payload",
                                               G_TYPE_INT, payload, "ssrc", G_TYPE_UINT, ssrc, nullptr);
    g_object_set(transceiver, "direction",
                 receive ? GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_SENDRECV : GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_SENDONLY,
                 "codec-preferences", preferences, nullptr);
    gst_caps_unref(preferences);
    gst_object_unref(transceiver);
  }
  gst_object_unref(rtc_sink);
  gst_object_unref(pay_src);
  st->audio_sink = gst_element_get_static_pad(st->audio_queue, "sink");
}

}  // namespace

namespace {

// webrtcbin's new src pad (a stream from the browser): the element's, or drained.
void on_incoming_pad(GstElement*, GstPad* pad, gpointer user_data) {
  auto* branch = static_cast<WhepSendBranch*>(user_data);
  if (GST_PAD_DIRECTION(pad) != GST_PAD_SRC) return;
  if (branch->take_incoming(pad)) return;
  GST_INFO_OBJECT(pad, "a stream from the browser nobody takes: dropped");
  branch->drain(pad);
}

}  // namespace

bool WhepSendBranch::take_incoming(GstPad* pad) { return st_->on_incoming && st_->on_incoming(pad); }

WhepSendBranch::WhepSendBranch(GstBin* owner, const std::string& session, const WhepSendSettings& settings)
    : st_(new State), reports_(new ReportWatch) {
  static gsize debug_once = 0;
  if (g_once_init_enter(&debug_once)) {
    GST_DEBUG_CATEGORY_INIT(whep_send_debug, "whepsend", 0, "A WHEP session's video on its way out");
    g_once_init_leave(&debug_once, 1);
  }
  State* st = st_.get();
  st->owner = owner;
  st->session = session;
  reports_->session = session;
  reports_->rate = LossBasedRate(LossRateParams{settings.max_kbit});  // (its floor never exceeds the maximum)
  reports_->on_rate = settings.on_rate;
  reports_->silence = LecturerSilence(settings.lecturer_timeout_ns);
  reports_->silence.start(g_get_monotonic_time() * 1000);
  st->reports = reports_.get();
  st->queue = gst_element_factory_make("queue", nullptr);
  g_object_set(st->queue, "max-size-buffers", kSendQueueFrames, "max-size-time", guint64(0), "max-size-bytes", 0,
               nullptr);
  st->pay = gst_element_factory_make("rtph264pay", nullptr);
  // The stream's SSRC is chosen here, not by the payloader when its first frame comes, so that the answer can
  // name it whenever it is made (below).
  const guint ssrc = st->ssrc = g_random_int();
  g_object_set(st->pay, "pt", settings.payload, "ssrc", ssrc, "config-interval", -1, "aggregate-mode",
               1 /* zero-latency */, nullptr);
  // The browser may then show frames as soon as they are decoded rather than buffer them. The payloader's
  // caps name the extension, and webrtcbin answers with it.
  if (settings.playout_extension_id > 0 && settings.playout_delay_ms >= 0) {
    GstRTPHeaderExtension* ext = GST_RTP_HEADER_EXTENSION(g_object_new(GST_TYPE_RTP_HDREXT_PLAYOUT_DELAY, nullptr));
    gst_rtp_header_extension_set_id(ext, settings.playout_extension_id);
    g_object_set(ext, "min-delay", 0, "max-delay", settings.playout_delay_ms, nullptr);
    g_signal_emit_by_name(st->pay, "add-extension", ext);
    gst_object_unref(ext);
  }
  st->webrtc = gst_element_factory_make("webrtcbin", nullptr);
  g_object_set(st->webrtc, "bundle-policy", GST_WEBRTC_BUNDLE_POLICY_MAX_BUNDLE, nullptr);
  for (const IceServer& ice : settings.ice_servers)
    g_object_set(st->webrtc, ice.scheme == "stun" ? "stun-server" : "turn-server", ice.uri.c_str(), nullptr);
  g_signal_connect(st->webrtc, "deep-element-added", G_CALLBACK(on_webrtc_element_added), st);
  gst_bin_add_many(owner, st->queue, st->pay, st->webrtc, nullptr);
  gst_element_link(st->queue, st->pay);
  GstPad* pay_sink = gst_element_get_static_pad(st->pay, "sink");
  gst_pad_add_probe(pay_sink, GST_PAD_PROBE_TYPE_BUFFER, on_frame_out, st, nullptr);
  gst_object_unref(pay_sink);
  GstPad* pay_src = gst_element_get_static_pad(st->pay, "src");
  gst_pad_add_probe(pay_src, GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST), on_rtp_out,
                    st, nullptr);
  GstPad* rtc_sink = gst_element_request_pad_simple(st->webrtc, "sink_%u");
  gst_pad_link(pay_src, rtc_sink);
  GstWebRTCRTPTransceiver* transceiver = nullptr;
  g_object_get(rtc_sink, "transceiver", &transceiver, nullptr);
  if (transceiver) {
    // A packet the lecturer's browser misses is sent again when it asks (NACK, RFC 4585; the copy on the offer's
    // RTX payload, RFC 4588): a lost packet then costs a round trip, not every frame up to the next key frame.
    g_object_set(transceiver, "direction", GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_SENDONLY, "do-nack", TRUE, nullptr);
    // The answer names the offer's H.264 payload, the stream's SSRC and, where sent, the playout-delay
    // extension, whether or not the payloader's caps have reached webrtcbin yet (the first frame may come
    // after the offer, and webrtcbin answers from the caps it has: under load the answer then lacked the
    // extension, and without the SSRC it names the RTX payload but not the RTX stream's SSRC (no ssrc-group),
    // and Chromium decoded the frames without ever showing one).
    GstCaps* preferences = gst_caps_new_simple("application/x-rtp", "media", G_TYPE_STRING, "video", "encoding-name",
                                               G_TYPE_STRING, "H264", "clock-rate", G_TYPE_INT, 90000, "payload",
                                               G_TYPE_INT, settings.payload, "ssrc", G_TYPE_UINT, ssrc, nullptr);
    if (settings.playout_extension_id > 0 && settings.playout_delay_ms >= 0) {
      const std::string field = "extmap-" + std::to_string(settings.playout_extension_id);
      gst_caps_set_simple(preferences, field.c_str(), G_TYPE_STRING, kPlayoutDelayUri, nullptr);
    }
    g_object_set(transceiver, "codec-preferences", preferences, nullptr);
    gst_caps_unref(preferences);
    gst_object_unref(transceiver);
  }
  gst_object_unref(rtc_sink);
  gst_object_unref(pay_src);
  st->sink = gst_element_get_static_pad(st->queue, "sink");
  gst_pad_add_probe(st->sink, GST_PAD_PROBE_TYPE_BUFFER, on_frame_in, st, nullptr);
  gst_pad_add_probe(st->sink, GST_PAD_PROBE_TYPE_QUERY_DOWNSTREAM, on_serialized_query, nullptr, nullptr);
  if (settings.opus_payload >= 0) add_audio(st, settings.opus_payload, settings.send_sound, settings.take_voice);
  st->on_incoming = settings.on_incoming;
  g_signal_connect(st->webrtc, "pad-added", G_CALLBACK(on_incoming_pad), this);
  gst_element_sync_state_with_parent(st->webrtc);
  gst_element_sync_state_with_parent(st->pay);
  gst_element_sync_state_with_parent(st->queue);
  if (st->audio_queue) {
    gst_element_sync_state_with_parent(st->audio_pay);
    gst_element_sync_state_with_parent(st->audio_queue);
  }
}

WhepSendBranch::~WhepSendBranch() {
  {
    std::lock_guard<std::mutex> g(reports_->lock);
    reports_->alive = false;
  }
  State* st = st_.get();
  std::vector<GstElement*> drains;
  {
    std::lock_guard<std::mutex> g(st->drains_lock);
    drains.swap(st->drains);
  }
  for (GstElement* e : {st->webrtc, st->pay, st->queue, st->audio_pay, st->audio_queue}) {
    if (!e) continue;
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(st->owner, e);
  }
  for (GstElement* e : drains) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(st->owner, e);
  }
  gst_object_unref(st->sink);
  if (st->audio_sink) gst_object_unref(st->audio_sink);
  if (st->channel) gst_object_unref(st->channel);
}

GstElement* WhepSendBranch::webrtc() const { return st_->webrtc; }

void WhepSendBranch::poll_receiver_reports() {
  GstPromise* promise = gst_promise_new_with_change_func(
      on_stats, new std::shared_ptr<ReportWatch>(reports_),
      [](gpointer p) { delete static_cast<std::shared_ptr<ReportWatch>*>(p); });
  g_signal_emit_by_name(st_->webrtc, "get-stats", nullptr, promise);
  gst_promise_unref(promise);
}

GstPad* WhepSendBranch::sink() const { return st_->sink; }

GstPad* WhepSendBranch::audio_sink() const { return st_->audio_sink; }

void WhepSendBranch::drain(GstPad* pad) {
  GstElement* sink = gst_element_factory_make("fakesink", nullptr);
  g_object_set(sink, "sync", FALSE, "async", FALSE, nullptr);
  gst_bin_add(st_->owner, sink);
  GstPad* in = gst_element_get_static_pad(sink, "sink");
  gst_pad_link(pad, in);
  gst_object_unref(in);
  gst_element_sync_state_with_parent(sink);
  std::lock_guard<std::mutex> g(st_->drains_lock);
  st_->drains.push_back(sink);
}

bool WhepSendBranch::lecturer_gone(int64_t* silent_ns) const {
  std::lock_guard<std::mutex> g(reports_->lock);
  const int64_t now = g_get_monotonic_time() * 1000;
  *silent_ns = reports_->silence.silent_ns(now);
  return reports_->silence.gone(now);
}

bool WhepSendBranch::set_echo_channel(GstWebRTCDataChannel* channel) {
  std::lock_guard<std::mutex> g(st_->lock);
  if (st_->channel) return false;
  st_->channel = GST_WEBRTC_DATA_CHANNEL(gst_object_ref(channel));
  return true;
}

}  // namespace vclassroom
