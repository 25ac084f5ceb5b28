#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "whep_endpoint.h"

#include <gst/rtp/rtp.h>
#include <gst/sdp/sdp.h>
#include <gst/webrtc/webrtc.h>
#include <libsoup/soup.h>

#include <map>
#include <mutex>
#include <vector>

#include <gst/video/video.h>

#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/send_gate.h>
#include <gst/vclassroom/webrtc/whep.h>

#include "gstrtphdrextplayoutdelay.h"

GST_DEBUG_CATEGORY_STATIC(whep_endpoint_debug);
#define GST_CAT_DEFAULT whep_endpoint_debug

namespace vclassroom {

namespace {

enum Prop {
  kPort, kToken, kTlsCertificate, kTlsKey, kBitrate, kMaxSessions, kWebRoot, kBoundPort, kSessions, kPlayoutDelay,
  kStunServer, kTurnServer, kCount
};

// Encoded frames a session's send queue holds (about 130 ms at 30 fps) before its GopSendGate drops.
constexpr guint kSendQueueFrames = 4;

struct FramePose {
  uint64_t seq;
  int64_t viewer_time_ns;
  RenderedPose rendered;  // after the navigation bounds: where the lecturer's view really is
};

struct Session {
  std::string id;
  WhepEndpoint::State* owner = nullptr;
  GstPad* source = nullptr;  // the element's H.264 pad feeding this session (a reference)
  GstElement* queue = nullptr;  // never leaks nor blocks: `gate` drops whole rests of GOPs before it fills
  GopSendGate gate;              // the streaming thread's only
  GstElement* pay = nullptr;
  GstElement* webrtc = nullptr;
  GstWebRTCDataChannel* channel = nullptr;
  SoupServerMessage* pending = nullptr;  // the POST waiting for the answer
  GstClockTime last_echoed_pts = GST_CLOCK_TIME_NONE;
  GstClockTime last_sent_pts = GST_CLOCK_TIME_NONE;  // the send stamp of the previous frame (on_frame_out)
  std::map<GstClockTime, FramePose> frame_poses;  // this session's recent frames' poses by PTS (bounded)
};

void respond(SoupServerMessage* msg, int status, const char* type = nullptr, const std::string& body = "") {
  soup_server_message_set_status(msg, status, nullptr);
  if (type) soup_server_message_set_response(msg, type, SOUP_MEMORY_COPY, body.data(), body.size());
}

// The offer's first H.264 payload type a browser decodes as constrained
// baseline in packetization mode 1; -1 when it offers none.
int pick_h264_payload(const GstSDPMessage* sdp) {
  for (guint m = 0; m < gst_sdp_message_medias_len(sdp); ++m) {
    const GstSDPMedia* media = gst_sdp_message_get_media(sdp, m);
    if (g_strcmp0(gst_sdp_media_get_media(media), "video") != 0) continue;
    for (guint f = 0; f < gst_sdp_media_formats_len(media); ++f) {
      const int pt = atoi(gst_sdp_media_get_format(media, f));
      GstCaps* caps = gst_sdp_media_get_caps_from_media(media, pt);
      if (!caps) continue;
      const GstStructure* s = gst_caps_get_structure(caps, 0);
      const char* name = gst_structure_get_string(s, "encoding-name");
      const char* mode = gst_structure_get_string(s, "packetization-mode");
      // GstSDP turns profile-level-id 42e0xx into profile=constrained-baseline.
      const char* profile = gst_structure_get_string(s, "profile");
      const bool ok = name && g_ascii_strcasecmp(name, "H264") == 0 && g_strcmp0(mode, "1") == 0 &&
                      g_strcmp0(profile, "constrained-baseline") == 0;
      gst_caps_unref(caps);
      if (ok) return pt;
    }
  }
  return -1;
}

// The id the offer's video gives the extension `uri` (a=extmap), or 0 when it offers none.
int offered_extension_id(const GstSDPMessage* sdp, const char* uri) {
  for (guint m = 0; m < gst_sdp_message_medias_len(sdp); ++m) {
    const GstSDPMedia* media = gst_sdp_message_get_media(sdp, m);
    if (g_strcmp0(gst_sdp_media_get_media(media), "video") != 0) continue;
    for (guint i = 0;; ++i) {
      const gchar* value = gst_sdp_media_get_attribute_val_n(media, "extmap", i);
      if (!value) break;
      if (const int id = extmap_id_for(value, uri)) return id;
    }
  }
  return 0;
}

}  // namespace

struct WhepEndpoint::State {
  GstBin* owner = nullptr;
  std::string name;  // for messages
  WhepEndpointHooks hooks;
  std::mutex lock;
  guint port = 8080;
  std::string token, tls_certificate, tls_key, web_root = VCLASSROOM_WEB_DIR;
  std::string stun_server, turn_server;  // as set; checked at start() into ice_servers
  std::vector<IceServer> ice_servers;
  guint bitrate_kbit = 4000;
  guint max_sessions = 4;
  // The playout-delay extension's maximum (its minimum is 0), -1: not sent. 0..100 ms measured a little
  // better than no extension or 0..0 (docs/lecturer.md, "Latency").
  int playout_delay_ms = 100;
  double max_distance_m = 20.0;
  GThread* thread = nullptr;
  GMainContext* context = nullptr;
  GMainLoop* loop = nullptr;
  SoupServer* server = nullptr;
  guint bound_port = 0;
  WhepSessionTable table{4};
  std::map<std::string, Session*> sessions;
};

namespace {

using State = WhepEndpoint::State;

void on_pose_message(GstWebRTCDataChannel*, const gchar* text, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  State* st = s->owner;
  Pose pose;
  std::string why;
  if (!text || !parse_pose_message(text, &pose, &why) || !pose_is_plausible(pose, st->max_distance_m, &why)) {
    GST_WARNING_OBJECT(st->owner, "session %s: pose refused: %s", s->id.c_str(), why.c_str());
    return;
  }
  st->hooks.pose(s->id, pose);
}

void on_data_channel(GstElement*, GstWebRTCDataChannel* channel, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  std::lock_guard<std::mutex> g(s->owner->lock);
  if (s->channel) return;  // the page opens one channel; others are ignored
  GST_DEBUG_OBJECT(s->owner->owner, "session %s: data channel", s->id.c_str());
  s->channel = GST_WEBRTC_DATA_CHANNEL(gst_object_ref(channel));
  g_signal_connect(channel, "on-message-string", G_CALLBACK(on_pose_message), s);
}

// Every encoded frame entering a session's branch: the send gate (a full queue drops the rest of the GOP
// and asks the encoder for a key frame), then its pose (the pose meta the encoder keeps), so the echo can
// name it. The payloaders see the same PTS.
GstPadProbeReturn on_frame_in(GstPad* pad, GstPadProbeInfo* info, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf) return GST_PAD_PROBE_OK;
  guint queued = 0;
  g_object_get(s->queue, "current-level-buffers", &queued, nullptr);
  if (!s->gate.admit(!GST_BUFFER_FLAG_IS_SET(buf, GST_BUFFER_FLAG_DELTA_UNIT), queued >= kSendQueueFrames)) {
    if (s->gate.take_key_frame_request()) {
      GST_INFO_OBJECT(s->owner->owner, "session %s: sending fell behind (%" G_GUINT64_FORMAT " frames dropped so "
                      "far): dropping to the next key frame, which is asked for", s->id.c_str(), s->gate.dropped());
      gst_pad_push_event(pad, gst_video_event_new_upstream_force_key_unit(GST_CLOCK_TIME_NONE, TRUE, 0));
    }
    return GST_PAD_PROBE_DROP;
  }
  PoseMeta* meta = buffer_get_pose_meta(buf);
  if (!meta || !GST_BUFFER_PTS_IS_VALID(buf)) return GST_PAD_PROBE_OK;
  std::lock_guard<std::mutex> g(s->owner->lock);
  s->frame_poses[GST_BUFFER_PTS(buf)] = FramePose{meta->seq, meta->viewer_time_ns, meta->rendered};
  while (s->frame_poses.size() > 64) s->frame_poses.erase(s->frame_poses.begin());
  return GST_PAD_PROBE_OK;
}

// A serialized query (the encoder's ALLOCATION query when it negotiates, a DRAIN) would wait in the send
// queue until the queue is empty, and a session whose link is not up (webrtcbin holds the first packet until
// the DTLS handshake, which a dead or hostile peer never finishes) never empties it: the encoder, which the
// sessions may share, would stop. Such queries are answered here instead: the encoder then allocates alone.
GstPadProbeReturn on_serialized_query(GstPad*, GstPadProbeInfo* info, gpointer) {
  GstQuery* query = GST_PAD_PROBE_INFO_QUERY(info);
  return query && GST_QUERY_IS_SERIALIZED(query) ? GST_PAD_PROBE_HANDLED : GST_PAD_PROBE_OK;
}

// Each frame leaving a session's send queue is stamped with the time it is sent, so its RTP timestamp says
// when it left rather than when its cameras saw it: a browser sizes its jitter buffer by how unevenly
// frames arrive against their timestamps, and the server's uneven render time would otherwise count as
// network jitter, buffered at the cost of pose-to-photon latency. The frame's pose moves to the new stamp.
GstPadProbeReturn on_frame_out(GstPad* pad, GstPadProbeInfo* info, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstEvent* segment_event = gst_pad_get_sticky_event(pad, GST_EVENT_SEGMENT, 0);
  GstClock* clock = gst_element_get_clock(s->pay);
  GstClockTime sent = GST_CLOCK_TIME_NONE;
  if (buf && GST_BUFFER_PTS_IS_VALID(buf) && segment_event && clock) {
    const GstSegment* segment = nullptr;
    gst_event_parse_segment(segment_event, &segment);
    const GstClockTime now = gst_clock_get_time(clock), base = gst_element_get_base_time(s->pay);
    if (segment->format == GST_FORMAT_TIME && now >= base)
      sent = gst_segment_position_from_running_time(segment, GST_FORMAT_TIME, now - base);
  }
  if (segment_event) gst_event_unref(segment_event);
  if (clock) gst_object_unref(clock);
  if (!GST_CLOCK_TIME_IS_VALID(sent)) return GST_PAD_PROBE_OK;
  if (GST_CLOCK_TIME_IS_VALID(s->last_sent_pts) && sent <= s->last_sent_pts) sent = s->last_sent_pts + 1;
  s->last_sent_pts = sent;
  buf = gst_buffer_make_writable(buf);
  GST_PAD_PROBE_INFO_DATA(info) = buf;
  const GstClockTime captured = GST_BUFFER_PTS(buf);
  GST_BUFFER_PTS(buf) = sent;
  GST_BUFFER_DTS(buf) = GST_CLOCK_TIME_NONE;
  std::lock_guard<std::mutex> g(s->owner->lock);
  auto it = s->frame_poses.find(captured);
  if (it != s->frame_poses.end()) {
    const FramePose pose = it->second;
    s->frame_poses.erase(it);
    s->frame_poses[sent] = pose;
  }
  return GST_PAD_PROBE_OK;
}

// Each RTP packet leaving a session's payloader: the first of each frame
// sends the echo of the pose that frame was rendered for.
GstPadProbeReturn on_rtp_out(GstPad*, GstPadProbeInfo* info, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstBuffer* buf = (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST)
                       ? gst_buffer_list_get(GST_PAD_PROBE_INFO_BUFFER_LIST(info), 0)
                       : GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf) return GST_PAD_PROBE_OK;
  std::string echo;
  GstWebRTCDataChannel* channel = nullptr;
  {
    std::lock_guard<std::mutex> g(s->owner->lock);
    const GstClockTime pts = GST_BUFFER_PTS(buf);
    if (!s->channel || pts == s->last_echoed_pts) return GST_PAD_PROBE_OK;
    s->last_echoed_pts = pts;
    auto it = s->frame_poses.find(pts);
    GST_LOG_OBJECT(s->owner->owner, "session %s: frame %" GST_TIME_FORMAT " out: %s", s->id.c_str(),
                   GST_TIME_ARGS(pts), it == s->frame_poses.end() ? "no pose known" : "echo");
    if (it == s->frame_poses.end()) return GST_PAD_PROBE_OK;
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    if (!gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return GST_PAD_PROBE_OK;
    echo = format_frame_echo(gst_rtp_buffer_get_timestamp(&rtp), it->second.seq, it->second.viewer_time_ns,
                             it->second.rendered);
    gst_rtp_buffer_unmap(&rtp);
    channel = GST_WEBRTC_DATA_CHANNEL(gst_object_ref(s->channel));
  }
  GstWebRTCDataChannelState state;
  g_object_get(channel, "ready-state", &state, nullptr);
  if (state == GST_WEBRTC_DATA_CHANNEL_STATE_OPEN) gst_webrtc_data_channel_send_string(channel, echo.c_str());
  gst_object_unref(channel);
  return GST_PAD_PROBE_OK;
}

// webrtcbin's clocksync and nicesink sync on the clock: they hold every packet until its frame's running
// time plus the pipeline's latency (which includes viewfuse's wait for late cameras), while a live view
// should leave the moment it is encoded.
void on_webrtc_element_added(GstBin*, GstBin*, GstElement* element, gpointer) {
  GstElementFactory* factory = gst_element_get_factory(element);
  const char* name = factory ? GST_OBJECT_NAME(factory) : "";
  if (g_strcmp0(name, "nicesink") == 0 || g_strcmp0(name, "clocksync") == 0) g_object_set(element, "sync", FALSE, nullptr);
}

struct AnswerReply {
  State* st;
  std::string id;
  std::string sdp;  // empty: failed
};

// In the server's thread: the answer (or the failure) to the waiting POST.
gboolean send_answer(gpointer data) {
  AnswerReply* r = static_cast<AnswerReply*>(data);
  std::lock_guard<std::mutex> g(r->st->lock);
  auto it = r->st->sessions.find(r->id);
  if (it != r->st->sessions.end() && it->second->pending) {
    SoupServerMessage* msg = it->second->pending;
    it->second->pending = nullptr;
    if (r->sdp.empty()) {
      respond(msg, 500);
    } else {
      respond(msg, 201, "application/sdp", r->sdp);
      soup_message_headers_replace(soup_server_message_get_response_headers(msg), "Location",
                                   (std::string(kWhepPath) + "/" + r->id).c_str());
    }
    soup_server_message_unpause(msg);
  }
  return G_SOURCE_REMOVE;
}

void on_gathering_state(GstElement* webrtc, GParamSpec*, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstWebRTCICEGatheringState state;
  g_object_get(webrtc, "ice-gathering-state", &state, nullptr);
  if (state != GST_WEBRTC_ICE_GATHERING_STATE_COMPLETE) return;
  GstWebRTCSessionDescription* answer = nullptr;
  g_object_get(webrtc, "local-description", &answer, nullptr);
  AnswerReply* r = new AnswerReply{s->owner, s->id, ""};
  if (answer) {
    gchar* text = gst_sdp_message_as_text(answer->sdp);
    r->sdp = text;
    g_free(text);
    gst_webrtc_session_description_free(answer);
  }
  g_main_context_invoke_full(s->owner->context, G_PRIORITY_DEFAULT, send_answer, r,
                             [](gpointer p) { delete static_cast<AnswerReply*>(p); });
}

void on_answer_created(GstPromise* promise, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstWebRTCSessionDescription* answer = nullptr;
  const GstStructure* reply = gst_promise_get_reply(promise);
  if (reply) gst_structure_get(reply, "answer", GST_TYPE_WEBRTC_SESSION_DESCRIPTION, &answer, nullptr);
  gst_promise_unref(promise);
  if (!answer) {
    GST_WARNING_OBJECT(s->owner->owner, "session %s: no answer", s->id.c_str());
    return;
  }
  g_signal_emit_by_name(s->webrtc, "set-local-description", answer, nullptr);
  gst_webrtc_session_description_free(answer);
  on_gathering_state(s->webrtc, nullptr, s);  // already complete on loopback
}

void on_offer_set(GstPromise* promise, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  gst_promise_unref(promise);
  g_signal_emit_by_name(s->webrtc, "create-answer", nullptr,
                        gst_promise_new_with_change_func(on_answer_created, s, nullptr));
}

// Feeds the element's `source` (taken) for session `id` through queue ! rtph264pay ! webrtcbin and starts
// answering `offer` (taken). Called with the lock held.
void start_session_locked(State* st, const std::string& id, GstPad* source, GstSDPMessage* offer, int payload,
                          SoupServerMessage* msg) {
  Session* s = new Session;
  s->owner = st;
  s->id = id;
  s->source = source;
  s->queue = gst_element_factory_make("queue", nullptr);
  g_object_set(s->queue, "max-size-buffers", kSendQueueFrames, "max-size-time", guint64(0), "max-size-bytes", 0,
               nullptr);
  s->pay = gst_element_factory_make("rtph264pay", nullptr);
  g_object_set(s->pay, "pt", payload, "config-interval", -1, "aggregate-mode", 1 /* zero-latency */, nullptr);
  // The browser may then show frames as soon as they are decoded rather than buffer them. The payloader's
  // caps name the extension, and webrtcbin answers with it.
  if (const int id = st->playout_delay_ms >= 0 ? offered_extension_id(offer, kPlayoutDelayUri) : 0) {
    GstRTPHeaderExtension* ext = GST_RTP_HEADER_EXTENSION(g_object_new(GST_TYPE_RTP_HDREXT_PLAYOUT_DELAY, nullptr));
    gst_rtp_header_extension_set_id(ext, id);
    g_object_set(ext, "min-delay", 0, "max-delay", st->playout_delay_ms, nullptr);
    g_signal_emit_by_name(s->pay, "add-extension", ext);
    gst_object_unref(ext);
  }
  s->webrtc = gst_element_factory_make("webrtcbin", nullptr);
  g_object_set(s->webrtc, "bundle-policy", GST_WEBRTC_BUNDLE_POLICY_MAX_BUNDLE, nullptr);
  for (const IceServer& ice : st->ice_servers)
    g_object_set(s->webrtc, ice.scheme == "stun" ? "stun-server" : "turn-server", ice.uri.c_str(), nullptr);
  gst_bin_add_many(st->owner, s->queue, s->pay, s->webrtc, nullptr);
  gst_element_link(s->queue, s->pay);
  GstPad* pay_sink = gst_element_get_static_pad(s->pay, "sink");
  gst_pad_add_probe(pay_sink, GST_PAD_PROBE_TYPE_BUFFER, on_frame_out, s, nullptr);
  gst_object_unref(pay_sink);
  GstPad* pay_src = gst_element_get_static_pad(s->pay, "src");
  gst_pad_add_probe(pay_src, GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST), on_rtp_out,
                    s, nullptr);
  GstPad* rtc_sink = gst_element_request_pad_simple(s->webrtc, "sink_%u");
  gst_pad_link(pay_src, rtc_sink);
  GstWebRTCRTPTransceiver* transceiver = nullptr;
  g_object_get(rtc_sink, "transceiver", &transceiver, nullptr);
  if (transceiver) {
    g_object_set(transceiver, "direction", GST_WEBRTC_RTP_TRANSCEIVER_DIRECTION_SENDONLY, nullptr);
    gst_object_unref(transceiver);
  }
  gst_object_unref(rtc_sink);
  gst_object_unref(pay_src);
  g_signal_connect(s->webrtc, "deep-element-added", G_CALLBACK(on_webrtc_element_added), nullptr);
  g_signal_connect(s->webrtc, "on-data-channel", G_CALLBACK(on_data_channel), s);
  g_signal_connect(s->webrtc, "notify::ice-gathering-state", G_CALLBACK(on_gathering_state), s);
  gst_element_sync_state_with_parent(s->webrtc);
  gst_element_sync_state_with_parent(s->pay);
  gst_element_sync_state_with_parent(s->queue);
  GstPad* queue_sink = gst_element_get_static_pad(s->queue, "sink");
  gst_pad_add_probe(queue_sink, GST_PAD_PROBE_TYPE_BUFFER, on_frame_in, s, nullptr);
  gst_pad_add_probe(queue_sink, GST_PAD_PROBE_TYPE_QUERY_DOWNSTREAM, on_serialized_query, nullptr, nullptr);
  gst_pad_link(s->source, queue_sink);
  gst_object_unref(queue_sink);

