#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "whep_http_server.h"

#include <netinet/in.h>
#include <netinet/tcp.h>

#include <mutex>

#include <gst/vclassroom/core/warning_limiter.h>

GST_DEBUG_CATEGORY_STATIC(whep_http_debug);
#define GST_CAT_DEFAULT whep_http_debug

namespace vclassroom {

namespace {

// The kinds of trouble the server warns about, each rate-limited on its own.
enum Trouble { kOverCap, kNoDescriptors, kAcceptFailed, kRefusedHead, kBodyCut, kTimedOut, kTroubleCount };

// How long a listener that could not accept waits before it tries again: long enough not to spin while
// the process has no descriptor left, short enough that a lecturer hardly notices.
constexpr guint kAcceptRetryMs = 100;

GQuark connection_quark() { return g_quark_from_static_string("vclassroom-whep-connection"); }
GQuark body_quark() { return g_quark_from_static_string("vclassroom-whep-body"); }

using Impl = WhepHttpServer::Impl;

struct Listener {
  Impl* impl = nullptr;
  GSocket* socket = nullptr;
  GSource* source = nullptr;  // waiting for connections; null while paused
  GSource* retry = nullptr;   // while paused: the timer that resumes it
};

// One accepted connection, kept as qdata of its GSocketConnection: freed (and its place under the caps
// given back) when libsoup, or a refusal, lets the connection go and its descriptor is closed.
struct Connection {
  Impl* impl = nullptr;
  std::string address;
  GSocket* socket = nullptr;          // the connection's, alive as long as this record
  GSocketAddress* remote = nullptr;   // a reference; libsoup hands it back with each message
  GSource* deadline = nullptr;        // until the request has been read whole
  bool head_seen = false;             // its request's headers arrived
};

// The body of a request as it arrives, at most the limit.
struct BodyBuffer {
  std::string text;
  bool cut = false;
};

}  // namespace

struct WhepHttpServer::Impl {
  GstElement* owner = nullptr;
  GMainContext* context = nullptr;
  WhepHttpSettings settings;
  std::function<std::string()> token;
  std::function<std::string(const std::string&)> cors_origin;
  WhepHttpHandler handler;
  SoupServer* server = nullptr;
  std::vector<Listener*> listeners;
  GCancellable* cancellable = nullptr;  // the refusals' writes, cancelled at stop
  guint bound_port = 0;
  // A connection may be let go in another thread than the server's (the answer's), so the counts and the
  // warnings' state are locked.
  std::mutex lock;
  ConnectionCounter counter;
  WarningLimiter warnings[kTroubleCount];
};

namespace {

// The first of each kind of trouble is posted as a warning at once, then at most one every 5 s with the
// count since (the server is under attack or misconfigured, not broken); each is logged at INFO.
void warn(Impl* impl, Trouble kind, const char* singular, const char* plural, const std::string& detail) {
  GST_INFO_OBJECT(impl->owner, "%s: %s", singular, detail.c_str());
  uint64_t count = 0;
  int64_t span = 0;
  {
    std::lock_guard<std::mutex> g(impl->lock);
    if (!impl->warnings[kind].note(g_get_monotonic_time() * 1000, &count, &span)) return;
  }
  const std::string text = describe_occurrences(count, singular, plural, "", span);
  GST_ELEMENT_WARNING(impl->owner, RESOURCE, READ, ("WHEP server: %s", text.c_str()), ("latest: %s", detail.c_str()));
}

void connection_gone(gpointer data) {
  Connection* c = static_cast<Connection*>(data);
  if (c->deadline) {
    g_source_destroy(c->deadline);
    g_source_unref(c->deadline);
  }
  g_object_set_qdata(G_OBJECT(c->remote), connection_quark(), nullptr);
  g_object_unref(c->remote);
  {
    std::lock_guard<std::mutex> g(c->impl->lock);
    c->impl->counter.release(c->address);
  }
  delete c;
}

Connection* connection_of(SoupServerMessage* msg) {
  GSocketAddress* remote = soup_server_message_get_remote_address(msg);
  return remote ? static_cast<Connection*>(g_object_get_qdata(G_OBJECT(remote), connection_quark())) : nullptr;
}

void cancel_deadline(Connection* c) {
  if (!c || !c->deadline) return;
  g_source_destroy(c->deadline);
  g_source_unref(c->deadline);
  c->deadline = nullptr;
}

// The connection has not sent its whole request in time (an idle or slow peer): shutting the socket down
// ends libsoup's wait at once, and libsoup lets the connection go. One that sent no whole head is only
// logged: browsers open spare connections they may never use; a body that stalls is warned about.
gboolean on_deadline(gpointer data) {
  Connection* c = static_cast<Connection*>(data);
  if (c->head_seen)
    warn(c->impl, kTimedOut, "a request whose body stalled closed", "requests whose body stalled closed", c->address);
  else
    GST_INFO_OBJECT(c->impl->owner, "connection from %s closed: no whole request head in time", c->address.c_str());
  g_socket_shutdown(c->socket, TRUE, TRUE, nullptr);
  g_source_unref(c->deadline);
  c->deadline = nullptr;
  return G_SOURCE_REMOVE;
}

void arm(Impl* impl, GSource* source, GSourceFunc callback, gpointer data) {
  g_source_set_callback(source, callback, data, nullptr);
  g_source_attach(source, impl->context);
}

// Hands an accepted socket to libsoup, or closes it at once when it is over a cap.
void take_connection(Impl* impl, GSocket* client) {
  GSocketAddress* remote = g_socket_get_remote_address(client, nullptr);
  GSocketAddress* local = g_socket_get_local_address(client, nullptr);
  bool admitted = false;
  std::string address;
  if (remote && local && G_IS_INET_SOCKET_ADDRESS(remote)) {
    gchar* text = g_inet_address_to_string(g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(remote)));
    address = text;
    g_free(text);
    std::lock_guard<std::mutex> g(impl->lock);
    admitted = impl->counter.admit(address);
  }
  if (!admitted) {
    g_socket_close(client, nullptr);
    warn(impl, kOverCap, "a connection over the caps closed", "connections over the caps closed", address);
    if (remote) g_object_unref(remote);
    if (local) g_object_unref(local);
    return;
  }
  // Each read or write may wait this long; the deadline below bounds the whole request.
  g_socket_set_timeout(client, impl->settings.timeout_s);
  g_socket_set_option(client, IPPROTO_TCP, TCP_NODELAY, TRUE, nullptr);
  GSocketConnection* base = g_socket_connection_factory_create_connection(client);
  Connection* c = new Connection{impl, address, client, remote, nullptr};
  g_object_set_qdata_full(G_OBJECT(base), connection_quark(), c, connection_gone);
  g_object_set_qdata(G_OBJECT(remote), connection_quark(), c);
  c->deadline = g_timeout_source_new(impl->settings.timeout_s * 1000);
  arm(impl, c->deadline, on_deadline, c);
  GIOStream* stream = G_IO_STREAM(base);
  if (impl->settings.tls) {
    GError* err = nullptr;
    GIOStream* tls = g_tls_server_connection_new(stream, impl->settings.tls, &err);
    g_object_unref(base);  // the TLS connection holds it; without one, this lets it go
    if (!tls) {
      warn(impl, kAcceptFailed, "a TLS connection not set up", "TLS connections not set up", err->message);
      g_error_free(err);
      g_object_unref(local);
      return;
    }
    stream = tls;
  }
  soup_server_accept_iostream(impl->server, stream, local, remote, nullptr);
  g_object_unref(stream);
  g_object_unref(local);
}

gboolean on_incoming(GSocket*, GIOCondition, gpointer data);

gboolean resume_listener(gpointer data) {
  Listener* l = static_cast<Listener*>(data);
  g_source_unref(l->retry);
  l->retry = nullptr;
  l->source = g_socket_create_source(l->socket, G_IO_IN, nullptr);
  arm(l->impl, l->source, G_SOURCE_FUNC(on_incoming), l);
  return G_SOURCE_REMOVE;
}

// Accepts what is waiting. When accept fails (no descriptor left, EMFILE/ENFILE, or anything else that
// would fail again at once) the listener pauses and tries again kAcceptRetryMs later: the pending
// connection stays in the kernel's backlog meanwhile, and the listener never gives up (libsoup's does).
gboolean on_incoming(GSocket*, GIOCondition, gpointer data) {
  Listener* l = static_cast<Listener*>(data);
  for (int i = 0; i < 32; ++i) {
    GError* err = nullptr;
    GSocket* client = g_socket_accept(l->socket, nullptr, &err);
    if (client) {
      take_connection(l->impl, client);
      g_object_unref(client);
      continue;
    }
    const bool would_block = g_error_matches(err, G_IO_ERROR, G_IO_ERROR_WOULD_BLOCK);
    const std::string why = err->message;
    const bool no_descriptors = g_error_matches(err, G_IO_ERROR, G_IO_ERROR_TOO_MANY_OPEN_FILES);
    g_error_free(err);
    if (would_block) break;
    if (no_descriptors)
      warn(l->impl, kNoDescriptors, "an accept failed for want of descriptors, retried",
           "accepts failed for want of descriptors, retried", why);
    else
      warn(l->impl, kAcceptFailed, "an accept failed, retried", "accepts failed, retried", why);
    g_source_unref(l->source);
    l->source = nullptr;
    l->retry = g_timeout_source_new(kAcceptRetryMs);
    arm(l->impl, l->retry, resume_listener, l);
    return G_SOURCE_REMOVE;
  }
  return G_SOURCE_CONTINUE;
}

struct Refusal {
  Refusal(Impl* i, SoupServerMessage* m, int s)
      : impl(i), msg(m), status(s), http_1_0(soup_server_message_get_http_version(m) == SOUP_HTTP_1_0) {
    const char* origin = soup_message_headers_get_one(soup_server_message_get_request_headers(m), "Origin");
    const std::string allow = origin && i->cors_origin ? i->cors_origin(origin) : "";
    // (The value is "*" or the request's own Origin, allowed only in its normal form: no header can be made
    // of it.)
    if (!allow.empty()) cors = "Access-Control-Allow-Origin: " + allow + "\r\nVary: Origin\r\n";
  }
  Impl* impl;
  SoupServerMessage* msg;
  int status;
  std::string cors;  // the CORS header lines for a page of an allowed origin, else empty
  bool http_1_0;  // answered in the request's version, as libsoup answers the others
  GIOStream* stream = nullptr;
  std::string text;
};

void refusal_closed(GObject* stream, GAsyncResult* result, gpointer data) {
  g_io_stream_close_finish(G_IO_STREAM(stream), result, nullptr);
  Refusal* r = static_cast<Refusal*>(data);
  g_object_unref(r->stream);
  delete r;
}

void refusal_written(GObject* out, GAsyncResult* result, gpointer data) {
  g_output_stream_write_all_finish(G_OUTPUT_STREAM(out), result, nullptr, nullptr);
  Refusal* r = static_cast<Refusal*>(data);
  g_io_stream_close_async(r->stream, G_PRIORITY_DEFAULT, nullptr, refusal_closed, r);
}

// Out of libsoup's reading (it was paused): takes the connection from libsoup, which would otherwise read
// the body it announced before answering, writes the refusal and closes the connection.
gboolean send_refusal(gpointer data) {
  Refusal* r = static_cast<Refusal*>(data);
  r->stream = soup_server_message_steal_connection(r->msg);
  g_clear_object(&r->msg);
  if (!r->stream) {
    delete r;
    return G_SOURCE_REMOVE;
  }
  r->text = std::string(r->http_1_0 ? "HTTP/1.0 " : "HTTP/1.1 ") + std::to_string(r->status) + " " + soup_status_get_phrase(r->status) +
            "\r\n" + r->cors + "Content-Length: 0\r\nConnection: close\r\n\r\n";
  g_output_stream_write_all_async(g_io_stream_get_output_stream(r->stream), r->text.data(), r->text.size(),
                                  G_PRIORITY_DEFAULT, r->impl->cancellable, refusal_written, r);
  return G_SOURCE_REMOVE;
}

void answer_and_close(Impl* impl, SoupServerMessage* msg, int status) {
  Connection* c = connection_of(msg);
  cancel_deadline(c);  // the write has the socket's own timeout
  soup_server_message_pause(msg);
  GSource* idle = g_idle_source_new();
  g_source_set_callback(idle, send_refusal, new Refusal(impl, SOUP_SERVER_MESSAGE(g_object_ref(msg)), status), nullptr);
  g_source_attach(idle, impl->context);
  g_source_unref(idle);
}

void on_body_chunk(SoupServerMessage* msg, GBytes* chunk, gpointer data) {
  Impl* impl = static_cast<Impl*>(data);
  BodyBuffer* b = static_cast<BodyBuffer*>(g_object_get_qdata(G_OBJECT(msg), body_quark()));
  if (!b || b->cut) return;
  gsize n = 0;
  const char* bytes = static_cast<const char*>(g_bytes_get_data(chunk, &n));
  if (b->text.size() + n > impl->settings.limits.max_offer_bytes) {
    b->cut = true;
    std::string().swap(b->text);
    warn(impl, kBodyCut, "a request body over the limit cut", "request bodies over the limit cut",
         std::to_string(impl->settings.limits.max_offer_bytes) + " bytes at most");
    answer_and_close(impl, msg, 413);
    return;
  }
  b->text.append(bytes, n);
}

// After the headers, before any byte of the body.
void on_request_head(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable* query, gpointer data) {
  Impl* impl = static_cast<Impl*>(data);
  if (Connection* c = connection_of(msg)) c->head_seen = true;
  SoupMessageHeaders* headers = soup_server_message_get_request_headers(msg);
  const std::string token = whep_request_token(msg, query);
  WhepRequestHead head;
  head.method = soup_server_message_get_method(msg);
  head.path = path;
  head.token = token;
  head.cors_preflight = soup_message_headers_get_one(headers, "Access-Control-Request-Method") != nullptr;
  const SoupEncoding encoding = soup_message_headers_get_encoding(headers);
  if (encoding == SOUP_ENCODING_CHUNKED) head.chunked = true;
  else if (encoding == SOUP_ENCODING_CONTENT_LENGTH) head.content_length = soup_message_headers_get_content_length(headers);
  const WhepHeadVerdict verdict = judge_request_head(head, impl->token(), impl->settings.limits);
  if (verdict.status != 0) {
    warn(impl, kRefusedHead, "a request refused before its body", "requests refused before their body",
         std::to_string(verdict.status) + " " + std::string(head.method) + ": " + verdict.why);
    answer_and_close(impl, msg, verdict.status);
    return;
  }
  // The body is gathered here, bounded, instead of by libsoup, which would take any length.
  soup_message_body_set_accumulate(soup_server_message_get_request_body(msg), FALSE);
  g_object_set_qdata_full(G_OBJECT(msg), body_quark(), new BodyBuffer,
                          [](gpointer p) { delete static_cast<BodyBuffer*>(p); });
  g_signal_connect(msg, "got-chunk", G_CALLBACK(on_body_chunk), impl);
}

void on_request_read(SoupServer*, SoupServerMessage* msg, gpointer) { cancel_deadline(connection_of(msg)); }

void on_request(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable* query, gpointer data) {
  Impl* impl = static_cast<Impl*>(data);
  BodyBuffer* b = static_cast<BodyBuffer*>(g_object_get_qdata(G_OBJECT(msg), body_quark()));
  static const std::string empty;
  impl->handler(msg, path, query, b ? b->text : empty);
}

// One listening socket on `address`:`port`; nullptr with `error` set.
GSocket* listen_on(const std::string& address, guint port, GError** error) {
  GInetAddress* ip = g_inet_address_new_from_string(address.c_str());
  if (!ip) {
    g_set_error(error, G_IO_ERROR, G_IO_ERROR_INVALID_ARGUMENT, "%s is not an IP address", address.c_str());
    return nullptr;
  }
  const GSocketFamily family = g_inet_address_get_family(ip);
  GSocket* s = g_socket_new(family, G_SOCKET_TYPE_STREAM, G_SOCKET_PROTOCOL_TCP, error);
  GSocketAddress* where = g_inet_socket_address_new(ip, guint16(port));
  g_object_unref(ip);
  // "::" is IPv6 only, so that it and "0.0.0.0" can share a port (and each be listed or not).
  const bool ok = s && (family != G_SOCKET_FAMILY_IPV6 || g_socket_set_option(s, IPPROTO_IPV6, IPV6_V6ONLY, 1, error)) &&
                  g_socket_bind(s, where, TRUE, error) && (g_socket_set_listen_backlog(s, 128), g_socket_listen(s, error));
  g_object_unref(where);
  if (!ok) {
    g_clear_object(&s);
    return nullptr;
  }
  g_socket_set_blocking(s, FALSE);
  return s;
}

}  // namespace

