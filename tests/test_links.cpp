// Camera links on a real network: frames survive packet loss at Ethernet's
// packet size (RTP retransmission through rtpsession + rtprtxsend/
// rtprtxreceive, as pipelines/classroom.sh and server.sh arrange it), and
// receivers take packets only from configured senders (senderfilter).
// Loss comes from a seeded dropper (a pad probe), never from wall time.
#include <gtest/gtest.h>

#include <filesystem>

#include <csignal>

#include <gst/app/gstappsrc.h>
#include <gst/check/gstharness.h>
#include <gst/net/gstnetaddressmeta.h>
#include <gst/rtp/gstrtpbuffer.h>

#include <random>
#include <thread>
#include <functional>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/net/sender_filter.h>
#include <gst/vclassroom/net/srtp_key.h>

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

// With retransmission the server demultiplexes a camera port by SSRC; a stray
// packet of another payload type would open a stream nothing handles and stop
// the server. Only the configured types pass, and none of another type is locked onto.
TEST(SenderFilter, OnlyConfiguredPayloadTypesPassAndNoneOtherIsLockedOnto) {
  SenderFilter f({}, true, 1'000'000'000);
  f.set_payload_types(parse_payload_types("96, 97"));
  const NetAddress a = addr("127.0.0.1");
  const auto video = rtp_packet(96, 0x1111), rtx = rtp_packet(97, 0x2222), stray = rtp_packet(111, 0x3333);
  EXPECT_EQ(f.check(&a, stray.data(), stray.size(), 0), SenderFilter::Verdict::kForeignPayloadType);
  EXPECT_EQ(f.check(&a, video.data(), video.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&a, rtx.data(), rtx.size(), 0), SenderFilter::Verdict::kAccept);
  uint32_t kept = 0;
  EXPECT_FALSE(f.kept_ssrc(111, &kept));
  EXPECT_EQ(f.dropped_payload_type(), 1u);
  EXPECT_EQ(parse_payload_types(""), std::vector<uint8_t>{});
  EXPECT_THROW(parse_payload_types("96,128"), Error);
  EXPECT_THROW(parse_payload_types("video"), Error);
}

// A camera's fixed SSRC (both ends know it) is the only stream of its payload type, from the first packet
// on: a stray packet that arrives first is not locked onto.
TEST(SenderFilter, AFixedSsrcIsTheOnlyStreamOfItsPayloadType) {
  SenderFilter f({}, true, 1'000'000'000);
  f.set_fixed_ssrcs(parse_fixed_ssrcs("96=0x56430001 97=1447264257"));
  const NetAddress a = addr("127.0.0.1");
  const auto stray = rtp_packet(96, 0x1234), camera = rtp_packet(96, 0x56430001), rtx = rtp_packet(97, 1447264257);
  EXPECT_EQ(f.check(&a, stray.data(), stray.size(), 0), SenderFilter::Verdict::kForeignSsrc);
  EXPECT_EQ(f.check(&a, camera.data(), camera.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&a, rtx.data(), rtx.size(), 0), SenderFilter::Verdict::kAccept);
  EXPECT_EQ(f.check(&a, stray.data(), stray.size(), 5'000'000'000), SenderFilter::Verdict::kForeignSsrc);
  for (const char* bad : {"96", "96=", "96=-1", "300=1", "96=0x1FFFFFFFF", "x=1"})
    EXPECT_THROW(parse_fixed_ssrcs(bad), Error) << bad;
}

namespace {

GstBuffer* rtp_from(const std::string& address, uint32_t ssrc, uint16_t seq, uint8_t pt = 96) {
  const auto bytes = rtp_packet(pt, ssrc, seq);
  GstBuffer* b = gst_buffer_new_memdup(bytes.data(), bytes.size());
  GSocketAddress* sa = g_inet_socket_address_new_from_string(address.c_str(), 5000);
  gst_buffer_add_net_address_meta(b, sa);
  g_object_unref(sa);
  return b;
}

}  // namespace

// The element as the server uses it: packets from another host, and a second camera stream on the same port
// from an allowed host, are dropped and counted; the configured camera's packets pass.
// Tears a harness down whose element posts on a bus of the test's: the bus
// is flushed first, as the messages of the teardown's own state changes
// would otherwise hold the element (and it the bus) for ever.
void teardown_with_bus(GstHarness* h, GstBus* bus) {
  gst_element_set_state(h->element, GST_STATE_NULL);
  gst_bus_set_flushing(bus, TRUE);
  gst_element_set_bus(h->element, nullptr);
  gst_object_unref(bus);
  gst_harness_teardown(h);
}

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
  EXPECT_EQ(warnings, 2);
  EXPECT_EQ(last_dropped_address, 3u);  // the stats posted with the first second-stream warning
  EXPECT_EQ(last_dropped_ssrc, 1u);
  teardown_with_bus(h, bus);
}

TEST(SenderFilterElement, DropsPayloadTypesThePortDoesNotCarry) {
  GstHarness* h = gst_harness_new("senderfilter");
  GstBus* bus = gst_bus_new();
  gst_element_set_bus(h->element, bus);
  gst_element_set_state(h->element, GST_STATE_NULL);
  gst_harness_set(h, "senderfilter", "payload-types", "96,97", nullptr);
  gst_harness_play(h);
  gst_harness_set_src_caps_str(h, "application/x-rtp");
  uint16_t seq = 0;
  for (uint8_t pt : {96, 97, 13, 111, 96}) EXPECT_EQ(gst_harness_push(h, rtp_from("127.0.0.1", 42 + pt, ++seq, pt)), GST_FLOW_OK);
  EXPECT_EQ(gst_harness_buffers_received(h), 3u);
  guint64 dropped = 0;
  g_object_get(h->element, "dropped", &dropped, nullptr);
  EXPECT_EQ(dropped, 2u);
  int warnings = 0;
  guint64 dropped_pt = 0;
  while (GstMessage* m = gst_bus_pop(bus)) {
    if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING) ++warnings;
    const GstStructure* s = gst_message_get_structure(m);
    if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ELEMENT && gst_structure_has_name(s, "vclassroom-sender-stats"))
      gst_structure_get_uint64(s, "dropped-payload-type", &dropped_pt);
    gst_message_unref(m);
  }
  EXPECT_EQ(warnings, 1);  // the first at once; the second within 5 s is counted
  EXPECT_EQ(dropped_pt, 1u);
  teardown_with_bus(h, bus);
  // A bad list stops the element at start, naming it.
  const auto r = vctest::run_launch("fakesrc num-buffers=1 ! senderfilter payload-types=96,300 ! fakesink");
  EXPECT_NE(r.error.find("payload-types=\"96,300\""), std::string::npos) << r.error;
}

namespace {

// Coded 960x540 camera frames (rgbdtestsrc ! rgbdenc), recorded once for all the loss tests.
struct CodedFrames {
  std::vector<GstBuffer*> frames;
  GstCaps* caps = nullptr;
};

CodedFrames record_coded_frames() {
  CodedFrames r;
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(
      "rgbdtestsrc camera-id=0 num-buffers=6 ground-truth=false ! rgbdenc ! appsink name=out sync=false", &err);
  EXPECT_NE(p, nullptr);
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  vctest::SampleCollector got(out);
  vctest::RunResult res = vctest::run_pipeline(p);
  EXPECT_EQ(res.error, "");
  for (size_t i = 0; i < got.size(); ++i) r.frames.push_back(gst_buffer_ref(got.buffer(i)));
  if (got.size() > 0) r.caps = gst_caps_ref(got.caps(0));
  gst_object_unref(out);
  gst_object_unref(p);
  return r;
}

// Made on first use and released when the tests end, before gst_deinit()
// (whose leaks tracer would otherwise count them).
CodedFrames* recorded_frames = nullptr;

class ReleaseCodedFrames : public ::testing::Environment {
 public:
  void TearDown() override {
    if (!recorded_frames) return;
    for (GstBuffer* b : recorded_frames->frames) gst_buffer_unref(b);
    if (recorded_frames->caps) gst_caps_unref(recorded_frames->caps);
    delete recorded_frames;
    recorded_frames = nullptr;
  }
};
const auto* const release_coded_frames = ::testing::AddGlobalTestEnvironment(new ReleaseCodedFrames);

const CodedFrames& coded_frames() {
  if (!recorded_frames) recorded_frames = new CodedFrames(record_coded_frames());
  return *recorded_frames;
}

struct LinkResult {
  size_t sent = 0, delivered = 0;
  std::string error;
  guint64 lost = 0;
  guint repaired = 0;  // retransmitted packets rtprtxreceive matched to a request
  std::string detail;
  GstStructure* decoder_stats = nullptr;  // rgbddec's last vclassroom-codec-stats message
  LinkResult() = default;
  LinkResult(const LinkResult&) = delete;
  LinkResult& operator=(const LinkResult&) = delete;
  LinkResult(LinkResult&& o) noexcept
      : sent(o.sent), delivered(o.delivered), error(std::move(o.error)), lost(o.lost), repaired(o.repaired),
        detail(std::move(o.detail)), decoder_stats(o.decoder_stats) {
    o.decoder_stats = nullptr;
  }
  ~LinkResult() {
    if (decoder_stats) gst_structure_free(decoder_stats);
  }
};

// Keeps the decoder's stats messages as they are posted (the bus is popped elsewhere).
GstBusSyncReply keep_decoder_stats(GstBus*, GstMessage* m, gpointer data) {
  const GstStructure* s = gst_message_get_structure(m);
  if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ELEMENT && gst_structure_has_name(s, "vclassroom-codec-stats")) {
    auto* r = static_cast<LinkResult*>(data);
    if (r->decoder_stats) gst_structure_free(r->decoder_stats);
    r->decoder_stats = gst_structure_copy(s);
  }
  return GST_BUS_PASS;
}

// Drops each packet that crosses the pad with probability `loss`, from a seeded generator.
struct Dropper {
  std::mt19937 rng;
  double loss;
  guint64 dropped = 0;
  bool lose() {
    if (std::uniform_real_distribution<double>(0, 1)(rng) >= loss) return false;
    ++dropped;
    return true;
  }
  // Payloaders push lists of packets: each packet in a list is lost or kept on its own.
  static GstPadProbeReturn probe(GstPad*, GstPadProbeInfo* info, gpointer self) {
    auto* d = static_cast<Dropper*>(self);
    if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) return d->lose() ? GST_PAD_PROBE_DROP : GST_PAD_PROBE_OK;
    if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER_LIST) {
      GstBufferList* list = gst_buffer_list_make_writable(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
      for (guint i = gst_buffer_list_length(list); i-- > 0;)
        if (d->lose()) gst_buffer_list_remove(list, i, 1);
      GST_PAD_PROBE_INFO_DATA(info) = list;
    }
    return GST_PAD_PROBE_OK;
  }
};