  s->pending = msg;
  st->table.add(s->id);
  st->sessions[s->id] = s;
  GstWebRTCSessionDescription* desc = gst_webrtc_session_description_new(GST_WEBRTC_SDP_TYPE_OFFER, offer);
  g_signal_emit_by_name(s->webrtc, "set-remote-description", desc,
                        gst_promise_new_with_change_func(on_offer_set, s, nullptr));
  gst_webrtc_session_description_free(desc);
}

// Takes the session's branch out of the pipeline, lets the element take its source out, and frees it.
// Lock not held.
void end_session(State* st, Session* s) {
  GstPad* queue_sink = gst_element_get_static_pad(s->queue, "sink");
  gst_pad_unlink(s->source, queue_sink);
  gst_object_unref(queue_sink);
  for (GstElement* e : {s->webrtc, s->pay, s->queue}) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(st->owner, e);
  }
  st->hooks.detach(s->id, s->source);
  gst_object_unref(s->source);
  if (s->channel) gst_object_unref(s->channel);
  if (s->pending) {
    respond(s->pending, 503);
    soup_server_message_unpause(s->pending);
  }
  delete s;
}

void on_request(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable* query, gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  SoupMessageHeaders* headers = soup_server_message_get_request_headers(msg);
  WhepRequest r;
  r.method = soup_server_message_get_method(msg);
  r.path = path;
  const char* token = query ? static_cast<const char*>(g_hash_table_lookup(query, "token")) : nullptr;
  const char* auth = soup_message_headers_get_one(headers, "Authorization");
  if (token) r.token = token;
  else if (auth && g_str_has_prefix(auth, "Bearer ")) r.token = auth + 7;
  const char* type = soup_message_headers_get_content_type(headers, nullptr);
  r.content_type = type ? type : "";
  SoupMessageBody* body = soup_server_message_get_request_body(msg);
  r.body_size = body->length < 0 ? 0 : static_cast<size_t>(body->length);
  std::string body_text;
  if (body->length >= 0 && static_cast<size_t>(body->length) <= WhepLimits().max_offer_bytes) {
    GBytes* bytes = soup_message_body_flatten(body);
    gsize n = 0;
    const char* data = static_cast<const char*>(g_bytes_get_data(bytes, &n));
    body_text.assign(data ? data : "", n);
    g_bytes_unref(bytes);
  }
  r.body = body_text;

  Session* leaving = nullptr;
  GstSDPMessage* offer = nullptr;
  int payload = -1;
  {
    std::lock_guard<std::mutex> g(st->lock);
    std::string file, mime_type;
    if (r.method == "GET" && lecturer_page_file(r.path, &file, &mime_type)) {
      gchar* contents = nullptr;
      gsize length = 0;
      const std::string full = st->web_root + "/" + file;
      if (!token_equal(st->token, r.token)) {
        respond(msg, 401);
      } else if (st->web_root.empty() || !g_file_get_contents(full.c_str(), &contents, &length, nullptr)) {
        GST_WARNING_OBJECT(st->owner, "no lecturer page at %s (web-root)", full.c_str());
        respond(msg, 404);
      } else {
        respond(msg, 200, mime_type.c_str(), std::string(contents, length));
        soup_message_headers_replace(soup_server_message_get_response_headers(msg), "Cache-Control", "no-store");
      }
      g_free(contents);
      return;
    }
    WhepLimits limits;
    limits.max_sessions = st->max_sessions;
    const WhepDecision d = check_whep_request(r, st->token, limits, st->sessions.size());
    if (d.action == WhepAction::kRefuse) {
      GST_INFO_OBJECT(st->owner, "%s %s refused %d: %s", r.method.c_str(), path, d.status, d.why.c_str());
      respond(msg, d.status);
      return;
    }
    if (d.action == WhepAction::kIceServers) {
      respond(msg, 204);
      SoupMessageHeaders* out = soup_server_message_get_response_headers(msg);
      for (const IceServer& ice : st->ice_servers)
        soup_message_headers_append(out, "Link", ice_server_link(ice).c_str());
      soup_message_headers_replace(out, "Cache-Control", "no-store");
      return;
    }
    if (d.action == WhepAction::kLeave) {
      auto it = st->sessions.find(d.session_id);
      if (it == st->sessions.end()) {
        respond(msg, 404);
        return;
      }
      leaving = it->second;
      st->sessions.erase(it);
      st->table.remove(d.session_id);
    } else if (gst_sdp_message_new_from_text(body_text.c_str(), &offer) != GST_SDP_OK ||
               (payload = pick_h264_payload(offer)) < 0) {
      if (offer) gst_sdp_message_free(offer);
      GST_INFO_OBJECT(st->owner, "offer without H.264 constrained baseline (packetization-mode 1): 406");
      respond(msg, 406);  // no H.264 constrained baseline offered
      return;
    }
  }
  if (offer) {
    // The element builds the session's video without this lock (it may read the settings); requests are
    // handled one at a time in this thread, so the session count checked above still holds.
    const std::string id = new_whep_session_id();
    GstPad* source = st->hooks.attach(id);
    if (!source) {
      GST_WARNING_OBJECT(st->owner, "no view for a new session: 503");
      gst_sdp_message_free(offer);
      respond(msg, 503);
      return;
    }
    soup_server_message_pause(msg);
    {
      std::lock_guard<std::mutex> g(st->lock);
      start_session_locked(st, id, source, offer, payload, msg);
    }
    if (st->hooks.start) st->hooks.start(id);
    return;
  }
  GST_INFO_OBJECT(st->owner, "session %s left", leaving->id.c_str());
  end_session(st, leaving);
  respond(msg, 200);
}