std::string whep_request_token(SoupServerMessage* msg, GHashTable* query) {
  const char* token = query ? static_cast<const char*>(g_hash_table_lookup(query, "token")) : nullptr;
  if (token) return token;
  const char* auth = soup_message_headers_get_one(soup_server_message_get_request_headers(msg), "Authorization");
  if (auth && g_str_has_prefix(auth, "Bearer ")) return auth + 7;
  return "";
}

WhepHttpServer::WhepHttpServer(GstElement* owner, GMainContext* context, WhepHttpSettings settings,
                               std::function<std::string()> token,
                               std::function<std::string(const std::string&)> cors_origin, WhepHttpHandler handler)
    : impl_(new Impl) {
  static gsize debug_once = 0;
  if (g_once_init_enter(&debug_once)) {
    GST_DEBUG_CATEGORY_INIT(whep_http_debug, "whephttp", 0, "WHEP HTTP connections and their limits");
    g_once_init_leave(&debug_once, 1);
  }
  impl_->owner = owner;
  impl_->context = g_main_context_ref(context);
  impl_->settings = std::move(settings);
  if (impl_->settings.tls) g_object_ref(impl_->settings.tls);
  impl_->token = std::move(token);
  impl_->cors_origin = std::move(cors_origin);
  impl_->handler = std::move(handler);
  impl_->counter = ConnectionCounter(impl_->settings.connections);
  impl_->cancellable = g_cancellable_new();
}