// Set when end-of-stream reaches the sender's udpsink: everything has been sent once.
struct SenderDone {
  GMutex lock;
  GCond cond;
  bool done = false;
  SenderDone() {
    g_mutex_init(&lock);
    g_cond_init(&cond);
  }
  ~SenderDone() {
    g_mutex_clear(&lock);
    g_cond_clear(&cond);
  }
  static GstPadProbeReturn probe(GstPad*, GstPadProbeInfo* info, gpointer self) {
    auto* d = static_cast<SenderDone*>(self);
    if (GST_EVENT_TYPE(GST_PAD_PROBE_INFO_EVENT(info)) == GST_EVENT_EOS) {
      g_mutex_lock(&d->lock);
      d->done = true;
      g_cond_broadcast(&d->cond);
      g_mutex_unlock(&d->lock);
    }
    return GST_PAD_PROBE_OK;
  }
  bool wait(gint64 limit_us) {
    const gint64 deadline = g_get_monotonic_time() + limit_us;
    g_mutex_lock(&lock);
    while (!done && g_cond_wait_until(&cond, &lock, deadline)) {
    }
    const bool ok = done;
    g_mutex_unlock(&lock);
    return ok;
  }
};

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t i = s.find(from); i != std::string::npos; i = s.find(from, i + to.size())) s.replace(i, from.size(), to);
  return s;
}

// Waits (bounded) until the appsink has seen end-of-stream or the pipeline posted an error; returns the error.
std::string wait_for_sink_eos(GstElement* pipeline, GstElement* appsink, GstClockTime limit) {
  GstBus* bus = gst_element_get_bus(pipeline);
  std::string error;
  const gint64 deadline = g_get_monotonic_time() + gint64(limit / 1000);
  while (!gst_app_sink_is_eos(GST_APP_SINK(appsink))) {
    if (g_get_monotonic_time() > deadline) {
      error = "timeout";
      ADD_FAILURE() << "the receiver neither finished nor failed within the time limit (a stall)";
      break;
    }
    if (GstMessage* m = gst_bus_timed_pop_filtered(bus, 50 * GST_MSECOND, GST_MESSAGE_ERROR)) {
      GError* err = nullptr;
      gst_message_parse_error(m, &err, nullptr);
      error = err ? err->message : "error";
      g_clear_error(&err);
      gst_message_unref(m);
      break;
    }
  }
  gst_object_unref(bus);
  return error;
}

// The rate the link tests replay their frames at: the cameras send 30 fps, but 30 fps of 960x540 RGB-D is about
// 100 Mbit/s through the payloader, two RTP sessions, the jitter buffer and the decoder, which a 2-core runner
// under the sanitizers cannot keep up with: the decoder falls behind, the jitter buffer's queue grows past
// its latency and drop-on-latency drops whole runs of packets, and what was tested was the machine's speed
// (CI under ASan: 78 of 120 frames at 30 fps; a loaded 2-core machine under ASan: 119 of 120 at 10 fps).
// What the full rate costs is tools/vclassroom-measure-link's.
constexpr int kLinkTestFps = 10;

