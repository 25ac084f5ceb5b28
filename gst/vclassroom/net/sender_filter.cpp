#include <gst/vclassroom/net/sender_filter.h>

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

NetAddress from_ipv4(const in_addr& a) {
  NetAddress out{};
  out[10] = out[11] = 0xff;
  std::memcpy(out.data() + 12, &a, 4);
  return out;
}

NetAddress from_ipv6(const in6_addr& a) {
  NetAddress out{};
  std::memcpy(out.data(), &a, 16);
  return out;
}

}  // namespace

std::vector<NetAddress> resolve_address(const std::string& text) {
  in_addr v4{};
  if (inet_pton(AF_INET, text.c_str(), &v4) == 1) return {from_ipv4(v4)};
  in6_addr v6{};
  if (inet_pton(AF_INET6, text.c_str(), &v6) == 1) return {from_ipv6(v6)};
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int rc = getaddrinfo(text.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr)
    throw Error("allowed sender '" + text + "' is neither an IP address nor a host name that resolves (" +
                gai_strerror(rc) + ")");
  std::vector<NetAddress> out;
  for (addrinfo* a = found; a != nullptr; a = a->ai_next) {
    if (a->ai_family == AF_INET)
      out.push_back(from_ipv4(reinterpret_cast<const sockaddr_in*>(a->ai_addr)->sin_addr));
    else if (a->ai_family == AF_INET6)
      out.push_back(from_ipv6(reinterpret_cast<const sockaddr_in6*>(a->ai_addr)->sin6_addr));
  }
  freeaddrinfo(found);
  return out;
}

namespace {

// The entries of a property's list: separated by commas, spaces or tabs.
std::vector<std::string> list_entries(const std::string& text) {
  std::vector<std::string> entries;
  std::string entry;
  for (char c : text + ",") {
    if (c != ',' && c != ' ' && c != '\t') {
      entry += c;
    } else if (!entry.empty()) {
      entries.push_back(entry);
      entry.clear();
    }
  }
  return entries;
}

uint8_t parse_payload_type(const std::string& entry) {
  char* end = nullptr;
  const long v = std::strtol(entry.c_str(), &end, 10);
  if (end == entry.c_str() || *end || v < 0 || v > 127)
    throw Error("payload type '" + entry + "' (expected an RTP payload type, 0 to 127)");
  return uint8_t(v);
}

}  // namespace

std::vector<NetAddress> parse_allowed_senders(const std::string& text) {
  std::vector<NetAddress> out;
  for (const std::string& entry : list_entries(text))
    for (const NetAddress& a : resolve_address(entry)) out.push_back(a);
  return out;
}

std::vector<uint8_t> parse_payload_types(const std::string& text) {
  std::vector<uint8_t> out;
  for (const std::string& entry : list_entries(text)) out.push_back(parse_payload_type(entry));
  return out;
}

std::map<uint8_t, uint32_t> parse_fixed_ssrcs(const std::string& text) {
  std::map<uint8_t, uint32_t> out;
  for (const std::string& entry : list_entries(text)) {
    const size_t eq = entry.find('=');
    const std::string value = eq == std::string::npos ? "" : entry.substr(eq + 1);
    char* end = nullptr;
    errno = 0;
    const unsigned long long v = value.empty() ? 0 : std::strtoull(value.c_str(), &end, 0);
    if (eq == std::string::npos || value.empty() || value[0] == '-' || *end || errno || v > 0xFFFFFFFFull)
      throw Error("SSRC entry '" + entry + "' (expected PT=SSRC, e.g. 96=0x56430001)");
    out[parse_payload_type(entry.substr(0, eq))] = uint32_t(v);
  }
  return out;
}

std::string address_to_string(const NetAddress& address) {
  static const uint8_t kMapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
  char buf[INET6_ADDRSTRLEN] = {};
  if (std::memcmp(address.data(), kMapped, 12) == 0)
    inet_ntop(AF_INET, address.data() + 12, buf, sizeof buf);
  else
    inet_ntop(AF_INET6, address.data(), buf, sizeof buf);
  return buf;
}

SenderFilter::SenderFilter(std::vector<NetAddress> allowed, bool lock_ssrc, int64_t takeover_ns)
    : allowed_(std::move(allowed)), lock_ssrc_(lock_ssrc), takeover_ns_(takeover_ns) {}

SenderFilter::Verdict SenderFilter::check(const NetAddress* source, const uint8_t* data, size_t size,
                                          int64_t now_ns) {
  if (!allowed_.empty() &&
      (source == nullptr || std::find(allowed_.begin(), allowed_.end(), *source) == allowed_.end())) {
    ++dropped_address_;
    return Verdict::kForeignAddress;
  }
  // RTP fixed header: version 2, 12 bytes at least (RFC 3550 §5.1).
  if (size < 12 || (data[0] >> 6) != 2) {
    ++dropped_not_rtp_;
    return Verdict::kNotRtp;
  }
  const uint8_t pt = data[1] & 0x7f;
  if (!payload_types_.empty() && std::find(payload_types_.begin(), payload_types_.end(), pt) == payload_types_.end()) {
    ++dropped_payload_type_;
    return Verdict::kForeignPayloadType;
  }
  const uint32_t ssrc = uint32_t(data[8]) << 24 | uint32_t(data[9]) << 16 | uint32_t(data[10]) << 8 | data[11];
  if (auto fixed = fixed_.find(pt); fixed != fixed_.end()) {
    if (ssrc != fixed->second) {
      ++dropped_ssrc_;
      return Verdict::kForeignSsrc;
    }
  } else if (lock_ssrc_) {
    auto it = streams_.find(pt);
    if (it == streams_.end()) {
      streams_[pt] = Kept{ssrc, now_ns};
    } else if (it->second.ssrc == ssrc) {
      it->second.last_ns = now_ns;
    } else if (now_ns - it->second.last_ns >= takeover_ns_) {
      it->second = Kept{ssrc, now_ns};  // the kept stream fell silent: a restarted sender takes over
    } else {
      ++dropped_ssrc_;
      return Verdict::kForeignSsrc;
    }
  }
  ++accepted_;
  return Verdict::kAccept;
}

bool SenderFilter::kept_ssrc(uint8_t pt, uint32_t* ssrc) const {
  auto it = streams_.find(pt);
  if (it == streams_.end()) return false;
  *ssrc = it->second.ssrc;
  return true;
}

}  // namespace vclassroom
