#include <gst/vclassroom/webrtc/whep.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include <glib.h>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/webrtc/playout_delay.h>

namespace vclassroom {

bool token_equal(std::string_view expected, std::string_view offered) {
  // Walk the whole secret whatever the offer: the difference accumulates,
  // nothing branches on the data; a length mismatch counts as a difference.
  unsigned char difference = expected.size() == offered.size() ? 0 : 1;
  for (size_t i = 0; i < expected.size(); ++i) {
    const unsigned char o = i < offered.size() ? static_cast<unsigned char>(offered[i]) : 0;
    difference |= static_cast<unsigned char>(expected[i]) ^ o;
  }
  // An empty secret would let everyone in: never equal.
  return difference == 0 && !expected.empty();
}

namespace {

WhepDecision refuse(int status, std::string why) {
  WhepDecision d;
  d.status = status;
  d.why = std::move(why);
  return d;
}

}  // namespace

bool is_whep_session_id(std::string_view id) {
  if (id.size() != kWhepSessionIdChars) return false;
  for (char c : id)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

WhepDecision check_whep_request(const WhepRequest& r, std::string_view expected_token, const WhepLimits& limits,
                                size_t sessions_now) {
  if (!token_equal(expected_token, r.token)) return refuse(401, r.token.empty() ? "no token" : "wrong token");
  const std::string_view base(kWhepPath);
  const std::string_view path(r.path);
  if (path == base) {
    if (r.method == "OPTIONS") {
      WhepDecision d;
      d.action = WhepAction::kIceServers;
      d.status = 204;
      return d;
    }
    if (r.method != "POST") return refuse(405, "only POST or OPTIONS on " + std::string(base));
    if (r.content_type != "application/sdp") return refuse(415, "offer is not application/sdp");
    if (r.body_size > limits.max_offer_bytes || r.body.size() != r.body_size)
      return refuse(413, "offer of " + std::to_string(r.body_size) + " bytes (at most " +
                             std::to_string(limits.max_offer_bytes) + ")");
    if (r.body.substr(0, 4) != "v=0\r" && r.body.substr(0, 4) != "v=0\n") return refuse(400, "not an SDP offer");
    if (sessions_now >= limits.max_sessions)
      return refuse(503, "already " + std::to_string(sessions_now) + " lecturers (at most " +
                             std::to_string(limits.max_sessions) + ")");
    WhepDecision d;
    d.action = WhepAction::kJoin;
    d.status = 201;
    return d;
  }
  if (path.size() > base.size() + 1 && path.substr(0, base.size() + 1) == std::string(base) + "/") {
    const std::string_view id = path.substr(base.size() + 1);
    if (!is_whep_session_id(id)) return refuse(404, "no such session");
    if (r.method != "DELETE") return refuse(405, "only DELETE on a session");
    WhepDecision d;
    d.action = WhepAction::kLeave;
    d.status = 200;
    d.session_id = std::string(id);
    return d;
  }
  return refuse(404, "not a WHEP path");
}

namespace {

// A host name (letters, digits, '-', '.') or an IPv6 address (hex digits, ':', '.').
bool plain_host(const std::string& host) {
  return !host.empty() && std::all_of(host.begin(), host.end(), [](char c) {
    return g_ascii_isalnum(c) || c == '-' || c == '.' || c == ':';
  });
}

// A decoded user name or password that fits a quoted Link header parameter: no control characters, quotes
// or backslashes.
bool plain_credential(const char* text) {
  if (!text || !*text) return false;
  for (const char* c = text; *c; ++c)
    if (static_cast<unsigned char>(*c) < 0x20 || *c == 0x7f || *c == '"' || *c == '\\') return false;
  return true;
}

}  // namespace

bool parse_ice_server(std::string_view uri, IceServer* server, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (uri.size() > 512) return fail("longer than 512 characters");
  const std::string text(uri);
  gchar *scheme = nullptr, *user = nullptr, *password = nullptr, *host = nullptr, *path = nullptr;
  gchar *query = nullptr, *fragment = nullptr;
  gint port = -1;
  GError* err = nullptr;
  // GLib's RFC 3986 parser; user and password come back %-decoded.
  const bool split = g_uri_split_with_user(text.c_str(), G_URI_FLAGS_HAS_PASSWORD, &scheme, &user, &password,
                                           nullptr, &host, &port, &path, &query, &fragment, &err);
  IceServer s;
  s.uri = text;
  s.scheme = scheme ? scheme : "";
  s.host = host ? host : "";
  s.port = port;
  s.username = user ? user : "";
  s.credential = password ? password : "";
  const bool has_user = user != nullptr, rest = (path && *path) || query || fragment;
  const bool credentials_ok = plain_credential(user) && plain_credential(password);
  const std::string error = err ? err->message : "";
  for (gchar* p : {scheme, user, password, host, path, query, fragment}) g_free(p);
  g_clear_error(&err);
  if (!split) return fail(error);
  if (s.scheme != "stun" && s.scheme != "turn" && s.scheme != "turns") return fail("scheme is not stun, turn or turns");
  if (rest) return fail("nothing may follow host:port");
  if (!plain_host(s.host)) return fail("not a host name or address");
  if (s.port < 1 || s.port > 65535) return fail("needs host:port, the port 1 to 65535");
  if (s.scheme == "stun") {
    if (has_user) return fail("a STUN server takes no user");
  } else {
    if (!credentials_ok) return fail("a TURN server needs user:password@ (no control characters, quotes, backslashes)");
    if (s.username.find(':') != std::string::npos)
      return fail("a user name with ':' is not taken: webrtcbin splits user and password at the first ':'");
  }
  if (s.host.find(':') != std::string::npos) s.host = "[" + s.host + "]";  // as written: an IPv6 address
  *server = std::move(s);
  return true;
}

std::string ice_server_link(const IceServer& s) {
  const std::string address = s.host + ":" + std::to_string(s.port);
  if (s.scheme == "stun") return "<stun:" + address + ">; rel=\"ice-server\"";
  return "<" + s.scheme + ":" + address + (s.scheme == "turn" ? "?transport=udp" : "?transport=tcp") +
         ">; rel=\"ice-server\"; username=\"" + s.username + "\"; credential=\"" + s.credential +
         "\"; credential-type=\"password\"";
}

bool lecturer_page_file(std::string_view path, std::string* file, std::string* mime_type) {
  if (path == "/" || path == "/index.html") {
    *file = "index.html";
    *mime_type = "text/html; charset=utf-8";
  } else if (path == "/lecturer.js") {
    *file = "lecturer.js";
    *mime_type = "text/javascript; charset=utf-8";
  } else {
    return false;
  }
  return true;
}

std::string new_whep_session_id() {
  std::string id;
  id.reserve(kWhepSessionIdChars);
  static const char digits[] = "0123456789abcdef";
  for (size_t i = 0; i < kWhepSessionIdChars / 8; ++i) {
    const guint32 word = g_random_int();
    for (int nibble = 0; nibble < 8; ++nibble) id.push_back(digits[(word >> (4 * nibble)) & 0xf]);
  }
  return id;
}

bool WhepSessionTable::add(const std::string& id) {
  if (sessions_.size() >= max_ || sessions_.count(id)) return false;
  sessions_[id].id = id;
  return true;
}

bool WhepSessionTable::remove(const std::string& id) { return sessions_.erase(id) != 0; }

WhepSession* WhepSessionTable::find(const std::string& id) {
  auto it = sessions_.find(id);
  return it == sessions_.end() ? nullptr : &it->second;
}

namespace {

// Splits on single spaces; false when a field is empty (two spaces, leading
// or trailing space) or there are not exactly `count` fields.
bool split_fields(std::string_view s, size_t count, std::vector<std::string_view>* fields) {
  fields->clear();
  size_t start = 0;
  while (fields->size() < count + 1) {
    const size_t end = s.find(' ', start);
    const std::string_view field = s.substr(start, end == std::string_view::npos ? s.size() - start : end - start);
    if (field.empty()) return false;
    fields->push_back(field);
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return fields->size() == count;
}

bool parse_number(std::string_view s, double* v) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
  return ec == std::errc() && end == s.data() + s.size() && std::isfinite(*v);
}

bool parse_number(std::string_view s, uint64_t* v) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
  return ec == std::errc() && end == s.data() + s.size();
}

bool fail(std::string* why, const std::string& text) {
  if (why) *why = text;
  return false;
}

// The items of a comma-separated list, with the spaces around each trimmed (an empty text is one empty item).
std::vector<std::string_view> comma_items(std::string_view text) {
  std::vector<std::string_view> items;
  for (size_t start = 0; start <= text.size();) {
    size_t end = text.find(',', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view item = text.substr(start, end - start);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    items.push_back(item);
    start = end + 1;
  }
  return items;
}

}  // namespace

bool parse_pose_message(std::string_view message, Pose* pose, std::string* why) {
  if (message.size() > kMaxPoseMessageBytes)
    return fail(why, "pose message of " + std::to_string(message.size()) + " bytes (at most " +
                         std::to_string(kMaxPoseMessageBytes) + ")");
  std::vector<std::string_view> f;
  if (!split_fields(message, 10, &f) || f[0] != "pose")
    return fail(why, "not a pose message (\"pose seq time_ms px py pz qx qy qz qw\")");
  Pose p;
  double t_ms = 0;
  double v[7];
  if (!parse_number(f[1], &p.seq)) return fail(why, "pose seq is not a non-negative integer");
  if (!parse_number(f[2], &t_ms) || t_ms < 0 || t_ms > 9.0e12)
    return fail(why, "pose viewer time is not a time in milliseconds");
  for (int i = 0; i < 7; ++i)
    if (!parse_number(f[3 + i], &v[i])) return fail(why, "pose field " + std::to_string(3 + i) + " is not a finite number");
  p.viewer_time_ns = static_cast<int64_t>(std::llround(t_ms * 1e6));
  p.position = Eigen::Vector3d(v[0], v[1], v[2]);
  p.orientation = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
  try {
    validate_pose(p);
  } catch (const Error& e) {
    return fail(why, e.what());
  }
  *pose = p;
  return true;
}

std::string format_pose_message(const Pose& p) {
  char text[kMaxPoseMessageBytes];
  const auto& q = p.orientation;
  std::snprintf(text, sizeof text, "pose %llu %.3f %.17g %.17g %.17g %.17g %.17g %.17g %.17g",
                static_cast<unsigned long long>(p.seq), p.viewer_time_ns < 0 ? 0.0 : p.viewer_time_ns / 1e6,
                p.position.x(), p.position.y(), p.position.z(), q.x(), q.y(), q.z(), q.w());
  return text;
}

std::string format_frame_echo(uint32_t rtp_timestamp, uint64_t seq, int64_t viewer_time_ns,
                              const RenderedPose& rendered) {
  char text[kMaxFrameEchoBytes];
  int n = std::snprintf(text, sizeof text, "frame %u %llu %.3f", rtp_timestamp, static_cast<unsigned long long>(seq),
                        viewer_time_ns < 0 ? -1.0 : viewer_time_ns / 1e6);
  if (rendered.known) {
    const float* p = rendered.position;
    const float* q = rendered.orientation;  // w x y z; the message writes x y z w, as the pose message
    std::snprintf(text + n, sizeof text - n, " %.9g %.9g %.9g %.9g %.9g %.9g %.9g %d", p[0], p[1], p[2], q[1], q[2],
                  q[3], q[0], rendered.clamped ? 1 : 0);
  }
  return text;
}

bool parse_frame_echo(std::string_view message, uint32_t* rtp_timestamp, uint64_t* seq, double* viewer_time_ms,
                      RenderedPose* rendered) {
  if (message.size() > kMaxFrameEchoBytes) return false;
  std::vector<std::string_view> f;
  uint64_t ts = 0, s = 0;
  double t = 0;
  const bool with_pose = split_fields(message, 12, &f);
  if ((!with_pose && !split_fields(message, 4, &f)) || f[0] != "frame" || !parse_number(f[1], &ts) ||
      ts > 0xffffffffu || !parse_number(f[2], &s) || !parse_number(f[3], &t))
    return false;
  RenderedPose r;
  if (with_pose) {
    double v[7];
    for (int i = 0; i < 7; ++i)
      if (!parse_number(f[4 + i], &v[i])) return false;
    if (f[11] != "0" && f[11] != "1") return false;
    r.known = true;
    r.clamped = f[11] == "1";
    for (int i = 0; i < 3; ++i) r.position[i] = static_cast<float>(v[i]);
    r.orientation[0] = static_cast<float>(v[6]);
    for (int i = 0; i < 3; ++i) r.orientation[1 + i] = static_cast<float>(v[3 + i]);
    if (!rendered_pose_is_valid(r)) return false;
  }
  *rtp_timestamp = static_cast<uint32_t>(ts);
  *seq = s;
  *viewer_time_ms = t;
  if (rendered) *rendered = r;
  return true;
}

}  // namespace vclassroom

namespace vclassroom {

WhepHeadVerdict judge_request_head(const WhepRequestHead& head, std::string_view expected_token,
                                   const WhepLimits& limits) {
  auto refuse_head = [](int status, std::string why) {
    WhepHeadVerdict v;
    v.status = status;
    v.why = std::move(why);
    return v;
  };
  // The token first, as check_whep_request: a stranger learns nothing else, and sends nothing more.
  const bool open = open_request(head.method, head.path, head.cors_preflight) != OpenRequest::kNone;
  if (!open && !token_equal(expected_token, head.token))
    return refuse_head(401, head.token.empty() ? "no token" : "wrong token");
  if (head.path.size() > kMaxWhepPathBytes)
    return refuse_head(414, "path of " + std::to_string(head.path.size()) + " bytes");
  if (head.content_length > 0 && static_cast<uint64_t>(head.content_length) > limits.max_offer_bytes)
    return refuse_head(413, "body of " + std::to_string(head.content_length) + " bytes announced (at most " +
                                std::to_string(limits.max_offer_bytes) + ")");
  // Only an offer has a body; reading one nobody wants would be the same attack with another method.
  const bool has_body = head.chunked || head.content_length > 0;
  if (has_body && head.method != "POST") return refuse_head(400, std::string(head.method) + " with a body");
  return WhepHeadVerdict{};
}

bool ConnectionCounter::admit(const std::string& address) {
  if (total_ >= limits_.max_total) return false;
  size_t& n = per_address_[address];
  if (n >= limits_.max_per_address) {
    if (n == 0) per_address_.erase(address);
    return false;
  }
  ++n;
  ++total_;
  return true;
}

void ConnectionCounter::release(const std::string& address) {
  auto it = per_address_.find(address);
  if (it == per_address_.end()) return;
  if (--it->second == 0) per_address_.erase(it);
  --total_;
}

size_t ConnectionCounter::from(const std::string& address) const {
  auto it = per_address_.find(address);
  return it == per_address_.end() ? 0 : it->second;
}

bool parse_listen_addresses(std::string_view text, std::vector<std::string>* addresses, std::string* why) {
  std::vector<std::string> out;
  for (std::string_view item : comma_items(text)) {
    const std::string address(item);
    // Literal addresses only: a name would be resolved at start, and an interface's address may change.
    if (address.empty() || !g_hostname_is_ip_address(address.c_str()))
      return fail(why, "listen address \"" + address + "\" is not an IPv4 or IPv6 address");
    if (std::find(out.begin(), out.end(), address) == out.end()) out.push_back(address);
    if (out.size() > 16) return fail(why, "more than 16 listen addresses");
  }
  *addresses = std::move(out);
  return true;
}

namespace {

// A decimal number of at most `max_digits` digits and nothing else (no sign, no spaces), into `*value`.
bool parse_decimal(std::string_view s, size_t max_digits, uint64_t* value) {
  if (s.empty() || s.size() > max_digits) return false;
  uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  *value = v;
  return true;
}

// A payload type as SDP writes it: 0..127 (RFC 3551: 7 bits in the RTP header).
bool parse_payload_type(std::string_view s, int* pt) {
  uint64_t v = 0;
  if (!parse_decimal(s, 3, &v) || v > 127) return false;
  *pt = static_cast<int>(v);
  return true;
}

// Splits at the first space: "a b c" -> "a", "b c".
std::pair<std::string_view, std::string_view> first_word(std::string_view s) {
  const size_t sp = s.find(' ');
  if (sp == std::string_view::npos) return {s, {}};
  return {s.substr(0, sp), s.substr(sp + 1)};
}

// What one media section says of its formats, while it is read.
struct MediaSection {
  bool video = false;
  bool audio = false;
  bool rtp = false;               // an RTP profile: its formats are payload types
  std::vector<int> formats;       // in the m= line's order
  std::map<int, bool> h264;       // payload type -> rtpmap H264/90000
  std::map<int, bool> baseline;   // payload type -> fmtp packetization-mode=1 and constrained baseline
  std::map<int, bool> opus;       // payload type -> rtpmap opus/48000/2
  int playout_id = 0;
};

// "packetization-mode=1;profile-level-id=42e01f": constrained baseline in mode 1, as GstSDP reads it
// (profile_idc 66 with constraint_set1 is "constrained-baseline").
bool fmtp_is_constrained_baseline_mode1(std::string_view params) {
  bool mode1 = false, baseline = false;
  size_t start = 0;
  while (start < params.size()) {
    size_t end = params.find(';', start);
    if (end == std::string_view::npos) end = params.size();
    std::string_view p = params.substr(start, end - start);
    while (!p.empty() && p.front() == ' ') p.remove_prefix(1);
    if (p == "packetization-mode=1") mode1 = true;
    if (p.size() == 23 && p.substr(0, 17) == "profile-level-id=") {
      const std::string hex(p.substr(17));
      char* stop = nullptr;
      const unsigned long v = std::strtoul(hex.c_str(), &stop, 16);
      if (stop == hex.c_str() + 6 && std::all_of(hex.begin(), hex.end(), [](char c) { return g_ascii_isxdigit(c) != 0; }))
        baseline = (v >> 16) == 0x42 && ((v >> 8) & 0x40) != 0;
    }
    start = end + 1;
  }
  return mode1 && baseline;
}

// The m= line: "<media> <port>[/<count>] <proto> <fmt> ...".
bool read_media_line(std::string_view value, MediaSection* m, std::string* why) {
  auto [media, rest] = first_word(value);
  auto [port_text, rest2] = first_word(rest);
  auto [proto, formats] = first_word(rest2);
  if (media.empty() || port_text.empty() || proto.empty()) return fail(why, "m= line without media, port and proto");
  const size_t slash = port_text.find('/');
  uint64_t port = 0, count = 1;
  if (!parse_decimal(port_text.substr(0, slash), 5, &port) || port > 65535 ||
      (slash != std::string_view::npos && (!parse_decimal(port_text.substr(slash + 1), 2, &count) || count < 1 ||
                                           count > 16)))
    return fail(why, "m= port \"" + std::string(port_text) + "\" out of range");
  m->video = media == "video";
  m->audio = media == "audio";
  m->rtp = proto.find("RTP/") != std::string_view::npos;
  size_t n = 0;
  while (!formats.empty()) {
    auto [fmt, more] = first_word(formats);
    formats = more;
    if (fmt.empty()) continue;
    if (++n > kMaxOfferFormats) return fail(why, "more than " + std::to_string(kMaxOfferFormats) + " formats");
    int pt = 0;
    if (m->rtp) {
      if (!parse_payload_type(fmt, &pt)) return fail(why, "payload type \"" + std::string(fmt) + "\" not in 0..127");
      m->formats.push_back(pt);
    }
  }
  return true;
}

// An a= line inside a media section; the attributes whose numbers anyone reads are checked.
bool read_media_attribute(std::string_view attr, MediaSection* m, std::string* why) {
  const size_t colon = attr.find(':');
  const std::string_view name = attr.substr(0, colon);
  const std::string_view value = colon == std::string_view::npos ? std::string_view() : attr.substr(colon + 1);
  auto [first, rest] = first_word(value);
  int pt = 0;
  if (name == "rtpmap" || name == "fmtp" || (name == "rtcp-fb" && first != "*")) {
    if (!parse_payload_type(first, &pt))
      return fail(why, "a=" + std::string(name) + " payload type \"" + std::string(first) + "\" not in 0..127");
  }
  if (name == "rtpmap") {
    // <encoding>/<clock rate>[/<channels>]
    const size_t s1 = rest.find('/');
    const std::string_view encoding = rest.substr(0, s1);
    const std::string_view clock_rest = s1 == std::string_view::npos ? std::string_view() : rest.substr(s1 + 1);
    const std::string_view clock = clock_rest.substr(0, clock_rest.find('/'));
    uint64_t rate = 0;
    if (encoding.empty() || !parse_decimal(clock, 9, &rate) || rate == 0)
      return fail(why, "a=rtpmap:" + std::to_string(pt) + " without an encoding and clock rate");
    // Chrome also puts codecs on 35..63 once 96..127 are taken (JSEP); H.264 there is never picked.
    if (encoding.size() == 4 && g_ascii_strncasecmp(encoding.data(), "H264", 4) == 0) m->h264[pt] = rate == 90000;
    if (encoding.size() == 4 && g_ascii_strncasecmp(encoding.data(), "opus", 4) == 0)
      m->opus[pt] = rate == 48000 && clock_rest == "48000/2";
  } else if (name == "fmtp") {
    m->baseline[pt] = fmtp_is_constrained_baseline_mode1(rest);
  } else if (name == "extmap") {
    // <id>[/<direction>] <uri> [<attributes>]
    const std::string_view id_text = first.substr(0, first.find('/'));
    uint64_t id = 0;
    if (!parse_decimal(id_text, 3, &id) || id < 1 || id > 255)
      return fail(why, "a=extmap id \"" + std::string(id_text) + "\" not in 1..255");
    if (m->video && m->playout_id == 0 && first_word(rest).first == kPlayoutDelayUri) m->playout_id = int(id);
  } else if (name == "ssrc") {
    uint64_t ssrc = 0;
    if (!parse_decimal(first, 10, &ssrc) || ssrc > 0xffffffffu) return fail(why, "a=ssrc not a 32-bit number");
  } else if (name == "rtcp") {
    uint64_t port = 0;
    if (!parse_decimal(first, 5, &port) || port > 65535) return fail(why, "a=rtcp port out of range");
  }
  return true;
}

// The offer's pick from a finished media section.
void take_media(const MediaSection& m, WhepOffer* offer) {
  if (m.audio && m.rtp && offer->opus_payload < 0) {
    for (int pt : m.formats) {
      auto o = m.opus.find(pt);
      if (o != m.opus.end() && o->second && pt >= 35 && (pt <= 63 || pt >= 96)) {
        offer->opus_payload = pt;
        break;
      }
    }
  }
  if (!m.video || !m.rtp || offer->h264_payload >= 0) return;
  for (int pt : m.formats) {
    auto h = m.h264.find(pt);
    auto b = m.baseline.find(pt);
    if (h != m.h264.end() && h->second && b != m.baseline.end() && b->second && pt >= 96) {
      offer->h264_payload = pt;
      offer->playout_delay_extension_id = m.playout_id;
      return;
    }
  }
}

}  // namespace

bool inspect_whep_offer(std::string_view sdp, WhepOffer* offer, std::string* why) {
  if (sdp.size() > WhepLimits().max_offer_bytes) return fail(why, "offer of " + std::to_string(sdp.size()) + " bytes");
  if (sdp.substr(0, 4) != "v=0\r" && sdp.substr(0, 4) != "v=0\n") return fail(why, "not an SDP offer");
  WhepOffer result;
  MediaSection media;
  bool in_media = false;
  size_t lines = 0, sections = 0, start = 0;
  while (start < sdp.size()) {
    size_t end = sdp.find('\n', start);
    if (end == std::string_view::npos) end = sdp.size();
    std::string_view line = sdp.substr(start, end - start);
    start = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (++lines > kMaxOfferLines) return fail(why, "more than " + std::to_string(kMaxOfferLines) + " lines");
    if (line.size() > kMaxOfferLineBytes)
      return fail(why, "a line of " + std::to_string(line.size()) + " bytes (at most " +
                           std::to_string(kMaxOfferLineBytes) + ")");
    for (char c : line)
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return fail(why, "a control character in a line");
    if (line.size() < 2 || line[1] != '=' || !g_ascii_islower(line[0])) return fail(why, "not a <type>=<value> line");
    const std::string_view value = line.substr(2);
    if (line[0] == 'm') {
      if (in_media) take_media(media, &result);
      if (++sections > kMaxOfferMedia) return fail(why, "more than " + std::to_string(kMaxOfferMedia) + " media");
      media = MediaSection();
      in_media = true;
      if (!read_media_line(value, &media, why)) return false;
    } else if (line[0] == 'a' && in_media) {
      if (!read_media_attribute(value, &media, why)) return false;
    }
  }
  if (in_media) take_media(media, &result);
  *offer = result;
  return true;
}

OpenRequest open_request(std::string_view method, std::string_view path, bool cors_preflight) {
  if (method == "OPTIONS" && cors_preflight) return OpenRequest::kCorsPreflight;
  if (method == "GET" && path == "/favicon.ico") return OpenRequest::kFavicon;
  return OpenRequest::kNone;
}

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(g_ascii_tolower(c));
  return out;
}

// "http[s]://host[:port]" with nothing after, lower-cased, its port written as a browser writes an origin
// (RFC 6454: in decimal, left out where it is the scheme's default); "" when it is not one.
std::string normal_origin(std::string_view text) {
  const std::string s = lower(text);
  size_t at = 0;
  if (s.rfind("http://", 0) == 0) at = 7;
  else if (s.rfind("https://", 0) == 0) at = 8;
  else return "";
  const std::string rest = s.substr(at);
  if (rest.empty() || rest.size() > 253 + 6) return "";
  // A bracketed IPv6 literal, or a name or IPv4 address; then an optional port.
  size_t host_end = 0;
  if (rest[0] == '[') {
    host_end = rest.find(']');
    if (host_end == std::string::npos || host_end < 2) return "";
    for (size_t i = 1; i < host_end; ++i)
      if (!g_ascii_isxdigit(rest[i]) && rest[i] != ':' && rest[i] != '.') return "";
    ++host_end;
  } else {
    while (host_end < rest.size() && (g_ascii_isalnum(rest[host_end]) || rest[host_end] == '-' || rest[host_end] == '.'))
      ++host_end;
    if (host_end == 0) return "";
  }
  if (host_end == rest.size()) return s;
  uint64_t port = 0;
  if (rest[host_end] != ':' || rest.size() - host_end - 1 > 5 ||
      !parse_number(std::string_view(rest).substr(host_end + 1), &port) || port < 1 || port > 65535)
    return "";
  const std::string origin = s.substr(0, at + host_end);
  return port == (at == 7 ? 80 : 443) ? origin : origin + ":" + std::to_string(port);
}

}  // namespace

bool parse_allowed_origins(std::string_view text, std::vector<std::string>* origins, std::string* why) {
  constexpr size_t kMaxOrigins = 16;
  origins->clear();
  for (std::string_view item : comma_items(text)) {
    if (item.empty()) {
      if (text.find_first_not_of(' ') == std::string_view::npos) return true;  // "": none
      *why = "an empty origin in the list";
      return false;
    }
    const std::string origin = item == "*" ? "*" : normal_origin(item);
    if (origin.empty()) {
      *why = "\"" + std::string(item.substr(0, 64)) + "\" is not an origin (http://host[:port] or https://host[:port])";
      return false;
    }
    if (origins->size() == kMaxOrigins) {
      *why = "more than " + std::to_string(kMaxOrigins) + " origins";
      return false;
    }
    origins->push_back(origin);
  }
  return true;
}

std::string cors_allow_origin(const std::vector<std::string>& allowed, std::string_view origin) {
  if (origin.empty()) return "";
  const std::string normal = normal_origin(origin);
  for (const std::string& a : allowed) {
    if (a == "*") return "*";
    if (!normal.empty() && a == normal) return std::string(origin);
  }
  return "";
}

}  // namespace vclassroom