// One camera link as the scripts run it, over UDP on loopback: the coded frames replayed at kLinkTestFps (by the
// clock) -> rtpgstpay mtu=1400 -> `sender` -> a seeded lossy udpsink -> udpsrc -> `receiver` -> rtpgstdepay
// -> rgbddec (which drops any damaged frame) -> appsink. In the fragments, {RTCP_TO_SENDER} and
// {RTCP_TO_RECEIVER} stand for the RTCP ports. When the sender has sent everything, the receiver is told
// end-of-stream and drains.
struct Scheme {
  std::string sender, sender_rtcp, receiver, receiver_rtcp;
  std::string media_type = "application/x-rtp";  // application/x-srtp for an encrypted link
};

LinkResult run_link(const Scheme& scheme, double loss, size_t frames, uint32_t seed) {
  const CodedFrames& coded = coded_frames();
  LinkResult r;
  if (coded.frames.empty()) return r;
  const int rtp_port = vctest::free_udp_port();
  const std::string to_sender = std::to_string(vctest::free_udp_port());
  const std::string to_receiver = std::to_string(vctest::free_udp_port());
  auto ports = [&](std::string s) {
    s = replace_all(s, "{RTCP_TO_SENDER}", to_sender);
    return replace_all(s, "{RTCP_TO_RECEIVER}", to_receiver);
  };
  const std::string tx_desc = ports(
      scheme.sender_rtcp + " appsrc name=src is-live=true format=time ! identity sync=true ! rtpgstpay config-interval=1 mtu=1400 pt=96 ! " +
      scheme.sender + " udpsink name=net host=127.0.0.1 port=" + std::to_string(rtp_port) + " sync=false");
  const std::string rx_desc = ports(
      scheme.receiver_rtcp + " udpsrc port=" + std::to_string(rtp_port) +
      " buffer-size=33554432 mtu=1500 caps=\"" + scheme.media_type +
      ",media=application,clock-rate=90000,encoding-name=X-GST,payload=96\" ! " +
      scheme.receiver + " rtpgstdepay ! rgbddec stats-interval=100000 ! appsink name=out sync=false");
  GError* err = nullptr;
  GstElement* tx = gst_parse_launch(tx_desc.c_str(), &err);
  EXPECT_TRUE(tx && !err) << tx_desc << ": " << (err ? err->message : "");
  g_clear_error(&err);
  GstElement* rx = gst_parse_launch(rx_desc.c_str(), &err);
  EXPECT_TRUE(rx && !err) << rx_desc << ": " << (err ? err->message : "");
  g_clear_error(&err);
  if (!tx || !rx) return r;
  GstElement* src = gst_bin_get_by_name(GST_BIN(tx), "src");
  GstElement* net = gst_bin_get_by_name(GST_BIN(tx), "net");
  GstElement* out = gst_bin_get_by_name(GST_BIN(rx), "out");
  GstBus* rx_bus = gst_element_get_bus(rx);
  gst_bus_set_sync_handler(rx_bus, keep_decoder_stats, &r, nullptr);
  gst_object_unref(rx_bus);
  Dropper dropper{std::mt19937(seed), loss};
  GstPad* net_sink = gst_element_get_static_pad(net, "sink");
  gst_pad_add_probe(net_sink, GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
                    &Dropper::probe, &dropper, nullptr);
  SenderDone done;
  gst_pad_add_probe(net_sink, GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM, &SenderDone::probe, &done, nullptr);
  gst_object_unref(net_sink);
  g_object_set(src, "caps", coded.caps, "max-bytes", guint64(0), nullptr);
  for (size_t i = 0; i < frames; ++i) {
    GstBuffer* b = gst_buffer_copy(coded.frames[i % coded.frames.size()]);
    GST_BUFFER_PTS(b) = i * GST_SECOND / kLinkTestFps;
    GST_BUFFER_DTS(b) = GST_CLOCK_TIME_NONE;
    GST_BUFFER_DURATION(b) = GST_SECOND / kLinkTestFps;
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  vctest::SampleCollector got(out);
  gst_element_set_state(rx, GST_STATE_PLAYING);
  // The sender's pipeline ends when the last packet has left; it keeps answering retransmission requests
  // until it is stopped below, after the receiver has drained.
  gst_element_set_state(tx, GST_STATE_PLAYING);
  if (!done.wait(120 * G_TIME_SPAN_SECOND)) {
    ADD_FAILURE() << "the sender did not send its last packet";
    r.error = "sender stalled";
  }
  gst_element_send_event(rx, gst_event_new_eos());  // to every source of the receiver
  const std::string rx_error = wait_for_sink_eos(rx, out, 120 * GST_SECOND);
  if (r.error.empty()) r.error = rx_error;
  // What the retransmission machinery did, printed for whoever reads a failure.
  if (GstElement* rtx_send = gst_bin_get_by_name(GST_BIN(tx), "rtxsend")) {
    guint requests = 0, packets = 0;
    g_object_get(rtx_send, "num-rtx-requests", &requests, "num-rtx-packets", &packets, nullptr);
    r.detail += "rtprtxsend: " + std::to_string(requests) + " requests, " + std::to_string(packets) + " resent; ";
    gst_object_unref(rtx_send);
  }
  if (GstElement* rtx_receive = gst_bin_get_by_name(GST_BIN(rx), "rtxreceive")) {
    guint requests = 0, packets = 0, assoc = 0;
    g_object_get(rtx_receive, "num-rtx-requests", &requests, "num-rtx-packets", &packets, "num-rtx-assoc-packets",
                 &assoc, nullptr);
    r.repaired = assoc;
    r.detail += "rtprtxreceive: " + std::to_string(requests) + " requests, " + std::to_string(packets) +
                " received, " + std::to_string(assoc) + " associated; ";
    gst_object_unref(rtx_receive);
  }
  for (auto [bin, name] : {std::pair{tx, "tx"}, std::pair{rx, "rx"}})
    if (GstElement* session = gst_bin_get_by_name(GST_BIN(bin), name)) {
      GstStructure* st = nullptr;
      g_object_get(session, "stats", &st, nullptr);
      guint sent = 0, recv = 0;
      if (st) {
        gst_structure_get_uint(st, "sent-nack-count", &sent);
        gst_structure_get_uint(st, "recv-nack-count", &recv);
        gst_structure_free(st);
      }
      r.detail += std::string(name) + " session: " + std::to_string(sent) + " NACKs sent, " + std::to_string(recv) +
                  " received; ";
      gst_object_unref(session);
    }
  if (GstElement* jb = gst_bin_get_by_name(GST_BIN(rx), "jitter")) {
    GstStructure* st = nullptr;
    g_object_get(jb, "stats", &st, nullptr);
    if (st) {
      gchar* text = gst_structure_to_string(st);
      r.detail += text;
      g_free(text);
      gst_structure_free(st);
    }
    gst_object_unref(jb);
  }
  gst_element_set_state(rx, GST_STATE_NULL);
  gst_element_set_state(tx, GST_STATE_NULL);
  r.sent = frames;
  r.delivered = got.size();
  r.lost = dropper.dropped;
  gst_object_unref(src);
  gst_object_unref(net);
  gst_object_unref(out);
  gst_object_unref(tx);
  gst_object_unref(rx);
  return r;
}

// The scheme of pipelines/classroom.sh and server.sh (the same elements and settings; keep them alike),
// except the time a packet may wait for its repair: 3 s here instead of the scripts' 300 ms (RTX_LATENCY),
// so that the result does not depend on the machine's speed (other tests run beside this one); how much
// latency the repairs cost is measured by tools/vclassroom-measure-link, not asserted here.
// NACK-driven retransmission (RFC 4588) through
// rtpsession (AVPF: feedback at once) with rtprtxsend/rtprtxreceive.
const Scheme kRetransmission = {

    "rtprtxsend name=rtxsend payload-type-map=application/x-rtp-pt-map,96=(uint)97 max-size-time=3000 max-size-packets=0 ! "
    "tx.send_rtp_sink tx.send_rtp_src !",
    "rtpsession name=tx rtp-profile=avpf udpsrc port={RTCP_TO_SENDER} caps=application/x-rtcp ! "
    "senderfilter lock-ssrc=false allow=127.0.0.1 ! tx.recv_rtcp_sink",
    "senderfilter allow=127.0.0.1 ! rx.recv_rtp_sink rx.recv_rtp_src ! "
    "rtprtxreceive name=rtxreceive payload-type-map=application/x-rtp-pt-map,96=(uint)97 ! rtpssrcdemux ! "
    "rtpjitterbuffer name=jitter latency=3000 do-retransmission=true rtx-min-retry-timeout=40 drop-on-latency=true !",
    "rtpsession name=rx probation=0 rtp-profile=avpf rtcp-min-interval=10000000 bandwidth=20000000 "
    "rx.send_rtcp_src ! udpsink host=127.0.0.1 port={RTCP_TO_SENDER} sync=false async=false"};
// Before: plain rtpgstpay, a jitter buffer and nothing else.
// (Its jitter buffer waits as long as the retransmission scheme's: only the missing repairs differ.)
const Scheme kPlain = {"", "", "rtpjitterbuffer name=jitter latency=3000 !", ""};

}  // namespace

