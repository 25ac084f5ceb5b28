// whepserversink: the server's rendered view to browsers. H.264 (constrained
// baseline, x264enc zerolatency) over webrtcbin (DTLS-SRTP), WHEP signalling
// on a libsoup 3 server in its own thread, the lecturer's pose over a data
// channel re-injected upstream as the vclassroom/pose event, and for each sent
// frame the pose it was rendered for echoed back keyed by RTP timestamp.
// Request checks, token, session ids and message formats live in
// gst/vclassroom/webrtc/whep.h; this file is the GStreamer/libsoup glue.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>
#include <gst/rtp/rtp.h>
#include <gst/sdp/sdp.h>
#include <gst/video/video.h>
#include <gst/webrtc/webrtc.h>
#include <libsoup/soup.h>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/webrtc/whep.h>

#include <map>
#include <mutex>
#include <string>

using namespace vclassroom;

struct _GstWhepServerSink;
typedef struct _GstWhepServerSink GstWhepServerSink;

GST_DEBUG_CATEGORY_STATIC(whep_debug);
#define GST_CAT_DEFAULT whep_debug

namespace {

struct Session {
  std::string id;
  GstElement* queue = nullptr;
  GstElement* pay = nullptr;
  GstElement* webrtc = nullptr;
  GstPad* tee_pad = nullptr;
  GstWebRTCDataChannel* channel = nullptr;
  SoupServerMessage* pending = nullptr;  // the POST waiting for the answer
  GstClockTime last_echoed_pts = GST_CLOCK_TIME_NONE;
  GstWhepServerSink* owner = nullptr;
};

struct FramePose {
  uint64_t seq;
  int64_t viewer_time_ns;
  RenderedPose rendered;  // after the navigation bounds: where the lecturer's view really is
};

struct WhepState {
  std::mutex lock;
  guint port = 8080;
  std::string token, tls_certificate, tls_key, web_root;
  guint bitrate_kbit = 4000;
  guint max_sessions = 4;
  double max_distance_m = 20.0;
  GThread* thread = nullptr;
  GMainContext* context = nullptr;
  GMainLoop* loop = nullptr;
  SoupServer* server = nullptr;
  guint bound_port = 0;
  WhepSessionTable table{4};
  std::map<std::string, Session*> sessions;
  PoseSession poses;
  std::map<GstClockTime, FramePose> frame_poses;  // recent input frames' poses by PTS (bounded)
};

}  // namespace

struct _GstWhepServerSink {
  GstBin parent;
  GstPad* sinkpad;
  GstElement* encoder;
  GstElement* tee;
  WhepState* st;
};
struct GstWhepServerSinkClass {
  GstBinClass parent_class;
};

G_DEFINE_TYPE(GstWhepServerSink, gst_whep_server_sink, GST_TYPE_BIN)
#define GST_WHEP_SERVER_SINK(o) ((GstWhepServerSink*)(o))

enum { PROP_0, PROP_PORT, PROP_TOKEN, PROP_TLS_CERTIFICATE, PROP_TLS_KEY, PROP_BITRATE, PROP_MAX_SESSIONS,
       PROP_WEB_ROOT, PROP_BOUND_PORT };

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("video/x-raw"));

static void respond(SoupServerMessage* msg, int status, const char* type = nullptr, const std::string& body = "") {
  soup_server_message_set_status(msg, status, nullptr);
  if (type) soup_server_message_set_response(msg, type, SOUP_MEMORY_COPY, body.data(), body.size());
}

// --- sessions -------------------------------------------------------------

// The offer's first H.264 payload type a browser decodes as constrained
// baseline in packetization mode 1; -1 when it offers none.
static int pick_h264_payload(const GstSDPMessage* sdp) {
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
      GST_LOG("offered payload %d: %" GST_PTR_FORMAT, pt, caps);
      const bool ok = name && g_ascii_strcasecmp(name, "H264") == 0 && g_strcmp0(mode, "1") == 0 &&
                      g_strcmp0(profile, "constrained-baseline") == 0;
      gst_caps_unref(caps);
      if (ok) return pt;
    }
  }
  return -1;
}