gpointer server_thread(gpointer data) {
  State* st = static_cast<State*>(data);
  g_main_context_push_thread_default(st->context);
  g_main_loop_run(st->loop);
  g_main_context_pop_thread_default(st->context);
  return nullptr;
}

GParamFlags rw() { return GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY); }
GParamFlags ro() { return GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS); }

}  // namespace

WhepEndpoint::WhepEndpoint(GstBin* owner, const char* debug_name, WhepEndpointHooks hooks) : st_(new State) {
  static gsize debug_once = 0;
  if (g_once_init_enter(&debug_once)) {
    GST_DEBUG_CATEGORY_INIT(whep_endpoint_debug, "whependpoint", 0, "WHEP signalling and WebRTC sessions");
    g_once_init_leave(&debug_once, 1);
  }
  st_->owner = owner;
  st_->name = debug_name;
  st_->hooks = std::move(hooks);
}

WhepEndpoint::~WhepEndpoint() { stop(); }

guint WhepEndpoint::install_properties(GObjectClass* klass, guint first_id) {
  const guint p = first_id;
  g_object_class_install_property(klass, p + kPort,
      g_param_spec_uint("port", "Port", "TCP port of the WHEP/HTTP server (0: any free port, see bound-port)", 0,
                        65535, 8080, rw()));
  g_object_class_install_property(klass, p + kToken,
      g_param_spec_string("token", "Token", "The join secret: requests without it (?token= or Bearer) get 401",
                          "", rw()));
  g_object_class_install_property(klass, p + kTlsCertificate,
      g_param_spec_string("tls-certificate", "TLS certificate", "PEM certificate file: serve HTTPS", "", rw()));
  g_object_class_install_property(klass, p + kTlsKey,
      g_param_spec_string("tls-key", "TLS key", "PEM private key file of tls-certificate", "", rw()));
  g_object_class_install_property(klass, p + kBitrate,
      g_param_spec_uint("bitrate", "Bitrate", "H.264 bitrate in kbit/s", 100, 50000, 4000, rw()));
  g_object_class_install_property(klass, p + kMaxSessions,
      g_param_spec_uint("max-sessions", "Max sessions", "Lecturers at once; more get 503", 1, 64, 4, rw()));
  g_object_class_install_property(klass, p + kWebRoot,
      g_param_spec_string("web-root", "Web root",
                          "Folder of the lecturer page (index.html, lecturer.js); default: the installed one",
                          VCLASSROOM_WEB_DIR, rw()));
  g_object_class_install_property(klass, p + kBoundPort,
      g_param_spec_uint("bound-port", "Bound port", "The port actually listened on", 0, 65535, 0, ro()));
  g_object_class_install_property(klass, p + kSessions,
      g_param_spec_uint("sessions", "Sessions", "Lecturers joined now", 0, 64, 0, ro()));
  g_object_class_install_property(klass, p + kPlayoutDelay,
      g_param_spec_int("playout-delay", "Playout delay",
                       "The most a browser may buffer each frame, in ms, sent with a minimum of 0 as the "
                       "playout-delay RTP header extension where the offer lists it: the browser shows frames as "
                       "soon as they are decoded instead of growing a jitter buffer (-1: not sent)",
                       -1, kPlayoutDelayMaxMs, 100, rw()));
  g_object_class_install_property(klass, p + kStunServer,
      g_param_spec_string("stun-server", "STUN server",
                          "stun://host:port: each session's ICE also gathers the address a NAT shows, and the page "
                          "is told to use it (WHEP OPTIONS Link header); empty: host candidates only", "", rw()));
  g_object_class_install_property(klass, p + kTurnServer,
      g_param_spec_string("turn-server", "TURN server",
                          "turn://user:password@host:port (or turns:// over TLS): a relay for lecturers behind NATs "
                          "that let no direct path through; the page gets it with its credentials", "", rw()));
  return p + kCount;
}

