// The GStreamer-free half of the WebRTC lecturer output (issue 13): WHEP
// request checks, the join token compared in constant time, the session
// table, and the pose data channel's messages. Everything that arrives here
// came from the network and is untrusted: sizes are checked first, nothing
// is allocated from a length a peer chose. Not thread-safe: callers lock.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

// True when the two strings are equal; the time taken depends only on the
// length of `expected` (the server's secret), never on where they differ.
bool token_equal(std::string_view expected, std::string_view offered);

struct WhepLimits {
  // An SDP offer from a browser is 3-6 kB; nothing legitimate comes near this.
  size_t max_offer_bytes = 64 * 1024;
  // Lecturers at once; a POST beyond it gets 503.
  size_t max_sessions = 4;
};

// What the HTTP layer hands over of one request (already bounded by it).
struct WhepRequest {
  std::string method;        // "POST", "DELETE", "OPTIONS", ...
  std::string path;          // e.g. "/whep" or "/whep/<session id>"
  std::string token;         // the `token` query parameter, or a Bearer token; empty when absent
  std::string content_type;  // without parameters
  size_t body_size = 0;
  std::string_view body;     // valid only during the check
};

enum class WhepAction {
  kRefuse,  // answer `status` with an empty body and nothing else
  kJoin,    // POST of an offer: make a session, answer 201 with the SDP answer and a Location
  kLeave,   // DELETE of a session's Location: end `session_id`, answer 200
  kIceServers,  // OPTIONS on the endpoint: answer 204 with the ICE servers as Link headers
};

struct WhepDecision {
  WhepAction action = WhepAction::kRefuse;
  int status = 400;
  std::string session_id;  // kLeave: the session named by the path
  std::string why;         // for the log, never sent to the peer
};

inline constexpr const char* kWhepPath = "/whep";
inline constexpr size_t kWhepSessionIdChars = 32;  // 16 random bytes, lower-case hex

// The decision for one request. A wrong or missing token is 401 whatever else
// the request says (checked first, so a stranger learns nothing else).
WhepDecision check_whep_request(const WhepRequest& request, std::string_view expected_token,
                                const WhepLimits& limits, size_t sessions_now);

// The head of an HTTP request as the server has it once the headers are read and before any byte of the
// body: what judge_request_head() decides from. Views into the caller's strings.
struct WhepRequestHead {
  std::string_view method;
  std::string_view path;          // without the query
  std::string_view token;         // as in WhepRequest
  int64_t content_length = -1;    // the Content-Length header; -1 when absent
  bool chunked = false;           // Transfer-Encoding: chunked (no length known in advance)
  bool cors_preflight = false;    // an Access-Control-Request-Method header came (a browser's preflight)
};

// The requests answered without the token: a browser sends no credentials with a CORS preflight (OPTIONS
// with Access-Control-Request-Method, before a page of another origin may POST; Fetch standard) and asks
// for /favicon.ico by itself. Neither tells anything: the preflight is answered with the allowed methods
// and headers only (the ICE servers, which may carry TURN credentials, need the token), the icon with 204.
enum class OpenRequest { kNone, kCorsPreflight, kFavicon };
OpenRequest open_request(std::string_view method, std::string_view path, bool cors_preflight);

// The origins whose pages may call the endpoint (allow-origin, WHEP_ALLOW_ORIGIN): "" none but the
// server's own page, "*" any, or a comma-separated list of origins "http[s]://host[:port]" (spaces around
// the commas allowed; scheme and host compared without case). False, with a reason, for anything else:
// a path, a query, another scheme, a port outside 1..65535, more than 16 origins.
bool parse_allowed_origins(std::string_view text, std::vector<std::string>* origins, std::string* why);
// The Access-Control-Allow-Origin value for a request whose Origin header is `origin` ("" when it has
// none): "*" where any origin is allowed, the origin itself where it is listed, "" otherwise (no CORS
// header: the browser keeps the answer from the other page).
std::string cors_allow_origin(const std::vector<std::string>& allowed, std::string_view origin);

// Longer paths are refused (414): the server's own are a few characters, and a path is logged.
inline constexpr size_t kMaxWhepPathBytes = 1024;