TEST(CameraLink, RecordedFramesAre960x540) {
  const CodedFrames& coded = coded_frames();
  ASSERT_FALSE(coded.frames.empty());
  const GstStructure* s = gst_caps_get_structure(coded.caps, 0);
  int w = 0, h = 0;
  ASSERT_TRUE(gst_structure_get_int(s, "width", &w) && gst_structure_get_int(s, "height", &h));
  EXPECT_EQ(w, 960);
  EXPECT_EQ(h, 540);
  // About 400 packets of 1400 bytes each: one lost packet used to cost the frame.
  EXPECT_GT(gst_buffer_get_size(coded.frames[0]), 300u * 1400u);
}

// A camera frame is about 400 packets at MTU 1400: before, one lost packet of 400 cost the frame (at 5 % loss
// none arrived). rtpgstdepay can only start at the stream's first in-band caps (rtpgstpay config-interval=1),
// so a lost first caps packet may cost up to the first second: the bound below holds even then.
TEST(CameraLink, FramesSurviveFivePercentLossAtMtu1400) {
  const size_t frames = 60, first_second = kLinkTestFps;
  LinkResult r = run_link(kRetransmission, 0.05, frames, 17);
  EXPECT_EQ(r.error, "");
  EXPECT_GT(r.lost, 0u);
  EXPECT_GE(r.delivered, (frames - first_second) * 9 / 10) << r.lost << " packets lost; " << r.detail;
  std::printf("5 %% loss: %zu of %zu frames delivered with retransmission (%s)\n", r.delivered, frames,
              r.detail.c_str());
}

// Before: plain rtpgstpay and a jitter buffer lose every frame at 5 % loss (kept as the reason for the above).
TEST(CameraLink, PlainLinkLosesFramesAtFivePercentLoss) {
  const size_t frames = 30;
  LinkResult plain = run_link(kPlain, 0.05, frames, 17);
  EXPECT_EQ(plain.error, "");
  EXPECT_LT(plain.delivered, frames / 10);
}

// At 30 % loss retransmission cannot repair everything; the link must go on repairing and end cleanly,
// without a stall or an error. How many frames come out whole depends on how fast the repairs come back
// (most of them at full speed, none under the sanitizers), so that count is printed, not asserted; what a
// camera that delivers nothing means for the view is viewfuse's (test_cameras: a lost camera is reported
// and the picture goes on).
TEST(CameraLink, ThirtyPercentLossKeepsRepairingWithoutError) {
  const size_t frames = 45;
  LinkResult r = run_link(kRetransmission, 0.30, frames, 5);
  EXPECT_EQ(r.error, "");
  EXPECT_GT(r.repaired, 0u) << r.detail;
  // The loss and the repairs are in the decoder's stats message, where a deployment reads them
  // (gst-launch-1.0 -m, server.sh STATS=N).
  ASSERT_NE(r.decoder_stats, nullptr);
  guint64 lost = 0, repaired = 0, requested = 0;
  EXPECT_TRUE(gst_structure_get_uint64(r.decoder_stats, "packets-repaired", &repaired));
  EXPECT_TRUE(gst_structure_get_uint64(r.decoder_stats, "retransmissions-requested", &requested));
  EXPECT_TRUE(gst_structure_get_uint64(r.decoder_stats, "packets-lost", &lost));
  EXPECT_GT(repaired, 0u);
  EXPECT_GE(requested, repaired);
  std::printf("30 %% loss: %zu of %zu frames delivered (%s)\n", r.delivered, frames, r.detail.c_str());
}

TEST(CameraLink, NoLossDeliversEveryFrameAfterTheFirstCaps) {
  const size_t frames = 30, first_second = kLinkTestFps;
  LinkResult r = run_link(kRetransmission, 0.0, frames, 1);
  EXPECT_EQ(r.error, "");
  // The receiver is told end-of-stream as soon as the sender's last packet left: the frame in flight then
  // may be cut.
  EXPECT_GE(r.delivered, frames - first_second - 1) << r.detail;
}