bool WhepEndpoint::set_property(guint id, const GValue* value) {
  std::lock_guard<std::mutex> g(st_->lock);
  auto str = [&] { const char* s = g_value_get_string(value); return std::string(s ? s : ""); };
  switch (id) {
    case kPort: st_->port = g_value_get_uint(value); return true;
    case kToken: st_->token = str(); return true;
    case kTlsCertificate: st_->tls_certificate = str(); return true;
    case kTlsKey: st_->tls_key = str(); return true;
    case kBitrate: st_->bitrate_kbit = g_value_get_uint(value); return true;
    case kMaxSessions: st_->max_sessions = g_value_get_uint(value); return true;
    case kWebRoot: st_->web_root = str(); return true;
    case kPlayoutDelay: st_->playout_delay_ms = g_value_get_int(value); return true;
    case kStunServer: st_->stun_server = str(); return true;
    case kTurnServer: st_->turn_server = str(); return true;
    default: return false;
  }
}

bool WhepEndpoint::get_property(guint id, GValue* value) {
  std::lock_guard<std::mutex> g(st_->lock);
  switch (id) {
    case kPort: g_value_set_uint(value, st_->port); return true;
    case kToken: g_value_set_string(value, st_->token.c_str()); return true;
    case kTlsCertificate: g_value_set_string(value, st_->tls_certificate.c_str()); return true;
    case kTlsKey: g_value_set_string(value, st_->tls_key.c_str()); return true;
    case kBitrate: g_value_set_uint(value, st_->bitrate_kbit); return true;
    case kMaxSessions: g_value_set_uint(value, st_->max_sessions); return true;
    case kWebRoot: g_value_set_string(value, st_->web_root.c_str()); return true;
    case kBoundPort: g_value_set_uint(value, st_->bound_port); return true;
    case kSessions: g_value_set_uint(value, guint(st_->sessions.size())); return true;
    case kPlayoutDelay: g_value_set_int(value, st_->playout_delay_ms); return true;
    case kStunServer: g_value_set_string(value, st_->stun_server.c_str()); return true;
    case kTurnServer: g_value_set_string(value, st_->turn_server.c_str()); return true;
    default: return false;
  }
}

