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
#include <gst/vclassroom/core/warning_limiter.h>
#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/whep.h>

#include "whep_http_server.h"
#include "whep_send_branch.h"
#include "whep_voice.h"

GST_DEBUG_CATEGORY_STATIC(whep_endpoint_debug);
#define GST_CAT_DEFAULT whep_endpoint_debug

namespace vclassroom {

namespace {

enum Prop {
  kPort, kToken, kTlsCertificate, kTlsKey, kBitrate, kMaxSessions, kWebRoot, kBoundPort, kSessions, kPlayoutDelay,
  kStunServer, kTurnServer, kLecturerTimeout, kListenAddresses, kHttpTimeout, kMaxConnections,
  kMaxConnectionsPerAddress, kAllowOrigin, kCount
};

struct Session {
  std::string id;
  WhepEndpoint::State* owner = nullptr;
  GstPad* source = nullptr;  // the element's H.264 pad feeding this session (a reference)
  GstPad* sound = nullptr;   // the audio tee's pad feeding this session, or null
  std::unique_ptr<WhepSendBranch> branch;
  SoupServerMessage* pending = nullptr;  // the POST waiting for the answer
};

void respond(SoupServerMessage* msg, int status, const char* type = nullptr, const std::string& body = "") {
  soup_server_message_set_status(msg, status, nullptr);
  if (type) soup_server_message_set_response(msg, type, SOUP_MEMORY_COPY, body.data(), body.size());
}

}  // namespace

struct WhepEndpoint::State {
  GstBin* owner = nullptr;
  std::string name;  // for messages
  WhepEndpointHooks hooks;
  std::mutex lock;
  guint port = 8080;
  std::string token, tls_certificate, tls_key, web_root = VCLASSROOM_WEB_DIR;
  bool web_root_set = false;  // by the application: no other folder is tried
  std::string allow_origin;   // as set; checked at start() into allowed_origins
  std::vector<std::string> allowed_origins;
  std::string stun_server, turn_server;  // as set; checked at start() into ice_servers
  std::vector<IceServer> ice_servers;
  GstElement* audio_tee = nullptr;  // the classroom's sound for the sessions (request_audio_pad), or null
  GstPad* audio_pad = nullptr;      // the element's pad for it
  std::shared_ptr<WhepVoiceMixer> voice;  // the lecturers' voices for the classroom (request_pad), or null
  bool voice_requested = false;          // request_pad is making it
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
  // Where and how long the HTTP server listens and waits (WhepHttpServer); the defaults serve a school's
  // LAN on every interface, IPv4 and IPv6 (docs/lecturer.md).
  std::string listen_addresses = "0.0.0.0,::";
  guint http_timeout_s = 5;
  guint max_connections = 64, max_connections_per_address = 16;
  std::unique_ptr<WhepHttpServer> http;
  WarningLimiter offer_warnings;  // offers refused for values out of range (server thread only)
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

// A stream from session `s`'s browser (webrtcbin's new src pad, in its streaming thread): the lecturer's
// microphone joins the classroom's mix where the element has one; anything else the branch drops.
bool take_lecturer_voice(State* st, const std::string& session, GstPad* pad) {
  GstWebRTCRTPTransceiver* transceiver = nullptr;
  g_object_get(pad, "transceiver", &transceiver, nullptr);
  GstWebRTCKind kind = GST_WEBRTC_KIND_UNKNOWN;
  if (transceiver) {
    g_object_get(transceiver, "kind", &kind, nullptr);
    gst_object_unref(transceiver);
  }
  std::shared_ptr<WhepVoiceMixer> voice;
  {
    std::lock_guard<std::mutex> g(st->lock);
    voice = st->voice;
  }
  if (kind != GST_WEBRTC_KIND_AUDIO || !voice) return false;
  if (!voice->add(session, pad)) {
    GST_WARNING_OBJECT(st->owner, "session %s: the lecturer's voice cannot be decoded", session.c_str());
    return false;
  }
  GST_INFO_OBJECT(st->owner, "session %s: the lecturer's voice joins the classroom's mix", session.c_str());
  return true;
}

// Feeds the element's `source` (taken) for session `id` through its send branch and starts answering
// `offer` (taken). Called with the lock held.
void start_session_locked(State* st, const std::string& id, GstPad* source, GstSDPMessage* offer,
                          const WhepOffer& offered, SoupServerMessage* msg) {
  Session* s = new Session;
  s->owner = st;
  s->id = id;
  s->source = source;
  WhepSendSettings send;
  send.payload = offered.h264_payload;
  send.playout_extension_id = offered.playout_delay_extension_id;
  send.playout_delay_ms = st->playout_delay_ms;
  send.opus_payload = offered.opus_payload;
  send.send_sound = st->audio_tee != nullptr;
  send.take_voice = st->voice != nullptr;
  send.ice_servers = st->ice_servers;
  send.max_kbit = int(st->bitrate_kbit);
  send.lecturer_timeout_ns = int64_t(st->lecturer_timeout_s) * GST_SECOND;
  send.on_incoming = [st, id](GstPad* pad) { return take_lecturer_voice(st, id, pad); };
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
  if (s->branch->audio_sink()) {
    s->sound = gst_element_request_pad_simple(st->audio_tee, "src_%u");
    gst_pad_link(s->sound, s->branch->audio_sink());
  }

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
  if (s->sound) {
    gst_pad_unlink(s->sound, s->branch->audio_sink());
    gst_element_release_request_pad(st->audio_tee, s->sound);
    gst_object_unref(s->sound);
  }
  s->branch.reset();
  // After webrtcbin: no stream of the session's can join the mix any more.
  std::shared_ptr<WhepVoiceMixer> voice;
  {
    std::lock_guard<std::mutex> g(st->lock);
    voice = st->voice;
  }
  if (GstPad* taken = voice ? voice->remove(s->id) : nullptr) gst_object_unref(taken);
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

// GET of the lecturer page's files (lecturer_page_file), with the token.
void serve_page(State* st, SoupServerMessage* msg, const WhepRequest& r, const std::string& file,
                const std::string& mime_type) {
  std::string root;
  bool allowed;
  {
    std::lock_guard<std::mutex> g(st->lock);
    root = st->web_root;
    allowed = token_equal(st->token, r.token);
  }
  gchar* contents = nullptr;
  gsize length = 0;
  const std::string full = root + "/" + file;
  if (!allowed) {
    respond(msg, 401);
  } else if (root.empty() || !g_file_get_contents(full.c_str(), &contents, &length, nullptr)) {
    GST_WARNING_OBJECT(st->owner, "no lecturer page at %s (web-root)", full.c_str());
    respond(msg, 404);
  } else {
    respond(msg, 200, mime_type.c_str(), std::string(contents, length));
    soup_message_headers_replace(soup_server_message_get_response_headers(msg), "Cache-Control", "no-store");
  }
  g_free(contents);
}

// An offer refused for its contents: 400 for a value out of range (with a rate-limited warning: a browser
// does not send those), 406 for no usable H.264. Nothing else is touched.
void refuse_offer(State* st, SoupServerMessage* msg, int status, const std::string& why) {
  GST_INFO_OBJECT(st->owner, "offer refused %d: %s", status, why.c_str());
  uint64_t count = 0;
  int64_t span = 0;
  if (status == 400 && st->offer_warnings.note(g_get_monotonic_time() * 1000, &count, &span)) {
    const std::string text = describe_occurrences(count, "a malformed offer refused", "malformed offers refused", "", span);
    GST_ELEMENT_WARNING(st->owner, STREAM, DECODE, ("WHEP server: %s", text.c_str()), ("latest: %s", why.c_str()));
  }
  respond(msg, status);
}

// POST of an offer that check_whep_request let through: inspected here (every value range-checked, without
// GStreamer) before GstSDP and webrtcbin read it; a session is made for a usable one.
void join(State* st, SoupServerMessage* msg, const std::string& body) {
  WhepOffer offered;
  std::string why;
  GstSDPMessage* offer = nullptr;
  if (!inspect_whep_offer(body, &offered, &why)) return refuse_offer(st, msg, 400, why);
  if (offered.h264_payload < 0)
    return refuse_offer(st, msg, 406, "no H.264 constrained baseline (packetization-mode 1) offered");
  if (gst_sdp_message_new_from_text(body.c_str(), &offer) != GST_SDP_OK) {
    if (offer) gst_sdp_message_free(offer);
    return refuse_offer(st, msg, 400, "GstSDP does not read the offer");
  }
  // The element builds the session's video without the lock (it may read the settings); requests are
  // handled one at a time in this thread, so the session count checked before still holds.
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
    start_session_locked(st, id, source, offer, offered, msg);
  }
  if (st->hooks.start) st->hooks.start(id);
}

// The CORS headers of an answer to a page of an allowed origin (none for another: the browser keeps the
// answer from it); true when the request's origin is allowed (or it names none).
bool allow_cross_origin(State* st, SoupServerMessage* msg) {
  const char* origin = soup_message_headers_get_one(soup_server_message_get_request_headers(msg), "Origin");
  if (!origin) return true;
  std::string allow;
  {
    std::lock_guard<std::mutex> g(st->lock);
    allow = cors_allow_origin(st->allowed_origins, origin);
  }
  if (allow.empty()) return false;
  SoupMessageHeaders* out = soup_server_message_get_response_headers(msg);
  soup_message_headers_replace(out, "Access-Control-Allow-Origin", allow.c_str());
  soup_message_headers_replace(out, "Access-Control-Expose-Headers", "Location, Link");
  soup_message_headers_append(out, "Vary", "Origin");
  return true;
}

// The requests that need no token (open_request): a preflight learns the methods and headers a page of an
// allowed origin may use (403 for another), the icon is no content.
void answer_open_request(State* st, SoupServerMessage* msg, OpenRequest kind) {
  const bool allowed = allow_cross_origin(st, msg);
  if (kind == OpenRequest::kFavicon) return respond(msg, 204);
  if (!allowed) return respond(msg, 403);
  SoupMessageHeaders* out = soup_server_message_get_response_headers(msg);
  soup_message_headers_replace(out, "Access-Control-Allow-Methods", "POST, DELETE, OPTIONS");
  soup_message_headers_replace(out, "Access-Control-Allow-Headers", "Authorization, Content-Type");
  soup_message_headers_replace(out, "Access-Control-Max-Age", "600");
  respond(msg, 204);
}

// A request whose head WhepHttpServer accepted and whose body (bounded) it read.
void on_request(State* st, SoupServerMessage* msg, const char* path, GHashTable* query, const std::string& body) {
  SoupMessageHeaders* in = soup_server_message_get_request_headers(msg);
  const OpenRequest open = open_request(soup_server_message_get_method(msg), path,
                                        soup_message_headers_get_one(in, "Access-Control-Request-Method") != nullptr);
  if (open != OpenRequest::kNone) return answer_open_request(st, msg, open);
  allow_cross_origin(st, msg);
  WhepRequest r;
  r.method = soup_server_message_get_method(msg);
  r.path = path;
  r.token = whep_request_token(msg, query);
  const char* type = soup_message_headers_get_content_type(soup_server_message_get_request_headers(msg), nullptr);
  r.content_type = type ? type : "";
  r.body_size = body.size();
  r.body = body;
  std::string file, mime_type;
  if (r.method == "GET" && lecturer_page_file(r.path, &file, &mime_type)) return serve_page(st, msg, r, file, mime_type);
  Session* leaving = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
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
    }
  }
  if (!leaving) return join(st, msg, body);
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

// The page's folder: web-root when the application set it; else the installed page, or, where nothing is
// installed, VCLASSROOM_WEB_ROOT's (meson devenv and the tests set it to the source tree's). A warning
// names web-root when the folder holds no index.html: browsers opening the server's URL would get 404.
// Called with the lock held.
void find_web_root_locked(State* st) {
  auto has_page = [](const std::string& dir) { return g_file_test((dir + "/index.html").c_str(), G_FILE_TEST_IS_REGULAR); };
  const char* uninstalled = g_getenv("VCLASSROOM_WEB_ROOT");
  if (!st->web_root_set && !has_page(st->web_root) && uninstalled && has_page(uninstalled)) st->web_root = uninstalled;
  if (!has_page(st->web_root))
    GST_ELEMENT_WARNING(st->owner, RESOURCE, NOT_FOUND,
                        ("%s: no lecturer page at %s/index.html: browsers get 404 (set web-root to the folder "
                         "holding index.html, web/lecturer in the source tree)",
                         st->name.c_str(), st->web_root.c_str()),
                        (nullptr));
}

// The HTTP server on the listen-addresses, its caps and timeout from the properties, in a new context that
// the server thread will run; false after posting an error on the owner.
bool start_http(State* st) {
  WhepHttpSettings settings;
  std::string why;
  auto fail = [st](const std::string& text) {
    GST_ELEMENT_ERROR(st->owner, RESOURCE, OPEN_READ, ("Cannot serve WHEP on port %u: %s", st->port, text.c_str()),
                      (nullptr));
    return false;
  };
  if (!parse_listen_addresses(st->listen_addresses, &settings.addresses, &why)) return fail("listen-addresses: " + why);
  GError* err = nullptr;
  if (!st->tls_certificate.empty()) {
    settings.tls = g_tls_certificate_new_from_files(st->tls_certificate.c_str(), st->tls_key.c_str(), &err);
    if (!settings.tls) {
      const std::string text = err->message;
      g_clear_error(&err);
      return fail(text);
    }
  }
  settings.port = st->port;
  settings.timeout_s = st->http_timeout_s;
  settings.connections.max_total = st->max_connections;
  settings.connections.max_per_address = st->max_connections_per_address;
  GTlsCertificate* tls = settings.tls;
  st->context = g_main_context_new();
  st->loop = g_main_loop_new(st->context, FALSE);
  st->http = std::make_unique<WhepHttpServer>(
      GST_ELEMENT(st->owner), st->context, std::move(settings),
      [st] {
        std::lock_guard<std::mutex> g(st->lock);
        return st->token;
      },
      [st](const std::string& origin) {
        std::lock_guard<std::mutex> g(st->lock);
        return cors_allow_origin(st->allowed_origins, origin);
      },
      [st](SoupServerMessage* msg, const char* path, GHashTable* query, const std::string& body) {
        on_request(st, msg, path, query, body);
      });
  if (tls) g_object_unref(tls);  // the server took its own reference
  if (!st->http->start(&err)) {
    const std::string text = err->message;
    g_clear_error(&err);
    st->http.reset();
    g_main_loop_unref(st->loop);
    g_main_context_unref(st->context);
    st->loop = nullptr;
    st->context = nullptr;
    return fail(text);
  }
  st->bound_port = st->http->bound_port();
  return true;
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
                        "Highest H.264 bitrate a lecturer gets, in kbit/s (lowered on reported losses)",
                        100, 50000, 4000, rw()));
  g_object_class_install_property(klass, p + kMaxSessions,
      g_param_spec_uint("max-sessions", "Max sessions", "Lecturers at once; more get 503", 1, 64, 4, rw()));
  g_object_class_install_property(klass, p + kWebRoot,
      g_param_spec_string("web-root", "Web root",
                          "Folder of the lecturer page (index.html, lecturer.js); default: the installed one, else the source tree's",
                          VCLASSROOM_WEB_DIR, rw()));
  g_object_class_install_property(klass, p + kBoundPort,
      g_param_spec_uint("bound-port", "Bound port", "The port actually listened on", 0, 65535, 0, ro()));
  g_object_class_install_property(klass, p + kSessions,
      g_param_spec_uint("sessions", "Sessions", "Lecturers joined now", 0, 64, 0, ro()));
  g_object_class_install_property(klass, p + kPlayoutDelay,
      g_param_spec_int("playout-delay", "Playout delay",
                       "Maximum playout delay sent to browsers, in ms (-1 = not sent)",
                       -1, kPlayoutDelayMaxMs, 100, rw()));
  g_object_class_install_property(klass, p + kStunServer,
      g_param_spec_string("stun-server", "STUN server",
                          "STUN server as stun://host:port for the sessions and the page (empty = host candidates only)",
                          "", rw()));
  g_object_class_install_property(klass, p + kTurnServer,
      g_param_spec_string("turn-server", "TURN server",
                          "TURN relay as turn://user:password@host:port or turns:// (empty = none)", "", rw()));
  g_object_class_install_property(klass, p + kLecturerTimeout,
      g_param_spec_uint("lecturer-timeout", "Lecturer timeout",
                        "Seconds without a receiver report before a lecturer's session is ended (0 = never)",
                        0, 3600, 15, rw()));
  g_object_class_install_property(klass, p + kListenAddresses,
      g_param_spec_string("listen-addresses", "Listen addresses",
                          "Comma-separated IP addresses the WHEP/HTTP server listens on (0.0.0.0 = all IPv4, :: = all IPv6)",
                          "0.0.0.0,::", rw()));
  g_object_class_install_property(klass, p + kHttpTimeout,
      g_param_spec_uint("http-timeout", "HTTP timeout",
                        "Seconds an HTTP connection has to send its whole request; also the longest read or write wait",
                        1, 300, 5, rw()));
  g_object_class_install_property(klass, p + kMaxConnections,
      g_param_spec_uint("max-connections", "Max connections",
                        "HTTP connections open at once; one more is closed at once (each carries one request)",
                        1, 4096, 64, rw()));
  g_object_class_install_property(klass, p + kMaxConnectionsPerAddress,
      g_param_spec_uint("max-connections-per-address", "Max connections per address",
                        "HTTP connections open at once from one IP address; one more is closed at once",
                        1, 4096, 16, rw()));
  g_object_class_install_property(klass, p + kAllowOrigin,
      g_param_spec_string("allow-origin", "Allow origin",
                          "Origins whose pages may call the endpoint (CORS): comma-separated https://host[:port], * = any",
                          "", rw()));
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
    case kWebRoot:
      st_->web_root = str();
      st_->web_root_set = true;
      return true;
    case kPlayoutDelay: st_->playout_delay_ms = g_value_get_int(value); return true;
    case kStunServer: st_->stun_server = str(); return true;
    case kTurnServer: st_->turn_server = str(); return true;
    case kLecturerTimeout: st_->lecturer_timeout_s = g_value_get_uint(value); return true;
    case kListenAddresses: st_->listen_addresses = str(); return true;
    case kHttpTimeout: st_->http_timeout_s = g_value_get_uint(value); return true;
    case kMaxConnections: st_->max_connections = g_value_get_uint(value); return true;
    case kMaxConnectionsPerAddress: st_->max_connections_per_address = g_value_get_uint(value); return true;
    case kAllowOrigin: st_->allow_origin = str(); return true;
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
    case kListenAddresses: g_value_set_string(value, st_->listen_addresses.c_str()); return true;
    case kHttpTimeout: g_value_set_uint(value, st_->http_timeout_s); return true;
    case kMaxConnections: g_value_set_uint(value, st_->max_connections); return true;
    case kMaxConnectionsPerAddress: g_value_set_uint(value, st_->max_connections_per_address); return true;
    case kAllowOrigin: g_value_set_string(value, st_->allow_origin.c_str()); return true;
    default: return false;
  }
}