namespace {

struct ScriptRun {
  bool ended = false;
  int status = -1;
  std::string output;
};

// Runs bash SCRIPT from pipelines/ with extra environment, waiting at most `limit` for it to end (a
// bounded wait on the child, not a sleep); a script still running then is killed and reported as not ended.
// An entry "NAME" without "=" removes NAME from the environment; `path` (optional) is the script's path
// instead of the source tree's, run from the folder `cwd` (optional).
ScriptRun run_script(const std::string& script, const std::vector<std::string>& env, guint limit_s,
                     const std::string& path_instead = "", const std::string& cwd = "") {
  ScriptRun r;
  const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
  const std::string path =
      path_instead.empty() ? std::string(source_dir ? source_dir : ".") + "/pipelines/" + script : path_instead;
  GSubprocessLauncher* launcher =
      g_subprocess_launcher_new(GSubprocessFlags(G_SUBPROCESS_FLAGS_STDOUT_PIPE | G_SUBPROCESS_FLAGS_STDERR_MERGE));
  if (!cwd.empty()) g_subprocess_launcher_set_cwd(launcher, cwd.c_str());
  for (const std::string& e : env) {
    const size_t eq = e.find('=');
    if (eq == std::string::npos)
      g_subprocess_launcher_unsetenv(launcher, e.c_str());
    else
      g_subprocess_launcher_setenv(launcher, e.substr(0, eq).c_str(), e.substr(eq + 1).c_str(), TRUE);
  }
  GError* err = nullptr;
  GSubprocess* child = g_subprocess_launcher_spawn(launcher, &err, "bash", path.c_str(), nullptr);
  g_object_unref(launcher);
  if (!child) {
    ADD_FAILURE() << "cannot start " << path << ": " << (err ? err->message : "");
    g_clear_error(&err);
    return r;
  }
  GMainContext* context = g_main_context_new();
  g_main_context_push_thread_default(context);
  GMainLoop* loop = g_main_loop_new(context, FALSE);
  struct Wait {
    GMainLoop* loop;
    std::string output;
  } wait{loop, ""};
  g_subprocess_communicate_utf8_async(
      child, nullptr, nullptr,
      [](GObject* source, GAsyncResult* res, gpointer data) {
        auto* w = static_cast<Wait*>(data);
        gchar* out = nullptr;
        if (g_subprocess_communicate_utf8_finish(G_SUBPROCESS(source), res, &out, nullptr, nullptr) && out)
          w->output = out;
        g_free(out);
        g_main_loop_quit(w->loop);
      },
      &wait);
  GSource* timeout = g_timeout_source_new_seconds(limit_s);
  g_source_set_callback(
      timeout, [](gpointer l) -> gboolean {
        g_main_loop_quit(static_cast<GMainLoop*>(l));
        return G_SOURCE_REMOVE;
      },
      loop, nullptr);
  g_source_attach(timeout, context);
  g_main_loop_run(loop);
  g_source_destroy(timeout);
  g_source_unref(timeout);
  r.ended = g_subprocess_get_if_exited(child);
  if (r.ended) {
    r.status = g_subprocess_get_exit_status(child);
  } else {
    g_subprocess_force_exit(child);
    g_subprocess_wait(child, nullptr, nullptr);
    // Let the cancelled read finish before the loop goes.
    while (g_main_context_iteration(context, FALSE)) {
    }
  }
  r.output = wait.output;
  g_main_loop_unref(loop);
  g_main_context_pop_thread_default(context);
  g_main_context_unref(context);
  g_object_unref(child);
  return r;
}

std::string port_base() { return std::to_string(10000 + vctest::free_udp_port() % 50000); }

}  // namespace

// A camera whose source ends (end-of-stream) ends classroom.sh, retransmission session and all.
TEST(Scripts, ClassroomEndsAtEndOfStream) {
  ScriptRun r = run_script("classroom.sh",
                           {"RTX=1", "SOURCE=rgbdtestsrc num-buffers=3 ground-truth=false",
                            "PORT=" + std::to_string(vctest::free_udp_port()),
                            "NACK_PORT=" + std::to_string(vctest::free_udp_port())},
                           120);
  EXPECT_TRUE(r.ended) << r.output;
  EXPECT_EQ(r.status, 0) << r.output;
}

// Without meson devenv and without the plugins on GStreamer's path, the scripts take them from the build
// folder themselves, also started from there (build/pipelines/ runs the source tree's scripts, which is
// where `meson devenv -C build` puts the shell); with no build folder at all they stop and say what to do.
TEST(Scripts, FindThePluginsThemselvesFromTheSourceRootOrTheBuildFolder) {
  const char* tools = g_getenv("VCLASSROOM_TOOLS_DIR");
  const char* source = g_getenv("VCLASSROOM_SOURCE_DIR");
  if (!tools || !source) GTEST_SKIP() << "VCLASSROOM_TOOLS_DIR or VCLASSROOM_SOURCE_DIR not set (run through meson test)";
  const std::string build = std::filesystem::path(tools).parent_path();
  const std::vector<std::string> bare = {"GST_PLUGIN_PATH", "GST_REGISTRY", "VCLASSROOM_WEB_ROOT",
                                         "SOURCE=rgbdtestsrc num-buffers=3 ground-truth=false",
                                         "PORT=" + std::to_string(vctest::free_udp_port()),
                                         "NACK_PORT=" + std::to_string(vctest::free_udp_port())};
  std::vector<std::string> env = bare;
  env.push_back("VCLASSROOM_BUILD_DIR=" + build);  // as meson devenv sets it
  ScriptRun r = run_script("classroom.sh", env, 120, "pipelines/classroom.sh", build);
  EXPECT_TRUE(r.ended && r.status == 0) << "from the build folder: " << r.output;
  if (std::filesystem::path(build).parent_path() == std::filesystem::path(source)) {
    env = bare;  // the source tree's build/, found without any variable
    env.push_back("VCLASSROOM_BUILD_DIR");
    r = run_script("classroom.sh", env, 120, "", source);
    EXPECT_TRUE(r.ended && r.status == 0) << "from the source root: " << r.output;
  }
  // The scripts without any build beside them, and no plugins installed (none on GStreamer's system path).
  vctest::TempDir dir;
  std::filesystem::create_directories(dir / "pipelines");
  for (const char* part : {"classroom.sh", "trees.sh", "srtp.sh", "launch.sh"})
    std::filesystem::copy_file(std::filesystem::path(source) / "pipelines" / part, dir / ("pipelines/" + std::string(part)));
  std::filesystem::create_directories(dir / "no-plugins");
  env = bare;
  env.insert(env.end(), {"VCLASSROOM_BUILD_DIR", "GST_PLUGIN_SYSTEM_PATH=" + (dir / "no-plugins")});
  r = run_script("classroom.sh", env, 60, dir / "pipelines/classroom.sh");
  EXPECT_TRUE(r.ended) << r.output;
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no element viewfuse"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("scripts/setup.sh"), std::string::npos) << r.output;
}

// RECORD=folder: a camera records what it sends, as a live recording of its coded frames.
TEST(Scripts, ClassroomRecordsWhatItSends) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  const std::string rec = dir / "session";
  ScriptRun r = run_script("classroom.sh",
                           {"SOURCE=rgbdtestsrc rig=" + rig + " num-buffers=5 ground-truth=false", "RECORD=" + rec,
                            "PORT=" + std::to_string(vctest::free_udp_port()),
                            "NACK_PORT=" + std::to_string(vctest::free_udp_port())},
                           120);
  EXPECT_TRUE(r.ended) << r.output;
  EXPECT_EQ(r.status, 0) << r.output;
  const Dataset recorded = Dataset::open(rec);
  EXPECT_TRUE(recorded.is_recording(0));
  EXPECT_EQ(recorded.frame_count(0), 5u);
}