// What to do with a request before its body is read: `status` 0 means read the body (at most
// limits.max_offer_bytes, counted as it comes), anything else is the answer to send at once before the
// connection is closed, unread: 401 (wrong or missing token, checked first as in check_whep_request, but
// for an open_request),
// 414 (path too long), 413 (a Content-Length over the limit), 400 (a body on a method that takes none).
struct WhepHeadVerdict {
  int status = 0;
  std::string why;  // for the log, never sent
};
WhepHeadVerdict judge_request_head(const WhepRequestHead& head, std::string_view expected_token,
                                   const WhepLimits& limits);

// The connections the HTTP server keeps open at once, in all and from one address: a peer that opens
// connections and sends nothing must not take every descriptor the process has (docs/reliability.md).
// One request per connection, so a legitimate browser needs a few at a time.
struct ConnectionLimits {
  size_t max_total = 64;
  size_t max_per_address = 16;
};

// Counts open connections by peer address. Not thread-safe: callers lock (the server's one thread).
class ConnectionCounter {
 public:
  explicit ConnectionCounter(ConnectionLimits limits = ConnectionLimits()) : limits_(limits) {}
  // True, and counted, when one more connection from `address` stays within both caps; false: close it.
  bool admit(const std::string& address);
  // A connection admitted from `address` has closed. Releasing more than was admitted is ignored.
  void release(const std::string& address);
  size_t total() const { return total_; }
  size_t from(const std::string& address) const;
  const ConnectionLimits& limits() const { return limits_; }

 private:
  ConnectionLimits limits_;
  size_t total_ = 0;
  std::map<std::string, size_t> per_address_;
};

// A comma-separated list of IP addresses to listen on ("0.0.0.0,::", "192.168.1.10", "::1"), spaces around
// the commas allowed; false, with a reason, for an empty list, a host name, or more than 16 addresses.
bool parse_listen_addresses(std::string_view text, std::vector<std::string>* addresses, std::string* why);

// What the server takes from a browser's SDP offer (RFC 8866), read here without GStreamer so that
// every value is range-checked before GstSDP and webrtcbin see the offer.
struct WhepOffer {
  // The first video format that is H.264 constrained baseline (profile-level-id 42xxxx with
  // constraint_set1, as GstSDP calls constrained-baseline) in packetization mode 1, at 90 kHz; a dynamic
  // payload type (96..127). -1: none offered.
  int h264_payload = -1;
  int playout_delay_extension_id = 0;  // the video's a=extmap id (1..255) for kPlayoutDelayUri; 0: none
  // Opus (opus/48000/2) on a dynamic payload type (35..63 or 96..127) in the first audio section that has
  // it: the classroom's sound and the lecturer's voice go there. -1: none offered (the view without sound).
  int opus_payload = -1;
};
// Bounds of an offer: Chrome's and Firefox's are 3-8 kB in 60-200 lines with 3-4 media sections.
inline constexpr size_t kMaxOfferLineBytes = 4096;
inline constexpr size_t kMaxOfferLines = 2000;
inline constexpr size_t kMaxOfferMedia = 16;
inline constexpr size_t kMaxOfferFormats = 64;  // per media section
// False, with a reason (the request gets 400), when the offer is not SDP or any value the server, GstSDP or
// webrtcbin reads is out of range: its size, line count and lengths, control characters, the media
// sections' count, port (0..65535) and port count, every RTP payload type (0..127, in m=, a=rtpmap, a=fmtp,
// a=rtcp-fb), a clock rate, an a=extmap id (1..255), an a=ssrc (32 bits), an a=rtcp port. True otherwise,
// with `offer` filled (h264_payload -1: no usable H.264, 406); H.264 on a payload type outside 96..127
// (Chrome puts further codecs on 35..63) is well-formed but never picked.
bool inspect_whep_offer(std::string_view sdp, WhepOffer* offer, std::string* why);