guint WhepEndpoint::bitrate_kbit() const {
  std::lock_guard<std::mutex> g(st_->lock);
  return st_->bitrate_kbit;
}

void WhepEndpoint::add_sound_pad_templates(GstElementClass* klass) {
  static GstStaticPadTemplate audio =
      GST_STATIC_PAD_TEMPLATE("audio", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS("audio/x-opus"));
  static GstStaticPadTemplate voice =
      GST_STATIC_PAD_TEMPLATE("voice", GST_PAD_SRC, GST_PAD_REQUEST, GST_STATIC_CAPS(WHEP_VOICE_CAPS));
  gst_element_class_add_static_pad_template(klass, &audio);
  gst_element_class_add_static_pad_template(klass, &voice);
}

GstPad* WhepEndpoint::request_pad(GstPadTemplate* templ) {
  const std::string name = GST_PAD_TEMPLATE_NAME_TEMPLATE(templ);
  if (name == "voice") {
    {
      std::lock_guard<std::mutex> g(st_->lock);
      if (st_->voice || st_->voice_requested) return nullptr;
      st_->voice_requested = true;
    }
    // Made without the lock: adding the pad emits pad-added, whose handlers may read the element's settings.
    auto voice = std::make_shared<WhepVoiceMixer>(st_->owner, templ);
    std::lock_guard<std::mutex> g(st_->lock);
    st_->voice_requested = false;
    if (!voice->pad()) return nullptr;
    st_->voice = voice;
    return voice->pad();
  }
  if (name != "audio") return nullptr;
  GstElement* tee = nullptr;
  {
    std::lock_guard<std::mutex> g(st_->lock);
    if (st_->audio_pad) return nullptr;
    if (!st_->audio_tee) {
      // A session not yet linked to it (or none at all) must not stop the sound: the tee drops it.
      st_->audio_tee = gst_element_factory_make("tee", nullptr);
      g_object_set(st_->audio_tee, "allow-not-linked", TRUE, nullptr);
      gst_bin_add(st_->owner, st_->audio_tee);
    }
    tee = st_->audio_tee;
  }
  GstPad* target = gst_element_get_static_pad(tee, "sink");
  GstPad* pad = gst_ghost_pad_new_from_template("audio", target, templ);
  gst_object_unref(target);
  gst_pad_set_active(pad, TRUE);
  gst_element_add_pad(GST_ELEMENT(st_->owner), pad);
  gst_element_sync_state_with_parent(tee);
  std::lock_guard<std::mutex> g(st_->lock);
  st_->audio_pad = pad;
  return pad;
}