// loopback.sh with a server that cannot start returns (with the server's status) instead of waiting forever
// for the lecturer and the cameras.
TEST(Scripts, LoopbackReturnsWhenTheServerFailsToStart) {
  ScriptRun r = run_script("loopback.sh",
                           {"PREP_NICE=99", "CAMERAS=0", "SINK=fakesink", "PORT_BASE=" + port_base(),
                            "STOP_GRACE=3"},
                           120);
  EXPECT_TRUE(r.ended) << r.output;
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("PREP_NICE"), std::string::npos) << r.output;
}

// Ports are checked before anything starts.
TEST(Scripts, BadPortsAreRefused) {
  ScriptRun r = run_script("server.sh", {"POSE_PORT=70000"}, 60);
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.status, 2) << r.output;
  r = run_script("classroom.sh", {"NACK_PORT=x"}, 60);
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.status, 2) << r.output;
}

// A background memory length that is not a number of frames is refused before anything starts.
TEST(Scripts, ABadMemoryLengthIsRefused) {
  ScriptRun r = run_script("server.sh", {"MEMORY=x"}, 60);
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("MEMORY"), std::string::npos) << r.output;
  r = run_script("all-in-one.sh", {"MEMORY=65"}, 60);
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("MEMORY"), std::string::npos) << r.output;
}

// The background memory is on by default (MEMORY=8) and reaches the server's viewwarps, which start from
// the model's empty room: a model without that picture is an error naming it, before any camera sends.
TEST(Scripts, ServerMemoryStartsFromTheModelsEmptyRoom) {
  vctest::TempDir dir;
  const char* tools = g_getenv("VCLASSROOM_TOOLS_DIR");
  const vctest::Exit built = vctest::run_tool({std::string(tools ? tools : ".") + "/vclassroom-build-model",
                                               "--synthetic", "--frames", "1", "--size", "160x90", "--out",
                                               dir / "model"});
  ASSERT_EQ(built.status, 0) << built.err;
  ASSERT_TRUE(std::filesystem::remove(dir / "model/prior-color/cam0.png"));
  const std::string base = port_base();
  ScriptRun r = run_script("server.sh",
                           {"CAMERAS=0", "MODEL=" + dir / "model", "BASE_PORT=" + base,
                            "VIDEO_PORT=" + std::to_string(std::stoi(base) + 10),
                            "POSE_PORT=" + std::to_string(std::stoi(base) + 11), "STOP_GRACE=2"},
                           120);
  EXPECT_TRUE(r.ended) << r.output;
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("prior-color/cam0.png"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("empty-room"), std::string::npos) << r.output;
}

// What a person reads: the element, what was dropped, from where, and what is allowed.
TEST(SenderFilterElement, WarningSaysWhatWhereAndWhatIsAllowed) {
  GstHarness* h = gst_harness_new("senderfilter");
  GstBus* bus = gst_bus_new();
  gst_element_set_bus(h->element, bus);
  gst_element_set_state(h->element, GST_STATE_NULL);
  gst_harness_set(h, "senderfilter", "allow", "10.0.0.7", nullptr);
  gst_harness_play(h);
  gst_harness_set_src_caps_str(h, "application/x-rtp");
  EXPECT_EQ(gst_harness_push(h, rtp_from("10.0.0.9", 1, 1)), GST_FLOW_OK);
  EXPECT_EQ(gst_harness_buffers_received(h), 0u);
  std::string text;
  while (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING)) {
    GError* err = nullptr;
    gst_message_parse_warning(m, &err, nullptr);
    text = err ? err->message : "";
    g_clear_error(&err);
    gst_message_unref(m);
  }
  EXPECT_NE(text.find("a packet dropped from a sender not allowed"), std::string::npos) << text;
  EXPECT_NE(text.find("10.0.0.9"), std::string::npos) << text;
  EXPECT_NE(text.find("allowed: 10.0.0.7"), std::string::npos) << text;
  teardown_with_bus(h, bus);
}

namespace {

// A key file as the docs make one (30 bytes), and the hex that srtpenc takes.
std::string write_key(const vctest::TempDir& dir, const std::string& name, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string bytes;
  for (size_t i = 0; i < vclassroom::kSrtpKeyBytes; ++i) bytes += char(rng() & 0xff);
  vctest::write_text(dir / name, bytes);
  return dir / name;
}

std::string key_hex(const std::string& path) { return vclassroom::to_hex(vclassroom::read_srtp_key(path)); }

Scheme encrypted(Scheme s, const std::string& sender_key_hex, const std::string& receiver_key_file) {
  s.sender += " srtpenc key=" + sender_key_hex + " !";
  s.receiver = "srtpfiledec key-file=" + receiver_key_file + " ! " + s.receiver;
  s.media_type = "application/x-srtp";
  return s;
}

bool have_srtp() {
  GstElementFactory* f = gst_element_factory_find("srtpenc");
  if (f) gst_object_unref(f);
  return f != nullptr;
}

}  // namespace

TEST(SrtpKey, ReadsExactlyThirtyBytes) {
  vctest::TempDir dir;
  const std::string good = write_key(dir, "good.key", 1);
  EXPECT_EQ(vclassroom::read_srtp_key(good).size(), 30u);
  EXPECT_EQ(key_hex(good).size(), 60u);
  vctest::write_text(dir / "short.key", "0123456789");
  EXPECT_THROW(vclassroom::read_srtp_key(dir / "short.key"), vclassroom::Error);
  vctest::write_text(dir / "long.key", std::string(31, 'x'));
  EXPECT_THROW(vclassroom::read_srtp_key(dir / "long.key"), vclassroom::Error);
  EXPECT_THROW(vclassroom::read_srtp_key(dir / "missing.key"), vclassroom::Error);
}

// An SRTP camera link (retransmission included: the resent packets are another SSRC, which srtpfiledec
// keys too) carries the frames; packets encrypted with another key are all dropped.
TEST(SrtpLink, CarriesFramesWithTheKeyAndNoneWithAnother) {
  if (!have_srtp()) GTEST_SKIP() << "srtpenc/srtpdec (gstreamer1.0-plugins-bad) are not installed";
  vctest::TempDir dir;
  const std::string key = write_key(dir, "srtp.key", 7), other = write_key(dir, "other.key", 8);
  const size_t frames = 45, first_second = kLinkTestFps;
  LinkResult r = run_link(encrypted(kRetransmission, key_hex(key), key), 0.05, frames, 17);
  EXPECT_EQ(r.error, "");
  // Retransmitted packets (their own SSRC) were decrypted and repaired frames, and frames arrived.
  EXPECT_GT(r.repaired, 0u) << r.detail;
  EXPECT_GT(r.delivered, 0u) << r.detail;
  LinkResult wrong = run_link(encrypted(kPlain, key_hex(other), key), 0.0, 30, 1);
  EXPECT_EQ(wrong.error, "");
  EXPECT_EQ(wrong.delivered, 0u);
  LinkResult right = run_link(encrypted(kPlain, key_hex(key), key), 0.0, 30, 1);
  EXPECT_GE(right.delivered, 30u - first_second - 1);
  std::printf("SRTP: %zu of %zu frames at 5 %% loss with retransmission; another key %zu, same key %zu of 30\n",
              r.delivered, frames, wrong.delivered, right.delivered);
}