static void on_pose_message(GstWebRTCDataChannel*, const gchar* text, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstWhepServerSink* self = s->owner;
  Pose pose;
  std::string why;
  GstEvent* event = nullptr;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    if (!text || !parse_pose_message(text, &pose, &why) || !pose_is_plausible(pose, self->st->max_distance_m, &why)) {
      GST_WARNING_OBJECT(self, "session %s: pose refused: %s", s->id.c_str(), why.c_str());
      return;
    }
    const PoseVerdict v = self->st->poses.offer(s->id, pose.seq, pose.viewer_time_ns, g_get_monotonic_time() * 1000);
    GST_LOG_OBJECT(self, "session %s: pose %" G_GUINT64_FORMAT " %s", s->id.c_str(), pose.seq, pose_verdict_name(v));
    if (!pose_verdict_obeys(v)) return;
    event = pose_event_new(pose);
  }
  gst_pad_push_event(self->sinkpad, event);
}

static void on_data_channel(GstElement*, GstWebRTCDataChannel* channel, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  std::lock_guard<std::mutex> g(s->owner->st->lock);
  if (s->channel) return;  // the page opens one channel; others are ignored
  GST_DEBUG_OBJECT(s->owner, "session %s: data channel", s->id.c_str());
  s->channel = GST_WEBRTC_DATA_CHANNEL(gst_object_ref(channel));
  g_signal_connect(channel, "on-message-string", G_CALLBACK(on_pose_message), s);
}

