#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "whep_endpoint.h"

#include <gst/sdp/sdp.h>
#include <gst/webrtc/webrtc.h>
#include <libsoup/soup.h>

#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/whep.h>

#include "whep_send_branch.h"

GST_DEBUG_CATEGORY_STATIC(whep_endpoint_debug);
#define GST_CAT_DEFAULT whep_endpoint_debug

namespace vclassroom {

namespace {

enum Prop {
  kPort, kToken, kTlsCertificate, kTlsKey, kBitrate, kMaxSessions, kWebRoot, kBoundPort, kSessions, kPlayoutDelay,
  kStunServer, kTurnServer, kLecturerTimeout, kCount
};

struct Session {
  std::string id;
  WhepEndpoint::State* owner = nullptr;
  GstPad* source = nullptr;  // the element's H.264 pad feeding this session (a reference)
  std::unique_ptr<WhepSendBranch> branch;
  SoupServerMessage* pending = nullptr;  // the POST waiting for the answer
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

// The id the offer's video gives the extension `uri` (a=extmap, as GstSDP reads it into extmap-<id> caps
// fields: the URI alone, or <direction, URI, attributes>), or 0 when it offers none.
int offered_extension_id(const GstSDPMessage* sdp, const char* uri) {
  int id = 0;
  for (guint m = 0; m < gst_sdp_message_medias_len(sdp) && id == 0; ++m) {
    const GstSDPMedia* media = gst_sdp_message_get_media(sdp, m);
    if (g_strcmp0(gst_sdp_media_get_media(media), "video") != 0) continue;
    GstCaps* caps = gst_caps_new_empty_simple("application/x-rtp");
    gst_sdp_media_attributes_to_caps(media, caps);
    const GstStructure* s = gst_caps_get_structure(caps, 0);
    for (int f = 0; f < gst_structure_n_fields(s) && id == 0; ++f) {
      const char* field = gst_structure_nth_field_name(s, f);
      if (!g_str_has_prefix(field, "extmap-")) continue;
      const GValue* v = gst_structure_get_value(s, field);
      if (GST_VALUE_HOLDS_ARRAY(v)) v = gst_value_array_get_size(v) > 1 ? gst_value_array_get_value(v, 1) : nullptr;
      const int n = atoi(field + 7);
      if (v && G_VALUE_HOLDS_STRING(v) && g_strcmp0(g_value_get_string(v), uri) == 0 && n >= 1 && n <= 255) id = n;
    }
    gst_caps_unref(caps);
  }
  return id;
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
  guint lecturer_timeout_s = 15;  // no receiver report for this long: the lecturer is gone; 0: never
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
  if (!s->branch->set_echo_channel(channel)) return;  // the page opens one channel; others are ignored
  GST_DEBUG_OBJECT(s->owner->owner, "session %s: data channel", s->id.c_str());
  g_signal_connect(channel, "on-message-string", G_CALLBACK(on_pose_message), s);
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
  g_signal_emit_by_name(s->branch->webrtc(), "set-local-description", answer, nullptr);
  gst_webrtc_session_description_free(answer);
  on_gathering_state(s->branch->webrtc(), nullptr, s);  // already complete on loopback
}

void on_offer_set(GstPromise* promise, gpointer user_data) {
  Session* s = static_cast<Session*>(user_data);
  gst_promise_unref(promise);
  g_signal_emit_by_name(s->branch->webrtc(), "create-answer", nullptr,
                        gst_promise_new_with_change_func(on_answer_created, s, nullptr));
}

// Feeds the element's `source` (taken) for session `id` through its send branch and starts answering
// `offer` (taken). Called with the lock held.
void start_session_locked(State* st, const std::string& id, GstPad* source, GstSDPMessage* offer, int payload,
                          SoupServerMessage* msg) {
  Session* s = new Session;
  s->owner = st;
  s->id = id;
  s->source = source;
  WhepSendSettings send;
  send.payload = payload;
  send.playout_extension_id = offered_extension_id(offer, kPlayoutDelayUri);
  send.playout_delay_ms = st->playout_delay_ms;
  send.ice_servers = st->ice_servers;
  send.max_kbit = int(st->bitrate_kbit);
  send.lecturer_timeout_ns = int64_t(st->lecturer_timeout_s) * GST_SECOND;
  send.on_rate = [st, id](int kbit, double fraction_lost) {
    GST_INFO_OBJECT(st->owner, "session %s: %.1f %% lost, now %d kbit/s", id.c_str(), 100 * fraction_lost, kbit);
    gst_element_post_message(GST_ELEMENT(st->owner),
                             gst_message_new_element(GST_OBJECT(st->owner),
                                                     gst_structure_new("vclassroom-lecturer-bitrate", "session",
                                                                       G_TYPE_STRING, id.c_str(), "kbit", G_TYPE_INT,
                                                                       kbit, "fraction-lost", G_TYPE_DOUBLE,
                                                                       fraction_lost, nullptr)));
    if (st->hooks.rate) st->hooks.rate(id, kbit);
  };
  s->branch = std::make_unique<WhepSendBranch>(st->owner, id, send);
  GstElement* webrtc = s->branch->webrtc();
  g_signal_connect(webrtc, "on-data-channel", G_CALLBACK(on_data_channel), s);
  g_signal_connect(webrtc, "notify::ice-gathering-state", G_CALLBACK(on_gathering_state), s);
  gst_pad_link(s->source, s->branch->sink());

  s->pending = msg;
  st->table.add(s->id);
  st->sessions[s->id] = s;
  GstWebRTCSessionDescription* desc = gst_webrtc_session_description_new(GST_WEBRTC_SDP_TYPE_OFFER, offer);
  g_signal_emit_by_name(webrtc, "set-remote-description", desc,
                        gst_promise_new_with_change_func(on_offer_set, s, nullptr));
  gst_webrtc_session_description_free(desc);
}

// Takes the session's branch out of the pipeline, lets the element take its source out, and frees it.
// Lock not held.
void end_session(State* st, Session* s) {
  gst_pad_unlink(s->source, s->branch->sink());
  s->branch.reset();
  st->hooks.detach(s->id, s->source);
  gst_object_unref(s->source);
  if (s->pending) {
    respond(s->pending, 503);
    soup_server_message_unpause(s->pending);
  }
  delete s;
}

// Every second: each session's branch looks for a new receiver report (its bitrate follows the losses), and
// a session whose lecturer has gone silent (WhepSendBranch::lecturer_gone) is ended with a warning.
// Sessions start and end in this thread only (or after it stopped), so the branches stay while they are
// polled; they are polled without the lock, because a webrtcbin that is not running answers at once and
// the element's rate hook takes the element's lock.
gboolean poll_receiver_reports(gpointer user_data) {
  State* st = static_cast<State*>(user_data);
  std::vector<Session*> sessions;
  {
    std::lock_guard<std::mutex> g(st->lock);
    for (auto& kv : st->sessions)
      if (kv.second->branch) sessions.push_back(kv.second);
  }
  for (Session* s : sessions) s->branch->poll_receiver_reports();
  for (Session* s : sessions) {
    int64_t silent_ns = 0;
    if (s->pending || !s->branch->lecturer_gone(&silent_ns)) continue;
    {
      std::lock_guard<std::mutex> g(st->lock);
      st->sessions.erase(s->id);
      st->table.remove(s->id);
    }
    const std::string id = s->id;
    end_session(st, s);
    GST_ELEMENT_WARNING(st->owner, RESOURCE, READ,
                        ("Lecturer of session %s is gone: no receiver report for %.0f s; the session is ended",
                         id.c_str(), double(silent_ns) / GST_SECOND),
                        ("lecturer-timeout %u s", st->lecturer_timeout_s));
  }
  return G_SOURCE_CONTINUE;
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
      g_param_spec_uint("bitrate", "Bitrate",
                        "H.264 bitrate in kbit/s, the most a lecturer gets: each session's rate follows the losses "
                        "its browser reports (posting a vclassroom-lecturer-bitrate element message: session, "
                        "kbit, fraction-lost on each change; whepserversink's shared encoder takes the lowest)",
                        100, 50000, 4000, rw()));
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
  g_object_class_install_property(klass, p + kLecturerTimeout,
      g_param_spec_uint("lecturer-timeout", "Lecturer timeout",
                        "Seconds without a receiver report from a lecturer's browser, while their view was sent, "
                        "after which the lecturer is taken as gone (a closed laptop, a lost network, a handshake "
                        "never finished): their session is ended with a warning and its place freed. 0: never",
                        0, 3600, 15, rw()));
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
    case kLecturerTimeout: st_->lecturer_timeout_s = g_value_get_uint(value); return true;
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
    case kLecturerTimeout: g_value_set_uint(value, st_->lecturer_timeout_s); return true;
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
  GSource* reports = g_timeout_source_new_seconds(1);
  g_source_set_callback(reports, poll_receiver_reports, st, nullptr);
  g_source_attach(reports, st->context);
  g_source_unref(reports);
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