// classroom.sh with SRTP_KEY sends what srtpfiledec with the same key file decrypts into whole frames (the H.264
// camera link: colour and depth of each frame, docs/network.md).
TEST(SrtpLink, ClassroomScriptEncryptsItsFrames) {
  if (!have_srtp()) GTEST_SKIP() << "srtpenc/srtpdec (gstreamer1.0-plugins-bad) are not installed";
  vctest::TempDir dir;
  const std::string key = write_key(dir, "srtp.key", 11);
  const int port = vctest::free_udp_port();
  const std::string desc = "udpsrc port=" + std::to_string(port) +
                           " buffer-size=33554432 mtu=1500 caps=\"application/x-srtp,media=video,"
                           "clock-rate=90000,encoding-name=H264,payload=96\" ! senderfilter allow=127.0.0.1 ! "
                           "srtpfiledec key-file=" + key +
                           " ! rtpjitterbuffer latency=1500 ! rtph264depay ! rgbdlinkdemux ! openh264dec ! videoconvert ! "
                           "rgbdlinkjoin ! appsink name=out sync=false";
  GError* err = nullptr;
  GstElement* rx = gst_parse_launch(desc.c_str(), &err);
  ASSERT_TRUE(rx && !err) << (err ? err->message : "");
  GstElement* out = gst_bin_get_by_name(GST_BIN(rx), "out");
  vctest::SampleCollector got(out);
  gst_element_set_state(rx, GST_STATE_PLAYING);
  const size_t frames = 45;
  ScriptRun r = run_script("classroom.sh",
                           {"SOURCE=rgbdtestsrc num-buffers=" + std::to_string(frames) + " ground-truth=false",
                            "PORT=" + std::to_string(port), "NACK_PORT=" + std::to_string(vctest::free_udp_port()),
                            "SRTP_KEY=" + key, "LINK=h264"},
                           600);  // a hang guard: 45 frames rendered at 960x540 take minutes under the sanitizers
  EXPECT_TRUE(r.ended && r.status == 0) << r.output;
  gst_element_send_event(rx, gst_event_new_eos());
  EXPECT_EQ(wait_for_sink_eos(rx, out, 60 * GST_SECOND), "");
  gst_element_set_state(rx, GST_STATE_NULL);
  EXPECT_GE(got.size(), frames - 31) << "whole frames decrypted and decoded";
  gst_object_unref(out);
  gst_object_unref(rx);
  // A key file of the wrong size is refused before anything starts.
  vctest::write_text(dir / "bad.key", "too short");
  r = run_script("classroom.sh", {"SRTP_KEY=" + (dir / "bad.key")}, 60);
  EXPECT_EQ(r.status, 2) << r.output;
}

// server.sh asked to stop (SIGTERM, as loopback.sh does; Ctrl-C alike) while a camera port never received a
// packet: rtpssrcdemux holds that camera's end-of-stream back for ever, so the script must still end, within
// STOP_GRACE (pipelines/launch.sh). Waits on the script's own output for the pipeline to play, then on its exit
// (bounded: a script still running after the limit is killed and the test fails).
namespace {

struct StoppedScript {
  bool playing = false;  // it said "Setting pipeline to PLAYING" before the signal
  bool exited = false;   // it ended by itself, not by the watchdog's kill
  std::string output;
};

// Starts pipelines/SCRIPT with `env`, waits (on its output, no sleep) until its
// pipeline plays, runs `while_playing` (if any), sends `signal` (SIGINT as Ctrl-C,
// SIGTERM) and reads its output to the end. A watchdog kills it after 120 s, so
// nothing blocks for ever.
StoppedScript stop_when_playing(const std::string& script, const std::vector<std::pair<std::string, std::string>>& env,
                                int signal, const std::function<void()>& while_playing = nullptr) {
  StoppedScript r;
  const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
  const std::string path = std::string(source_dir ? source_dir : ".") + "/pipelines/" + script;
  GSubprocessLauncher* launcher =
      g_subprocess_launcher_new(GSubprocessFlags(G_SUBPROCESS_FLAGS_STDOUT_PIPE | G_SUBPROCESS_FLAGS_STDERR_MERGE));
  for (const auto& [k, v] : env) g_subprocess_launcher_setenv(launcher, k.c_str(), v.c_str(), TRUE);
  GError* err = nullptr;
  GSubprocess* child = g_subprocess_launcher_spawn(launcher, &err, "bash", path.c_str(), nullptr);
  g_object_unref(launcher);
  EXPECT_NE(child, nullptr) << (err ? err->message : "");
  g_clear_error(&err);
  if (!child) return r;
  struct Watchdog {
    GSubprocess* child;
    GMutex lock;
    GCond cond;
    bool done = false;
  } dog{child, {}, {}, false};
  g_mutex_init(&dog.lock);
  g_cond_init(&dog.cond);
  GThread* watchdog = g_thread_new(
      "watchdog",
      [](gpointer data) -> gpointer {
        auto* d = static_cast<Watchdog*>(data);
        const gint64 until = g_get_monotonic_time() + 120 * G_TIME_SPAN_SECOND;
        g_mutex_lock(&d->lock);
        while (!d->done)
          if (!g_cond_wait_until(&d->cond, &d->lock, until)) {
            g_subprocess_force_exit(d->child);
            break;
          }
        g_mutex_unlock(&d->lock);
        return nullptr;
      },
      &dog);
  GDataInputStream* out = g_data_input_stream_new(g_subprocess_get_stdout_pipe(child));
  while (gchar* line = g_data_input_stream_read_line(out, nullptr, nullptr, nullptr)) {
    r.output += std::string(line) + "\n";
    g_free(line);
    if (r.output.find("Setting pipeline to PLAYING") != std::string::npos) {
      r.playing = true;
      break;
    }
  }
  if (r.playing && while_playing) while_playing();
  g_subprocess_send_signal(child, signal);
  while (gchar* line = g_data_input_stream_read_line(out, nullptr, nullptr, nullptr)) {  // to its end
    r.output += std::string(line) + "\n";
    g_free(line);
  }
  g_subprocess_wait(child, nullptr, nullptr);
  g_mutex_lock(&dog.lock);
  dog.done = true;
  g_cond_signal(&dog.cond);
  g_mutex_unlock(&dog.lock);
  g_thread_join(watchdog);
  g_mutex_clear(&dog.lock);
  g_cond_clear(&dog.cond);
  // Its output reached its end only once every writer had gone: no gst-launch-1.0 left behind.
  r.exited = g_subprocess_get_if_exited(child);
  g_object_unref(out);
  g_object_unref(child);
  return r;
}

}  // namespace