// Each RTP packet leaving a session's payloader: the first of each frame
// sends the echo of the pose that frame was rendered for.
static GstPadProbeReturn on_rtp_out(GstPad*, GstPadProbeInfo* info, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstBuffer* buf = (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST)
                       ? gst_buffer_list_get(GST_PAD_PROBE_INFO_BUFFER_LIST(info), 0)
                       : GST_PAD_PROBE_INFO_BUFFER(info);
  if (!buf) return GST_PAD_PROBE_OK;
  WhepState* st = s->owner->st;
  std::string echo;
  GstWebRTCDataChannel* channel = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
    const GstClockTime pts = GST_BUFFER_PTS(buf);
    if (!s->channel || pts == s->last_echoed_pts) return GST_PAD_PROBE_OK;
    s->last_echoed_pts = pts;
    auto it = st->frame_poses.find(pts);
    GST_LOG_OBJECT(s->owner, "frame %" GST_TIME_FORMAT " out: %s", GST_TIME_ARGS(pts),
                   it == st->frame_poses.end() ? "no pose known" : "echo");
    if (it == st->frame_poses.end()) return GST_PAD_PROBE_OK;
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

struct AnswerReply {
  GstWhepServerSink* self;
  std::string id;
  std::string sdp;  // empty: failed
};

// In the server's thread: the answer (or the failure) to the waiting POST.
static gboolean send_answer(gpointer data) {
  AnswerReply* r = static_cast<AnswerReply*>(data);
  std::lock_guard<std::mutex> g(r->self->st->lock);
  auto it = r->self->st->sessions.find(r->id);
  if (it != r->self->st->sessions.end() && it->second->pending) {
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

static void on_gathering_state(GstElement* webrtc, GParamSpec*, gpointer user_data) {
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
  g_main_context_invoke_full(s->owner->st->context, G_PRIORITY_DEFAULT, send_answer, r,
                             [](gpointer p) { delete static_cast<AnswerReply*>(p); });
}

static void on_answer_created(GstPromise* promise, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  GstWebRTCSessionDescription* answer = nullptr;
  const GstStructure* reply = gst_promise_get_reply(promise);
  if (reply) gst_structure_get(reply, "answer", GST_TYPE_WEBRTC_SESSION_DESCRIPTION, &answer, nullptr);
  gst_promise_unref(promise);
  if (!answer) {
    GST_WARNING_OBJECT(s->owner, "session %s: no answer", s->id.c_str());
    return;
  }
  g_signal_emit_by_name(s->webrtc, "set-local-description", answer, nullptr);
  gst_webrtc_session_description_free(answer);
  on_gathering_state(s->webrtc, nullptr, s);  // already complete on loopback
}

static void on_offer_set(GstPromise* promise, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  gst_promise_unref(promise);
  g_signal_emit_by_name(s->webrtc, "create-answer", nullptr,
                        gst_promise_new_with_change_func(on_answer_created, s, nullptr));
}

// Makes the session's branch (queue ! rtph264pay ! webrtcbin) on the tee and
// starts answering `offer`. Called with the lock held; takes `offer`.
static Session* start_session_locked(GstWhepServerSink* self, GstSDPMessage* offer, int payload,
                                     SoupServerMessage* msg) {
  Session* s = new Session;
  s->owner = self;
  s->id = new_whep_session_id();
  s->queue = gst_element_factory_make("queue", nullptr);
  g_object_set(s->queue, "max-size-buffers", 2, "max-size-time", (guint64)0, "max-size-bytes", 0, "leaky", 2,
               nullptr);
  s->pay = gst_element_factory_make("rtph264pay", nullptr);
  g_object_set(s->pay, "pt", payload, "config-interval", -1, "aggregate-mode", 1 /* zero-latency */, nullptr);
  s->webrtc = gst_element_factory_make("webrtcbin", nullptr);
  g_object_set(s->webrtc, "bundle-policy", GST_WEBRTC_BUNDLE_POLICY_MAX_BUNDLE, nullptr);
  gst_bin_add_many(GST_BIN(self), s->queue, s->pay, s->webrtc, nullptr);
  gst_element_link(s->queue, s->pay);
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
  g_signal_connect(s->webrtc, "on-data-channel", G_CALLBACK(on_data_channel), s);
  g_signal_connect(s->webrtc, "notify::ice-gathering-state", G_CALLBACK(on_gathering_state), s);
  gst_element_sync_state_with_parent(s->webrtc);
  gst_element_sync_state_with_parent(s->pay);
  gst_element_sync_state_with_parent(s->queue);
  s->tee_pad = gst_element_request_pad_simple(self->tee, "src_%u");
  GstPad* queue_sink = gst_element_get_static_pad(s->queue, "sink");
  gst_pad_link(s->tee_pad, queue_sink);
  gst_object_unref(queue_sink);
  // A joining browser needs a key frame now, not at the next interval.
  GstPad* enc_src = gst_element_get_static_pad(self->encoder, "src");
  gst_pad_send_event(enc_src, gst_video_event_new_upstream_force_key_unit(GST_CLOCK_TIME_NONE, TRUE, 0));
  gst_object_unref(enc_src);

  s->pending = msg;
  self->st->table.add(s->id);
  self->st->sessions[s->id] = s;
  GstWebRTCSessionDescription* desc = gst_webrtc_session_description_new(GST_WEBRTC_SDP_TYPE_OFFER, offer);
  g_signal_emit_by_name(s->webrtc, "set-remote-description", desc,
                        gst_promise_new_with_change_func(on_offer_set, s, nullptr));
  gst_webrtc_session_description_free(desc);
  return s;
}

// Takes the session's branch out of the pipeline and frees it. Lock not held.
static void end_session(GstWhepServerSink* self, Session* s) {
  GstPad* queue_sink = gst_element_get_static_pad(s->queue, "sink");
  gst_pad_unlink(s->tee_pad, queue_sink);
  gst_object_unref(queue_sink);
  gst_element_release_request_pad(self->tee, s->tee_pad);
  gst_object_unref(s->tee_pad);
  for (GstElement* e : {s->webrtc, s->pay, s->queue}) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(GST_BIN(self), e);
  }
  if (s->channel) gst_object_unref(s->channel);
  if (s->pending) {
    respond(s->pending, 503);
    soup_server_message_unpause(s->pending);
  }
  delete s;
}

// --- HTTP -----------------------------------------------------------------

static void on_request(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable* query, gpointer user_data) {
  GstWhepServerSink* self = GST_WHEP_SERVER_SINK(user_data);
  WhepState* st = self->st;
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
        GST_WARNING_OBJECT(self, "no lecturer page at %s (web-root)", full.c_str());
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
      GST_INFO_OBJECT(self, "%s %s refused %d: %s", r.method.c_str(), path, d.status, d.why.c_str());
      respond(msg, d.status);
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
    } else {
      GstSDPMessage* offer = nullptr;
      int payload = -1;
      if (gst_sdp_message_new_from_text(body_text.c_str(), &offer) != GST_SDP_OK ||
          (payload = pick_h264_payload(offer)) < 0) {
        if (offer) gst_sdp_message_free(offer);
        GST_INFO_OBJECT(self, "offer without H.264 constrained baseline (packetization-mode 1): 406");
        respond(msg, 406);  // no H.264 constrained baseline offered
        return;
      }
      soup_server_message_pause(msg);
      start_session_locked(self, offer, payload, msg);
      return;
    }
  }
  end_session(self, leaving);
  respond(msg, 200);
}

