// Which packets a receiver takes: only from configured source addresses, and
// on a camera port only one RTP stream (SSRC) per payload type. A second
// flow's cameras on the same host, or anyone on the network, must not reach
// (and stop, or steer) a running server. GStreamer-free: the element
// (senderfilter, plugins/net) passes each packet's source address and bytes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace vclassroom {

// An IPv4 or IPv6 address as 16 bytes (IPv4 as an IPv4-mapped IPv6 address,
// so "127.0.0.1" and "::ffff:127.0.0.1" compare equal).
using NetAddress = std::array<uint8_t, 16>;

// Parses one address: numeric IPv4/IPv6, or a host name resolved now (all
// of its addresses). Throws vclassroom::Error naming the entry otherwise.
std::vector<NetAddress> resolve_address(const std::string& text);
// "127.0.0.1, 10.0.0.7,camera3.local": comma- or space-separated entries,
// each resolved as above. An empty list allows every address.
std::vector<NetAddress> parse_allowed_senders(const std::string& text);
// "96,97": the RTP payload types a port carries (comma- or space-separated,
// each 0..127). An empty list allows every payload type. Throws Error.
std::vector<uint8_t> parse_payload_types(const std::string& text);
// "96=1447231489, 97=0x56431000": the one SSRC each payload type may carry
// (decimal or 0x hex). Throws Error.
std::map<uint8_t, uint32_t> parse_fixed_ssrcs(const std::string& text);
// Numeric form for messages ("10.0.0.7", "::1").
std::string address_to_string(const NetAddress& address);

class SenderFilter {
 public:
  enum class Verdict { kAccept, kForeignAddress, kForeignPayloadType, kForeignSsrc, kNotRtp };

  // allowed empty: any address. lock_ssrc: keep one SSRC per payload type
  // and drop the others, until the kept one has been silent for
  // takeover_ns (a restarted camera comes back with a new SSRC).
  SenderFilter(std::vector<NetAddress> allowed, bool lock_ssrc, int64_t takeover_ns);

  // One packet: its source (nullptr: unknown, which counts as foreign when
  // a list is set), its bytes, and the caller's monotonic time.
  Verdict check(const NetAddress* source, const uint8_t* data, size_t size, int64_t now_ns);
  // Only RTP of these payload types passes (empty: any). A packet of another
  // type is never locked onto: with retransmission, a stray payload type
  // would open a stream nothing downstream handles.
  void set_payload_types(std::vector<uint8_t> types) { payload_types_ = std::move(types); }
  // A payload type with a fixed SSRC (a camera's, known to both ends) takes
  // only that one, from the first packet on: a stray packet of that type can
  // neither be locked onto first nor open a second stream downstream.
  void set_fixed_ssrcs(std::map<uint8_t, uint32_t> fixed) { fixed_ = std::move(fixed); }
  // Forgets the kept SSRCs (a new stream start).
  void reset_streams() { streams_.clear(); }

  uint64_t accepted() const { return accepted_; }
  uint64_t dropped_address() const { return dropped_address_; }
  uint64_t dropped_ssrc() const { return dropped_ssrc_; }
  uint64_t dropped_not_rtp() const { return dropped_not_rtp_; }
  uint64_t dropped_payload_type() const { return dropped_payload_type_; }
  // The SSRC kept for payload type pt, if any.
  bool kept_ssrc(uint8_t pt, uint32_t* ssrc) const;

 private:
  struct Kept {
    uint32_t ssrc;
    int64_t last_ns;
  };
  std::vector<NetAddress> allowed_;
  bool lock_ssrc_;
  int64_t takeover_ns_;
  std::vector<uint8_t> payload_types_;
  std::map<uint8_t, uint32_t> fixed_;
  std::map<uint8_t, Kept> streams_;
  uint64_t accepted_ = 0, dropped_address_ = 0, dropped_ssrc_ = 0, dropped_not_rtp_ = 0, dropped_payload_type_ = 0;
};

}  // namespace vclassroom
