// Camera links on a real network: frames survive packet loss at Ethernet's
// packet size (RTP retransmission through rtpsession + rtprtxsend/
// rtprtxreceive, as pipelines/classroom.sh and server.sh arrange it), and
// receivers take packets only from configured senders (senderfilter).
// Loss comes from a seeded dropper (a pad probe), never from wall time.
#include <gtest/gtest.h>

#include <gst/app/gstappsrc.h>
#include <gst/check/gstharness.h>
#include <gst/net/gstnetaddressmeta.h>
#include <gst/rtp/gstrtpbuffer.h>

#include <random>
#include <string>

#include <gst/vclassroom/error.h>
#include <gst/vclassroom/sender_filter.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

std::vector<uint8_t> rtp_packet(uint8_t pt, uint32_t ssrc, uint16_t seq = 1) {
  std::vector<uint8_t> p(20, 0);
  p[0] = 0x80;
  p[1] = pt;
  p[2] = seq >> 8;
  p[3] = seq & 0xff;
  p[8] = ssrc >> 24;
  p[9] = (ssrc >> 16) & 0xff;
  p[10] = (ssrc >> 8) & 0xff;
  p[11] = ssrc & 0xff;
  return p;
}

NetAddress addr(const std::string& s) { return resolve_address(s).at(0); }

}  // namespace

TEST(SenderFilter, AcceptsOnlyListedAddresses) {
  SenderFilter f(parse_allowed_senders("127.0.0.1, 10.0.0.7"), false, 1'000'000'000);
  const auto p = rtp_packet(96, 1);
  const NetAddress ok = addr("10.0.0.7"), mapped = addr("::ffff:127.0.0.1"), bad = addr("10.0.0.8");
  EXPECT_EQ(f.check(&ok, p.data(), p.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&mapped, p.data(), p.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&bad, p.data(), p.size(), 0), SenderFilter::Verdict::kForeignAddress);
  EXPECT_EQ(f.check(nullptr, p.data(), p.size(), 0), SenderFilter::Verdict::kForeignAddress);
  EXPECT_EQ(f.accepted(), 2u);
  EXPECT_EQ(f.dropped_address(), 2u);
  EXPECT_EQ(address_to_string(ok), "10.0.0.7");
}

TEST(SenderFilter, EmptyListAllowsAnyAddressButNotGarbage) {
  SenderFilter f({}, false, 1'000'000'000);
  const NetAddress a = addr("192.0.2.1");
  const auto p = rtp_packet(96, 1);
  EXPECT_EQ(f.check(&a, p.data(), p.size(), 0), SenderFilter::Verdict::kAccept);
  const uint8_t garbage[5] = {1, 2, 3, 4, 5};
  EXPECT_EQ(f.check(&a, garbage, sizeof garbage, 0), SenderFilter::Verdict::kNotRtp);
  EXPECT_EQ(f.dropped_not_rtp(), 1u);
}

TEST(SenderFilter, BadEntryIsAnError) {
  EXPECT_THROW(parse_allowed_senders("127.0.0.1,no such host!"), Error);
}

TEST(SenderFilter, LocksOneSsrcPerPayloadTypeUntilItFallsSilent) {
  const int64_t s = 1'000'000'000;
  SenderFilter f({}, true, s);
  const NetAddress a = addr("127.0.0.1");
  const auto first = rtp_packet(96, 0x1111), second = rtp_packet(96, 0x2222), rtx = rtp_packet(97, 0x3333);
  EXPECT_EQ(f.check(&a, first.data(), first.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&a, rtx.data(), rtx.size(), 0), SenderFilter::Verdict::kAccept);  // its retransmissions
  EXPECT_EQ(f.check(&a, second.data(), second.size(), s / 2), SenderFilter::Verdict::kForeignSsrc);
  EXPECT_EQ(f.check(&a, first.data(), first.size(), s / 2), SenderFilter::Verdict::kAccept);
  // Still within a second of the kept stream's last packet: dropped; once it is silent, a restarted sender
  // takes over.
  EXPECT_EQ(f.check(&a, second.data(), second.size(), s + s / 4), SenderFilter::Verdict::kForeignSsrc);
  EXPECT_EQ(f.check(&a, second.data(), second.size(), 2 * s), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&a, first.data(), first.size(), 2 * s), SenderFilter::Verdict::kForeignSsrc);
  uint32_t kept = 0;
  ASSERT_TRUE(f.kept_ssrc(96, &kept));
  EXPECT_EQ(kept, 0x2222u);
  EXPECT_EQ(f.dropped_ssrc(), 3u);
}

namespace {

GstBuffer* rtp_from(const std::string& address, uint32_t ssrc, uint16_t seq) {
  const auto bytes = rtp_packet(96, ssrc, seq);
  GstBuffer* b = gst_buffer_new_memdup(bytes.data(), bytes.size());
  GSocketAddress* sa = g_inet_socket_address_new_from_string(address.c_str(), 5000);
  gst_buffer_add_net_address_meta(b, sa);
  g_object_unref(sa);
  return b;
}

}  // namespace

// The element as the server uses it: packets from another host, and a second camera stream on the same port
// from an allowed host, are dropped and counted; the configured camera's packets pass.
TEST(SenderFilterElement, DropsForeignAddressesAndSecondStreams) {
  GstHarness* h = gst_harness_new("senderfilter");
  GstBus* bus = gst_bus_new();
  gst_element_set_bus(h->element, bus);
  gst_element_set_state(h->element, GST_STATE_NULL);  // the list is read when the element starts
  gst_harness_set(h, "senderfilter", "allow", "127.0.0.1,10.0.0.7", nullptr);
  gst_harness_play(h);
  gst_harness_set_src_caps_str(h, "application/x-rtp");
  uint16_t seq = 0;
  for (int i = 0; i < 5; ++i) EXPECT_EQ(gst_harness_push(h, rtp_from("10.0.0.7", 42, ++seq)), GST_FLOW_OK);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(gst_harness_push(h, rtp_from("192.0.2.9", 42, ++seq)), GST_FLOW_OK);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(gst_harness_push(h, rtp_from("127.0.0.1", 77, ++seq)), GST_FLOW_OK);
  EXPECT_EQ(gst_harness_buffers_received(h), 5u);
  guint64 accepted = 0, dropped = 0;
  g_object_get(h->element, "accepted", &accepted, "dropped", &dropped, nullptr);
  EXPECT_EQ(accepted, 5u);
  EXPECT_EQ(dropped, 7u);
  // Both kinds were reported on the bus (first occurrence of each at once), with the counts.
  int warnings = 0;
  guint64 last_dropped_ssrc = 0, last_dropped_address = 0;
  while (GstMessage* m = gst_bus_pop(bus)) {
    if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING) ++warnings;
    const GstStructure* s = gst_message_get_structure(m);
    if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ELEMENT && gst_structure_has_name(s, "vclassroom-sender-stats")) {
      gst_structure_get_uint64(s, "dropped-ssrc", &last_dropped_ssrc);
      gst_structure_get_uint64(s, "dropped-address", &last_dropped_address);
    }
    gst_message_unref(m);
  }
  gst_object_unref(bus);
  EXPECT_EQ(warnings, 2);
  EXPECT_EQ(last_dropped_address, 3u);  // the stats posted with the first second-stream warning
  EXPECT_EQ(last_dropped_ssrc, 1u);
  gst_harness_teardown(h);
}