static gpointer server_thread(gpointer data) {
  WhepState* st = static_cast<WhepState*>(data);
  g_main_context_push_thread_default(st->context);
  g_main_loop_run(st->loop);
  g_main_context_pop_thread_default(st->context);
  return nullptr;
}

static bool start_server(GstWhepServerSink* self) {
  WhepState* st = self->st;
  GError* err = nullptr;
  st->context = g_main_context_new();
  st->loop = g_main_loop_new(st->context, FALSE);
  g_main_context_push_thread_default(st->context);
  st->server = soup_server_new(nullptr, nullptr);
  soup_server_add_handler(st->server, nullptr, on_request, self, nullptr);
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
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("Cannot serve WHEP on port %u: %s", st->port, err->message),
                      (nullptr));
    g_clear_error(&err);
    return false;
  }
  GSList* uris = soup_server_get_uris(st->server);
  if (uris) st->bound_port = g_uri_get_port(static_cast<GUri*>(uris->data));
  g_slist_free_full(uris, (GDestroyNotify)g_uri_unref);
  GST_INFO_OBJECT(self, "WHEP on port %u", st->bound_port);
  st->thread = g_thread_new("whep-http", server_thread, st);
  return true;
}

static void stop_server(GstWhepServerSink* self) {
  WhepState* st = self->st;
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
    st->poses.reset();
    st->frame_poses.clear();
  }
  for (auto& kv : sessions) end_session(self, kv.second);
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

// --- element --------------------------------------------------------------

// Every encoded frame's pose (from its pose meta), so the echo can name it.
static GstPadProbeReturn on_frame_in(GstPad*, GstPadProbeInfo* info, gpointer user_data) {
  GstWhepServerSink* self = GST_WHEP_SERVER_SINK(user_data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  PoseMeta* meta = buf ? buffer_get_pose_meta(buf) : nullptr;
  if (!meta || !GST_BUFFER_PTS_IS_VALID(buf)) return GST_PAD_PROBE_OK;
  std::lock_guard<std::mutex> g(self->st->lock);
  self->st->frame_poses[GST_BUFFER_PTS(buf)] = FramePose{meta->seq, meta->viewer_time_ns, meta->rendered};
  while (self->st->frame_poses.size() > 64) self->st->frame_poses.erase(self->st->frame_poses.begin());
  return GST_PAD_PROBE_OK;
}

static GstStateChangeReturn gst_whep_server_sink_change_state(GstElement* element, GstStateChange transition) {
  GstWhepServerSink* self = GST_WHEP_SERVER_SINK(element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    if (self->st->token.empty()) {
      GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("whepserversink needs a token: the join secret in the URL"),
                        (nullptr));
      return GST_STATE_CHANGE_FAILURE;
    }
    g_object_set(self->encoder, "bitrate", self->st->bitrate_kbit, nullptr);
    self->st->table = WhepSessionTable(self->st->max_sessions);
    if (!start_server(self)) return GST_STATE_CHANGE_FAILURE;
  }
  GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_whep_server_sink_parent_class)->change_state(element, transition);
  if (transition == GST_STATE_CHANGE_READY_TO_NULL) stop_server(self);
  return ret;
}

