// The WHEP endpoint's HTTP server: libsoup 3 parses requests and writes responses, but the listening
// sockets are ours (issue #29): libsoup's own listener stops accepting for good after one failed accept
// (a process out of descriptors), counts nothing and times nothing out. Here
//  - each accepted connection is counted per peer address and in all (ConnectionCounter); one over either
//    cap is closed at once;
//  - a connection has `timeout_s` from its accept to the end of its request (headers and body), and each
//    read or write may wait that long (g_socket_set_timeout): idle and slow peers are closed;
//  - the request head is judged (judge_request_head: token, Content-Length, method) before any byte of the
//    body is read; a refusal is answered at once and the connection closed unread;
//  - a body is gathered as it comes, never beyond the limit (chunked bodies too): one that grows over it
//    is cut, answered 413 and closed;
//  - an accept that fails for want of descriptors (EMFILE, ENFILE) pauses that listener and tries again a
//    little later, on IPv4 and IPv6 alike.
// libsoup keeps connections alive only on its own listeners, so each connection here carries one request.
#pragma once

#include <gst/gst.h>
#include <libsoup/soup.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gst/vclassroom/webrtc/whep.h>

namespace vclassroom {

struct WhepHttpSettings {
  std::vector<std::string> addresses;  // IP addresses to listen on (parse_listen_addresses)
  guint port = 0;                      // 0: a free port, the same on every address
  GTlsCertificate* tls = nullptr;      // HTTPS when set (a reference is taken)
  guint timeout_s = 5;
  ConnectionLimits connections;
  WhepLimits limits;  // max_offer_bytes bounds every body
};

// A request whose head was accepted and whose body (at most limits.max_offer_bytes) was read whole.
using WhepHttpHandler =
    std::function<void(SoupServerMessage* msg, const char* path, GHashTable* query, const std::string& body)>;

// The join token a request carries: its `token` query parameter, else an "Authorization: Bearer" header.
std::string whep_request_token(SoupServerMessage* msg, GHashTable* query);

class WhepHttpServer {
 public:
  // `owner` gets the rate-limited warnings; `context` is the server thread's (sources are attached there;
  // every callback, the handler's included, runs in that thread). `token` is asked for each request;
  // `cors_origin` for the Access-Control-Allow-Origin value of a request's Origin (empty: not allowed), so
  // that a refusal from the head alone tells a page of an allowed origin why, as the endpoint's answers do.
  WhepHttpServer(GstElement* owner, GMainContext* context, WhepHttpSettings settings,
                 std::function<std::string()> token, std::function<std::string(const std::string&)> cors_origin,
                 WhepHttpHandler handler);
  ~WhepHttpServer();
  WhepHttpServer(const WhepHttpServer&) = delete;
  WhepHttpServer& operator=(const WhepHttpServer&) = delete;

  // Binds and listens on every address; false with `error` set when one cannot be (the IPv6 wildcard "::"
  // is skipped with a message where the system has no IPv6, if another address listens).
  bool start(GError** error);
  guint bound_port() const;
  // Closes the listeners and every connection. Call once the server thread has stopped.
  void stop();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace vclassroom