guint WhepEndpoint::bitrate_kbit() const {
  std::lock_guard<std::mutex> g(st_->lock);
  return st_->bitrate_kbit;
}

bool WhepEndpoint::start() {
  State* st = st_.get();
  if (st->token.empty()) {
    GST_ELEMENT_ERROR(st->owner, RESOURCE, SETTINGS, ("%s needs a token: the join secret in the URL", st->name.c_str()),
                      (nullptr));
    return false;
  }
  st->ice_servers.clear();
  auto add_ice_server = [st](const char* property, const std::string& uri, bool stun) {
    IceServer ice;
    std::string why = stun ? "not a stun:// server" : "not a turn:// or turns:// server";
    if (uri.empty()) return true;
    if (parse_ice_server(uri, &ice, &why) && (ice.scheme == "stun") == stun) {
      st->ice_servers.push_back(ice);
      return true;
    }
    GST_ELEMENT_ERROR(st->owner, RESOURCE, SETTINGS, ("%s %s: %s", property, uri.c_str(), why.c_str()), (nullptr));
    return false;
  };
  if (!add_ice_server("stun-server", st->stun_server, true) || !add_ice_server("turn-server", st->turn_server, false))
    return false;
  st->table = WhepSessionTable(st->max_sessions);
  GError* err = nullptr;
  st->context = g_main_context_new();
  st->loop = g_main_loop_new(st->context, FALSE);
  g_main_context_push_thread_default(st->context);
  st->server = soup_server_new(nullptr, nullptr);
  soup_server_add_handler(st->server, nullptr, on_request, st, nullptr);
  bool ok = true;
  if (!st->tls_certificate.empty()) {
    GTlsCertificate* cert = g_tls_certificate_new_from_files(st->tls_certificate.c_str(), st->tls_key.c_str(), &err);
    if (cert) {
      soup_server_set_tls_certificate(st->server, cert);
      g_object_unref(cert);
    } else {
      ok = false;
    }
  }
  if (ok)
    ok = soup_server_listen_all(st->server, st->port,
                                st->tls_certificate.empty() ? SoupServerListenOptions(0) : SOUP_SERVER_LISTEN_HTTPS,
                                &err);
  g_main_context_pop_thread_default(st->context);
  if (!ok) {
    GST_ELEMENT_ERROR(st->owner, RESOURCE, OPEN_READ, ("Cannot serve WHEP on port %u: %s", st->port, err->message),
                      (nullptr));
    g_clear_error(&err);
    stop();
    return false;
  }
  GSList* uris = soup_server_get_uris(st->server);
  if (uris) st->bound_port = g_uri_get_port(static_cast<GUri*>(uris->data));
  g_slist_free_full(uris, (GDestroyNotify)g_uri_unref);
  GST_INFO_OBJECT(st->owner, "WHEP on port %u", st->bound_port);
  st->thread = g_thread_new("whep-http", server_thread, st);
  return true;
}

void WhepEndpoint::stop() {
  State* st = st_.get();
  if (!st->context) return;
  if (st->thread) {
    g_main_loop_quit(st->loop);
    g_thread_join(st->thread);
    st->thread = nullptr;
  }
  std::map<std::string, Session*> sessions;
  {
    std::lock_guard<std::mutex> g(st->lock);
    sessions.swap(st->sessions);
    st->table = WhepSessionTable(st->max_sessions);
  }
  for (auto& kv : sessions) end_session(st, kv.second);
  if (st->server) {
    soup_server_disconnect(st->server);
    g_object_unref(st->server);
    st->server = nullptr;
  }
  g_main_loop_unref(st->loop);
  g_main_context_unref(st->context);
  st->loop = nullptr;
  st->context = nullptr;
}

}  // namespace vclassroom