bool WhepEndpoint::release_pad(GstPad* pad) {
  std::shared_ptr<WhepVoiceMixer> voice;
  {
    std::lock_guard<std::mutex> g(st_->lock);
    if (pad && st_->voice && pad == st_->voice->pad()) {
      voice = std::move(st_->voice);
      // The sessions go on without being heard: their microphones' streams are dropped from now on.
      for (auto& [id, s] : st_->sessions)
        if (GstPad* taken = voice->remove(id)) {
          s->branch->drain(taken);
          gst_object_unref(taken);
        }
    }
  }
  if (voice) {
    voice->take_out();
    return true;
  }
  {
    std::lock_guard<std::mutex> g(st_->lock);
    if (!pad || pad != st_->audio_pad) return false;
    st_->audio_pad = nullptr;
  }
  // The tee stays, silent, with the sessions' branches of it (a pad requested again feeds them anew).
  gst_element_remove_pad(GST_ELEMENT(st_->owner), pad);
  return true;
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
  {
    // The application may read or set the properties meanwhile.
    std::lock_guard<std::mutex> g(st->lock);
    std::string why;
    if (!parse_allowed_origins(st->allow_origin, &st->allowed_origins, &why)) {
      GST_ELEMENT_ERROR(st->owner, RESOURCE, SETTINGS, ("allow-origin %s: %s", st->allow_origin.c_str(), why.c_str()),
                        (nullptr));
      return false;
    }
    find_web_root_locked(st);
  }
  st->table = WhepSessionTable(st->max_sessions);
  if (!start_http(st)) return false;
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
    // The quit goes to the loop as a source of its context: g_main_loop_run marks the loop running when it
    // starts, so a g_main_loop_quit that came before the server thread got that far (a pipeline that ran and
    // stopped within the thread's first time slice, on a loaded machine) was lost, and the join below waited
    // for ever. (g_main_context_invoke is no help: while no thread owns the context it runs the callback
    // here, before the loop.)
    GSource* quit = g_idle_source_new();
    g_source_set_priority(quit, G_PRIORITY_HIGH);
    g_source_set_callback(
        quit,
        [](gpointer loop) -> gboolean {
          g_main_loop_quit(static_cast<GMainLoop*>(loop));
          return G_SOURCE_REMOVE;
        },
        g_main_loop_ref(st->loop), reinterpret_cast<GDestroyNotify>(g_main_loop_unref));
    g_source_attach(quit, st->context);
    g_source_unref(quit);
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
  st->http.reset();  // closes the listeners and every connection
  g_main_loop_unref(st->loop);
  g_main_context_unref(st->context);
  st->loop = nullptr;
  st->context = nullptr;
}

}  // namespace vclassroom