static void gst_whep_server_sink_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  WhepState* st = GST_WHEP_SERVER_SINK(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  auto str = [&] { const char* s = g_value_get_string(value); return std::string(s ? s : ""); };
  switch (id) {
    case PROP_PORT: st->port = g_value_get_uint(value); break;
    case PROP_TOKEN: st->token = str(); break;
    case PROP_TLS_CERTIFICATE: st->tls_certificate = str(); break;
    case PROP_TLS_KEY: st->tls_key = str(); break;
    case PROP_BITRATE: st->bitrate_kbit = g_value_get_uint(value); break;
    case PROP_MAX_SESSIONS: st->max_sessions = g_value_get_uint(value); break;
    case PROP_WEB_ROOT: st->web_root = str(); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_whep_server_sink_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  WhepState* st = GST_WHEP_SERVER_SINK(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (id) {
    case PROP_PORT: g_value_set_uint(value, st->port); break;
    case PROP_TOKEN: g_value_set_string(value, st->token.c_str()); break;
    case PROP_TLS_CERTIFICATE: g_value_set_string(value, st->tls_certificate.c_str()); break;
    case PROP_TLS_KEY: g_value_set_string(value, st->tls_key.c_str()); break;
    case PROP_BITRATE: g_value_set_uint(value, st->bitrate_kbit); break;
    case PROP_MAX_SESSIONS: g_value_set_uint(value, st->max_sessions); break;
    case PROP_WEB_ROOT: g_value_set_string(value, st->web_root.c_str()); break;
    case PROP_BOUND_PORT: g_value_set_uint(value, st->bound_port); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_whep_server_sink_init(GstWhepServerSink* self) {
  self->st = new WhepState;
  self->st->web_root = VCLASSROOM_WEB_DIR;
  GstElement* queue = gst_element_factory_make("queue", nullptr);
  g_object_set(queue, "max-size-buffers", 2, "max-size-time", (guint64)0, "max-size-bytes", 0, "leaky", 2, nullptr);
  GstElement* convert = gst_element_factory_make("videoconvert", nullptr);
  self->encoder = gst_element_factory_make("x264enc", nullptr);
  // Low latency: no B-frames nor lookahead, one slice per frame, a key frame
  // at least every 2 s besides those on join and on the browser's request.
  gst_util_set_object_arg(G_OBJECT(self->encoder), "tune", "zerolatency");
  gst_util_set_object_arg(G_OBJECT(self->encoder), "speed-preset", "ultrafast");
  g_object_set(self->encoder, "key-int-max", 60, "bitrate", self->st->bitrate_kbit, nullptr);
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
  // The pose meta is read after the encoder (which keeps untagged metas): the
  // encoder shifts timestamps, and the payloaders see the encoded PTS.
  GstPad* encoded = gst_element_get_static_pad(self->tee, "sink");
  gst_pad_add_probe(encoded, GST_PAD_PROBE_TYPE_BUFFER, on_frame_in, self, nullptr);
  gst_object_unref(encoded);
  GstPad* target = gst_element_get_static_pad(queue, "sink");
  self->sinkpad = gst_ghost_pad_new_from_template("sink", target, gst_static_pad_template_get(&sink_template));
  gst_object_unref(target);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
}

static void gst_whep_server_sink_finalize(GObject* object) {
  delete GST_WHEP_SERVER_SINK(object)->st;
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
  const GParamFlags rw = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(gobject_class, PROP_PORT,
      g_param_spec_uint("port", "Port", "TCP port of the WHEP/HTTP server (0: any free port, see bound-port)", 0,
                        65535, 8080, rw));
  g_object_class_install_property(gobject_class, PROP_TOKEN,
      g_param_spec_string("token", "Token", "The join secret: requests without it (?token= or Bearer) get 401",
                          "", rw));
  g_object_class_install_property(gobject_class, PROP_TLS_CERTIFICATE,
      g_param_spec_string("tls-certificate", "TLS certificate", "PEM certificate file: serve HTTPS", "", rw));
  g_object_class_install_property(gobject_class, PROP_TLS_KEY,
      g_param_spec_string("tls-key", "TLS key", "PEM private key file of tls-certificate", "", rw));
  g_object_class_install_property(gobject_class, PROP_BITRATE,
      g_param_spec_uint("bitrate", "Bitrate", "H.264 bitrate in kbit/s", 100, 50000, 4000, rw));
  g_object_class_install_property(gobject_class, PROP_MAX_SESSIONS,
      g_param_spec_uint("max-sessions", "Max sessions", "Lecturers at once; more get 503", 1, 64, 4, rw));
  g_object_class_install_property(gobject_class, PROP_WEB_ROOT,
      g_param_spec_string("web-root", "Web root", "Folder of the lecturer page (index.html, lecturer.js); default: the installed one", VCLASSROOM_WEB_DIR, rw));
  g_object_class_install_property(gobject_class, PROP_BOUND_PORT,
      g_param_spec_uint("bound-port", "Bound port", "The port actually listened on", 0, 65535, 0,
                        GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_set_static_metadata(element_class, "WHEP server sink", "Sink/Network",
      "The rendered view to browsers over WebRTC (H.264 constrained baseline, DTLS-SRTP) with WHEP signalling "
      "(POST /whep?token=..., DELETE the Location to leave); the pose comes back over a data channel as the "
      "vclassroom/pose event upstream. Example: gst-launch-1.0 videotestsrc num-buffers=30 ! "
      "video/x-raw,width=960,height=540 ! whepserversink port=0 token=secret",
      "gst-vclassroom");
}