WhepHttpServer::~WhepHttpServer() {
  stop();
  if (impl_->settings.tls) g_object_unref(impl_->settings.tls);
  g_object_unref(impl_->cancellable);
  g_main_context_unref(impl_->context);
}

bool WhepHttpServer::start(GError** error) {
  Impl* impl = impl_.get();
  g_main_context_push_thread_default(impl->context);
  impl->server = soup_server_new(nullptr, nullptr);
  soup_server_add_early_handler(impl->server, nullptr, on_request_head, impl, nullptr);
  soup_server_add_handler(impl->server, nullptr, on_request, impl, nullptr);
  g_signal_connect(impl->server, "request-read", G_CALLBACK(on_request_read), impl);
  g_main_context_pop_thread_default(impl->context);
  guint port = impl->settings.port;
  for (const std::string& address : impl->settings.addresses) {
    GError* err = nullptr;
    GSocket* s = listen_on(address, port, &err);
    if (!s) {
      // A system without IPv6 still serves IPv4 with the default "0.0.0.0,::".
      if (address == "::" && impl->settings.addresses.size() > 1) {
        GST_INFO_OBJECT(impl->owner, "not listening on [::]: %s", err->message);
        g_error_free(err);
        continue;
      }
      g_propagate_prefixed_error(error, err, "%s: ", address.c_str());
      stop();
      return false;
    }
    if (port == 0) {  // the first address picked a free port; the others take the same
      GSocketAddress* bound = g_socket_get_local_address(s, nullptr);
      if (bound) port = g_inet_socket_address_get_port(G_INET_SOCKET_ADDRESS(bound));
      g_clear_object(&bound);
    }
    Listener* l = new Listener{impl, s};
    l->source = g_socket_create_source(s, G_IO_IN, nullptr);
    arm(impl, l->source, G_SOURCE_FUNC(on_incoming), l);
    impl->listeners.push_back(l);
  }
  if (impl->listeners.empty()) {
    g_set_error(error, G_IO_ERROR, G_IO_ERROR_INVALID_ARGUMENT, "no address to listen on");
    stop();
    return false;
  }
  impl->bound_port = port;
  return true;
}

guint WhepHttpServer::bound_port() const { return impl_->bound_port; }

void WhepHttpServer::stop() {
  Impl* impl = impl_.get();
  for (Listener* l : impl->listeners) {
    for (GSource* s : {l->source, l->retry}) {
      if (!s) continue;
      g_source_destroy(s);
      g_source_unref(s);
    }
    g_socket_close(l->socket, nullptr);
    g_object_unref(l->socket);
    delete l;
  }
  impl->listeners.clear();
  // Refusals being written end now: their callbacks run in the loop below and let the connections go.
  g_cancellable_cancel(impl->cancellable);
  if (impl->server) {
    soup_server_disconnect(impl->server);
    g_clear_object(&impl->server);
  }
  while (g_main_context_iteration(impl->context, FALSE)) {
  }
}

}  // namespace vclassroom