TEST(Scripts, ServerEndsWhenStoppedWhileACameraNeverSent) {
  const std::string base = port_base();
  const StoppedScript r = stop_when_playing(
      "server.sh",
      {{"CAMERAS", "0"}, {"BASE_PORT", base}, {"VIDEO_PORT", std::to_string(std::stoi(base) + 10)},
       {"POSE_PORT", std::to_string(std::stoi(base) + 11)}, {"WIDTH", "256"}, {"HEIGHT", "144"},
       {"STOP_GRACE", "2"}, {"RTX", "1"}},
      SIGTERM);
  EXPECT_TRUE(r.playing) << r.output;
  EXPECT_TRUE(r.exited) << r.output;  // by its run_launch, not by the watchdog
  EXPECT_NE(r.output.find("Interrupt: Stopping pipeline"), std::string::npos) << r.output;
}

// The lecturer's first Ctrl-C ends lecturer.sh even when no video ever came (posesend ends its pose stream
// whether or not it sent a pose): end-of-stream reaches every sink and gst-launch-1.0 exits.
TEST(Scripts, LecturerEndsAtTheFirstCtrlCWhenNoVideoEverCame) {
  const StoppedScript r = stop_when_playing(
      "lecturer.sh",
      {{"VIDEO_PORT", std::to_string(vctest::free_udp_port())}, {"POSE_PORT", std::to_string(vctest::free_udp_port())},
       {"SINK", "fakesink"}},
      SIGINT);
  EXPECT_TRUE(r.playing) << r.output;
  EXPECT_TRUE(r.exited) << r.output;
  EXPECT_NE(r.output.find("Got EOS from element"), std::string::npos) << r.output;
}

// server.sh with LECTURER_OUT=whep-views (a view per lecturer, whepviewsink) plays with its cameras linked
// and the classroom's sound and loudspeaker (through the echo canceller), serves the lecturer page to the
// token and 401 to anyone else, prints the URL to join, and ends at Ctrl-C.
TEST(Scripts, ServerServesAViewPerLecturerOverWhep) {
  if (!gst_element_factory_find("whepviewsink")) GTEST_SKIP() << "the webrtc plugin is not built (no webrtcbin)";
  const guint16 http = static_cast<guint16>(vctest::free_tcp_port());
  std::string page, refused;
  const StoppedScript r = stop_when_playing(
      "server.sh",
      {{"LECTURER_OUT", "whep-views"}, {"TOKEN", "a-long-secret"}, {"WHEP_PORT", std::to_string(http)},
       {"CAMERAS", "0 1"}, {"BASE_PORT", std::to_string(vctest::free_udp_port())},
       {"POSE_PORT", std::to_string(vctest::free_udp_port())}, {"STOP_GRACE", "2"},
       // The classroom's sound and loudspeaker, through the echo canceller.
       {"CLASSROOM_SOUND", "audiotestsrc is-live=true"}, {"CLASSROOM_SPEAKER", "fakesink"}},
      SIGINT, [&] {
        page = vctest::first_response_line(http, false, "GET /?token=a-long-secret HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n");
        refused = vctest::first_response_line(http, false, "GET /?token=wrong HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n");
      });
  EXPECT_TRUE(r.playing) << r.output;
  EXPECT_TRUE(r.exited) << r.output;
  EXPECT_EQ(page.substr(0, 12), "HTTP/1.0 200") << page << "\n" << r.output;
  EXPECT_EQ(refused.substr(0, 12), "HTTP/1.0 401") << refused;
  EXPECT_NE(r.output.find("lecturer joins at http://"), std::string::npos) << r.output;
}

// The classroom's sound on the RTP path: server.sh sends CLASSROOM_SOUND as Opus beside the view, and
// lecturer.sh plays it where SPEAKER says (here into a file, read back: a second and more of a tone).
TEST(Scripts, TheLecturerHearsTheClassroomOverRtp) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  const std::string sound = dir / "sound.raw";
  ScriptRun r = run_script("loopback.sh",
                           {"PORT_BASE=" + port_base(), "CAMERAS=0", "RIG=" + rig, "WIDTH=64", "HEIGHT=48",
                            "SECONDS_TO_RUN=8", "STOP_GRACE=3",
                            "SOURCE=rgbdtestsrc camera-id=0 rig=" + rig + " is-live=true ground-truth=false",
                            "SINK=fakesink", "CLASSROOM_SOUND=audiotestsrc is-live=true volume=0.5",
                            "SPEAKER=audio/x-raw,format=S16LE ! filesink location=" + sound},
                           120);
  EXPECT_TRUE(r.ended) << r.output;
  const std::vector<int16_t> samples = vctest::read_s16_samples(sound);
  int loud = 0;
  for (int16_t v : samples) loud += std::abs(int(v)) > 3000;
  EXPECT_GT(samples.size(), 96000u) << "less than a second of the classroom's sound\n" << r.output;
  EXPECT_GT(loud, int(samples.size() / 10)) << "the sound is not the tone";
}

// Two loopback flows on one host (PORT_BASE apart) each run on their own: every lecturer gets its own
// server's video, and no server or lecturer sees a packet of the other flow (no senderfilter drops).
TEST(Scripts, TwoLoopbackFlowsOnOneHostRunWithoutCrosstalk) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  const int base_a = 10000 + vctest::free_udp_port() % 20000, base_b = base_a + 1000;
  std::vector<ScriptRun> runs(2);
  std::vector<std::thread> flows;
  for (int i = 0; i < 2; ++i) {
    const std::string frames = dir / ("lecturer" + std::to_string(i));
    g_mkdir_with_parents(frames.c_str(), 0755);
    flows.emplace_back([&, i, frames] {
      runs[i] = run_script("loopback.sh",
                           {"PORT_BASE=" + std::to_string(i == 0 ? base_a : base_b), "CAMERAS=0", "RIG=" + rig,
                            // Six processes start at once (two flows of three): under the sanitizers on two
                            // cores their start alone takes seconds, so the flows get 12 s to show frames.
                            "WIDTH=64", "HEIGHT=48", "SECONDS_TO_RUN=12", "STOP_GRACE=3",
                            "SOURCE=rgbdtestsrc camera-id=0 rig=" + rig + " is-live=true ground-truth=false",
                            "SINK=jpegenc ! multifilesink location=" + frames + "/%05d.jpg"},
                           120);
    });
  }
  for (auto& f : flows) f.join();
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE("flow " + std::to_string(i));
    EXPECT_TRUE(runs[i].ended) << runs[i].output;
    // Nothing foreign arrived: no senderfilter warned (its warnings end "(the latest from ADDRESS; allowed:
    // ...)") and no poserecv saw a pose of another session. (rgbddec may drop a frame whose packets a loaded
    // machine's socket lost: that is not crosstalk.)
    EXPECT_EQ(runs[i].output.find("(the latest from "), std::string::npos) << runs[i].output;
    EXPECT_EQ(runs[i].output.find("another session"), std::string::npos) << runs[i].output;
    const std::string frames = dir / ("lecturer" + std::to_string(i));
    GDir* d = g_dir_open(frames.c_str(), 0, nullptr);
    int count = 0;
    while (d && g_dir_read_name(d)) ++count;
    if (d) g_dir_close(d);
    EXPECT_GT(count, 0) << "the lecturer of flow " << i << " got no frame: " << runs[i].output;
  }
}