// A STUN or TURN server, as webrtcbin takes it: "stun://host:port", "turn://user:password@host:port" or
// "turns://..." (TURN over TLS), read by GLib's URI parser. Host names, IPv4 or [IPv6] addresses; user and
// password %-decoded ("pa%2Bss" is pa+ss), with no control characters, quotes or backslashes, and no ':' in
// the user name, even escaped (webrtcbin splits user and password at the first one).
struct IceServer {
  std::string scheme;  // "stun", "turn" or "turns"
  std::string host;    // as written (an IPv6 address with its brackets)
  int port = 0;
  std::string username, credential;  // TURN only, unescaped
  std::string uri;                   // as given, for webrtcbin
};
// False, with a reason, for anything else (no default ports: the administrator names them).
bool parse_ice_server(std::string_view uri, IceServer* server, std::string* why);
// The server as a WHEP Link header (the WHEP draft's ICE server configuration, RFC 7064/7065 URIs):
//   <stun:host:port>; rel="ice-server"
//   <turn:host:port?transport=udp>; rel="ice-server"; username="u"; credential="p"; credential-type="password"
// A browser page reads these from the OPTIONS response before it gathers its candidates.
std::string ice_server_link(const IceServer& server);

// The lecturer page's files a GET may ask for (after the token check): the
// file name under the page's folder and its MIME type, or false. A fixed
// list: no path from the request ever reaches the file system.
bool lecturer_page_file(std::string_view path, std::string* file, std::string* mime_type);

// A new session id: 16 bytes from GLib's random source, as 32 hex digits.
std::string new_whep_session_id();
bool is_whep_session_id(std::string_view id);

// The per-session state the element keeps: one PoseSession key each, the
// latest pose obeyed, what was echoed. Sessions are keyed by their id.
struct WhepSession {
  std::string id;
  uint64_t poses = 0;  // poses accepted from this session's data channel
};

class WhepSessionTable {
 public:
  explicit WhepSessionTable(size_t max_sessions) : max_(max_sessions) {}
  // False when full or the id is taken.
  bool add(const std::string& id);
  bool remove(const std::string& id);
  bool contains(const std::string& id) const { return sessions_.count(id) != 0; }
  WhepSession* find(const std::string& id);
  size_t size() const { return sessions_.size(); }
  size_t capacity() const { return max_; }

 private:
  size_t max_;
  std::map<std::string, WhepSession> sessions_;
};

// The data channel's pose message, one text message per pose:
//   "pose <seq> <viewer_time_ms> <px> <py> <pz> <qx> <qy> <qz> <qw>"
// seq a decimal integer, viewer time in milliseconds (the page's
// performance.now(), fractional allowed, >= 0), position in metres in the rig
// frame, orientation the camera-to-rig quaternion (OpenCV camera axes, as the
// vclassroom/pose event). At most kMaxPoseMessageBytes.
inline constexpr size_t kMaxPoseMessageBytes = 512;
// False, with a reason, when the message is not exactly that or the pose is
// not valid (validate_pose). `pose` is written only on success.
bool parse_pose_message(std::string_view message, Pose* pose, std::string* why);
std::string format_pose_message(const Pose& pose);

// What goes back for each sent frame: the pose it was rendered for, keyed by
// the frame's RTP timestamp (the page reads requestVideoFrameCallback's
// metadata.rtpTimestamp): "frame <rtp_timestamp> <seq> <viewer_time_ms>",
// followed, when the frame names it, by the pose as the server rendered it
// (after its navigation bounds) and whether it clamped it:
// " <x> <y> <z> <qx> <qy> <qz> <qw> <0|1>" (rig metres, camera-to-rig
// quaternion, as in the pose message). At most kMaxFrameEchoBytes.
inline constexpr size_t kMaxFrameEchoBytes = 256;
std::string format_frame_echo(uint32_t rtp_timestamp, uint64_t seq, int64_t viewer_time_ns,
                              const RenderedPose& rendered = RenderedPose{});
// False for anything else, or a pose rendered_pose_is_valid() refuses. `rendered` (optional) is left
// unknown for the short form.
bool parse_frame_echo(std::string_view message, uint32_t* rtp_timestamp, uint64_t* seq, double* viewer_time_ms,
                      RenderedPose* rendered = nullptr);

}  // namespace vclassroom
