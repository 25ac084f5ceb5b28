// The pose back channel: posesend -> RTP -> poserecv gives back the same pose
// event upstream on the server; latest wins through loss, reordering, damage.
#include <gtest/gtest.h>

#include <gio/gio.h>
#include <gst/check/gstharness.h>
#include <gst/app/gstappsrc.h>
#include <gst/vclassroom/pose.h>
#include <gst/vclassroom/pose_meta.h>
#include <gst/vclassroom/warning_limiter.h>

#include <algorithm>
#include <random>

#include "test_util.h"

using namespace vclassroom;

namespace {

Pose pose_with_seq(uint64_t seq) {
  Pose p;
  const double k = static_cast<double>(seq % 100);
  p.position = Eigen::Vector3d(0.01 * k, -0.2, 0.5);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitY()));
  p.seq = seq;
  p.viewer_time_ns = 1000 + static_cast<int64_t>(seq);
  return p;
}

// Collects what a pad receives, synchronously.
struct Capture {
  GstPad* pad = nullptr;
  std::vector<GstBuffer*> buffers;
  static GstFlowReturn chain(GstPad* pad, GstObject*, GstBuffer* buf) {
    static_cast<Capture*>(gst_pad_get_element_private(pad))->buffers.push_back(buf);
    return GST_FLOW_OK;
  }
  static gboolean event(GstPad*, GstObject*, GstEvent* ev) {
    gst_event_unref(ev);
    return TRUE;
  }
  void attach(GstElement* element, const char* pad_name) {
    pad = gst_pad_new("capture", GST_PAD_SINK);
    gst_pad_set_element_private(pad, this);
    gst_pad_set_chain_function(pad, chain);
    gst_pad_set_event_function(pad, event);
    gst_pad_set_active(pad, TRUE);
    GstPad* from = gst_element_get_static_pad(element, pad_name);
    EXPECT_EQ(gst_pad_link(from, pad), GST_PAD_LINK_OK);
    gst_object_unref(from);
  }
  ~Capture() {
    for (GstBuffer* b : buffers) gst_buffer_unref(b);
    if (pad) gst_object_unref(pad);
  }
};

// A source pad of ours feeding an element's pad, synchronously.
struct Feeder {
  GstPad* pad = nullptr;
  void attach(GstElement* element, const char* pad_name, const char* caps) {
    pad = gst_pad_new("feeder", GST_PAD_SRC);
    gst_pad_set_active(pad, TRUE);
    GstPad* to = gst_element_get_static_pad(element, pad_name);
    EXPECT_EQ(gst_pad_link(pad, to), GST_PAD_LINK_OK);
    gst_object_unref(to);
    gst_pad_push_event(pad, gst_event_new_stream_start("feeder"));
    GstCaps* c = gst_caps_from_string(caps);
    gst_pad_push_event(pad, gst_event_new_caps(c));
    gst_caps_unref(c);
    GstSegment seg;
    gst_segment_init(&seg, GST_FORMAT_TIME);
    gst_pad_push_event(pad, gst_event_new_segment(&seg));
  }
  ~Feeder() {
    if (pad) gst_object_unref(pad);
  }
};

// Poses that came out upstream of a poserecv harness.
std::vector<uint64_t> injected_seqs(GstHarness* h) {
  std::vector<uint64_t> out;
  while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
    Pose p;
    if (is_pose_event(ev) && pose_event_parse(ev, &p, nullptr)) out.push_back(p.seq);
    gst_event_unref(ev);
  }
  return out;
}

const char* kVideoCaps = "video/x-raw,format=RGB,width=4,height=4,framerate=30/1";

}  // namespace

TEST(PoseWire, RoundTripAndRejects) {
  Pose p = pose_with_seq(123456789012345ull);
  p.fov_deg = 70;
  uint8_t wire[kPoseWireSize];
  pose_to_wire(p, wire);
  Pose back;
  std::string err;
  ASSERT_TRUE(pose_from_wire(wire, sizeof wire, &back, &err)) << err;
  EXPECT_EQ(back.seq, p.seq);
  EXPECT_EQ(back.viewer_time_ns, p.viewer_time_ns);
  EXPECT_EQ(back.position, p.position);
  EXPECT_LT(back.orientation.angularDistance(p.orientation), 1e-15);
  EXPECT_EQ(back.fov_deg, 70);
  EXPECT_FALSE(pose_from_wire(wire, sizeof wire - 1, &back, &err));
  wire[0] = 'X';
  EXPECT_FALSE(pose_from_wire(wire, sizeof wire, &back, &err));
  wire[0] = 'V';
  wire[30] ^= 0x01;  // one bit of y
  EXPECT_FALSE(pose_from_wire(wire, sizeof wire, &back, &err));
  EXPECT_NE(err.find("checksum"), std::string::npos) << err;
}

TEST(PoseBackChannel, LatestWinsThroughLossReorderingAndDamage) {
  // Lecturer side: posesend with its rtp pad captured.
  GstHarness* lect = gst_harness_new("posesend");
  gst_harness_set_src_caps_str(lect, kVideoCaps);
  Capture packets;
  packets.attach(lect->element, "rtp");
  // Server side: poserecv fed packets by hand.
  GstHarness* serv = gst_harness_new("poserecv");
  gst_harness_set_src_caps_str(serv, kVideoCaps);
  Feeder link;
  link.attach(serv->element, "rtp", "application/x-rtp,media=application,clock-rate=90000,"
                                    "encoding-name=X-VCLASSROOM-POSE,payload=96");

  for (uint64_t seq = 1; seq <= 10; ++seq)
    EXPECT_TRUE(gst_harness_push_upstream_event(lect, pose_event_new(pose_with_seq(seq))));
  ASSERT_EQ(packets.buffers.size(), 10u);
  // The network loses packets 4 and 10, swaps 6 and 7, repeats 5 and damages 8.
  std::vector<GstBuffer*> wire;
  for (int i : {0, 1, 2, 4, 4, 6, 5, 7, 8}) wire.push_back(gst_buffer_copy_deep(packets.buffers[i]));
  GstMapInfo m;
  gst_buffer_map(wire[7], &m, GST_MAP_WRITE);
  m.data[m.size - 30] ^= 0x01;  // one bit of the orientation
  gst_buffer_unmap(wire[7], &m);
  for (GstBuffer* b : wire) EXPECT_EQ(gst_pad_push(link.pad, b), GST_FLOW_OK);
  // Every injected pose is newer than the one before; the damaged 8 is gone.
  EXPECT_EQ(injected_seqs(serv), (std::vector<uint64_t>{1, 2, 3, 5, 7, 9}));

  // Pose 10 was lost; the next video frame on the lecturer's side repeats it.
  for (GstBuffer* b : packets.buffers) gst_buffer_unref(b);
  packets.buffers.clear();
  gst_buffer_unref(gst_harness_push_and_pull(lect, gst_harness_create_buffer(lect, 48)));
  ASSERT_EQ(packets.buffers.size(), 1u);
  EXPECT_EQ(gst_pad_push(link.pad, gst_buffer_ref(packets.buffers[0])), GST_FLOW_OK);
  EXPECT_EQ(injected_seqs(serv), (std::vector<uint64_t>{10}));
  guint64 injected = 0, last = 0;
  g_object_get(serv->element, "injected", &injected, "last-seq", &last, nullptr);
  EXPECT_EQ(injected, 7u);
  EXPECT_EQ(last, 10u);

  // Pose events stop at posesend: the lecturer's source never sees them.
  GstEvent* up;
  while ((up = gst_harness_try_pull_upstream_event(lect))) {
    EXPECT_FALSE(is_pose_event(up));
    gst_event_unref(up);
  }
  gst_harness_teardown(lect);
  gst_harness_teardown(serv);
}

namespace {
struct Waiter {
  GMutex lock;
  GCond cond;
  std::vector<uint64_t> seqs;
};

GstPadProbeReturn on_pose(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* w = static_cast<Waiter*>(data);
  Pose p;
  if (pose_event_parse(GST_PAD_PROBE_INFO_EVENT(info), &p, nullptr)) {
    g_mutex_lock(&w->lock);
    w->seqs.push_back(p.seq);
    g_cond_broadcast(&w->cond);
    g_mutex_unlock(&w->lock);
  }
  return GST_PAD_PROBE_OK;
}

}  // namespace

// Two pipelines joined by UDP on loopback, as lecturer and server run.
TEST(PoseBackChannel, OverUdpOnLoopback) {
  const int port = vctest::free_udp_port();
  const std::string server_desc =
      "videotestsrc name=render is-live=true ! video/x-raw,width=32,height=24,framerate=30/1 ! poserecv name=r ! "
      "fakesink sync=false  udpsrc address=127.0.0.1 port=" + std::to_string(port) +
      " caps=\"application/x-rtp,media=application,clock-rate=90000,encoding-name=X-VCLASSROOM-POSE,payload=96\" ! r.rtp";
  const std::string lecturer_desc =
      "videotestsrc is-live=true ! video/x-raw,width=32,height=24,framerate=30/1 ! posesend name=s ! "
      "fakesink name=display sync=false  s.rtp ! udpsink host=127.0.0.1 port=" + std::to_string(port) +
      " sync=false async=false";
  GstElement* server = gst_parse_launch(server_desc.c_str(), nullptr);
  GstElement* lecturer = gst_parse_launch(lecturer_desc.c_str(), nullptr);
  ASSERT_NE(server, nullptr);
  ASSERT_NE(lecturer, nullptr);
  Waiter w;
  g_mutex_init(&w.lock);
  g_cond_init(&w.cond);
  GstElement* render = gst_bin_get_by_name(GST_BIN(server), "render");
  GstPad* render_src = gst_element_get_static_pad(render, "src");
  gst_pad_add_probe(render_src, GST_PAD_PROBE_TYPE_EVENT_UPSTREAM, on_pose, &w, nullptr);
  gst_element_set_state(server, GST_STATE_PLAYING);
  gst_element_set_state(lecturer, GST_STATE_PLAYING);
  ASSERT_EQ(gst_element_get_state(server, nullptr, nullptr, 20 * GST_SECOND), GST_STATE_CHANGE_SUCCESS);
  ASSERT_EQ(gst_element_get_state(lecturer, nullptr, nullptr, 20 * GST_SECOND), GST_STATE_CHANGE_SUCCESS);
  GstElement* display = gst_bin_get_by_name(GST_BIN(lecturer), "display");
  EXPECT_TRUE(gst_element_send_event(display, pose_event_new(pose_with_seq(41))));
  EXPECT_TRUE(gst_element_send_event(display, pose_event_new(pose_with_seq(42))));
  // Wait (bounded) until the server's render source has seen pose 42.
  const gint64 deadline = g_get_monotonic_time() + 20 * G_TIME_SPAN_SECOND;
  g_mutex_lock(&w.lock);
  while (std::find(w.seqs.begin(), w.seqs.end(), 42u) == w.seqs.end())
    if (!g_cond_wait_until(&w.cond, &w.lock, deadline)) break;
  const std::vector<uint64_t> seen = w.seqs;
  g_mutex_unlock(&w.lock);
  gst_element_set_state(lecturer, GST_STATE_NULL);
  gst_element_set_state(server, GST_STATE_NULL);
  ASSERT_FALSE(seen.empty()) << "no pose reached the server";
  EXPECT_EQ(seen.back(), 42u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  gst_object_unref(render_src);
  for (GstElement* e : {render, display, server, lecturer}) gst_object_unref(e);
  g_mutex_clear(&w.lock);
  g_cond_clear(&w.cond);
}

namespace {
// What a network keeps of a packet: its bytes, nothing else (no metas).
GstPadProbeReturn bytes_only(GstPad*, GstPadProbeInfo* info, gpointer) {
  GstBuffer* in = GST_PAD_PROBE_INFO_BUFFER(info);
  GstMapInfo m;
  gst_buffer_map(in, &m, GST_MAP_READ);
  GstBuffer* out = gst_buffer_new_memdup(m.data, m.size);
  gst_buffer_unmap(in, &m);
  GST_BUFFER_PTS(out) = GST_BUFFER_PTS(in);
  gst_buffer_unref(in);
  GST_PAD_PROBE_INFO_DATA(info) = out;
  return GST_PAD_PROBE_OK;
}
}  // namespace

// The pose a frame was rendered for crosses RTP in a header extension:
// payloader and depayloader enable it from the extmap field in the caps.
TEST(PoseHeaderExtension, SeqAndViewerTimeCrossRtp) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(
      "appsrc name=src format=time caps=video/x-raw,format=RGB,width=16,height=8,framerate=30/1 ! "
      "rtpvrawpay ! application/x-rtp,extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose ! "
      "rtpvrawdepay name=depay ! "
      "appsink name=out sync=false",
      &err);
  ASSERT_EQ(err, nullptr) << (err ? err->message : "");
  GstElement *src = gst_bin_get_by_name(GST_BIN(p), "src"), *out = gst_bin_get_by_name(GST_BIN(p), "out");
  GstElement* depay = gst_bin_get_by_name(GST_BIN(p), "depay");
  GstPad* wire = gst_element_get_static_pad(depay, "sink");
  gst_pad_add_probe(wire, GST_PAD_PROBE_TYPE_BUFFER, bytes_only, nullptr, nullptr);
  gst_object_unref(wire);
  gst_object_unref(depay);
  vctest::SampleCollector got(out);
  for (int i = 0; i < 4; ++i) {
    GstBuffer* b = gst_buffer_new_allocate(nullptr, 16 * 8 * 3, nullptr);
    gst_buffer_memset(b, 0, static_cast<guint8>(i), 16 * 8 * 3);
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    if (i != 1) buffer_add_pose_meta(b, 100 + i, 5000000000ll + i);  // frame 1: rendered before any pose
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const PoseMeta* m = buffer_get_pose_meta(got.buffer(i));
    if (i == 1) {
      EXPECT_EQ(m, nullptr);
      continue;
    }
    ASSERT_NE(m, nullptr) << "frame " << i;
    EXPECT_EQ(m->seq, 100u + i);
    EXPECT_EQ(m->viewer_time_ns, 5000000000ll + i);
  }
  gst_object_unref(src);
  gst_object_unref(out);
  gst_object_unref(p);
}

// ---- Rate-limited warnings (gst/vclassroom/warning_limiter.h)

TEST(WarningLimiter, FirstAtOnceThenOnePerIntervalWithTheCount) {
  vclassroom::WarningLimiter lim(5'000'000'000);
  uint64_t count = 0;
  int64_t span = -1;
  ASSERT_TRUE(lim.note(1'000, &count, &span));
  EXPECT_EQ(count, 1u);
  EXPECT_EQ(span, 0);
  // 36 more inside the interval: none posted, all counted.
  for (int i = 0; i < 36; ++i) EXPECT_FALSE(lim.note(1'000 + i * 100'000'000LL, &count, &span));
  EXPECT_EQ(lim.pending(), 36u);
  ASSERT_TRUE(lim.note(5'000'001'000, &count, &span));
  EXPECT_EQ(count, 37u);
  EXPECT_EQ(span, 5'000'000'000);
  EXPECT_EQ(lim.total(), 38u);
  EXPECT_EQ(lim.pending(), 0u);
  EXPECT_EQ(vclassroom::describe_occurrences(count, "a damaged frame", "damaged frames", "camera 2", span),
            "37 damaged frames from camera 2 in the last 5 s");
  EXPECT_EQ(vclassroom::describe_occurrences(1, "a damaged frame", "damaged frames", "camera 2", 0),
            "a damaged frame from camera 2");
}

TEST(WarningLimiter, PendingAfterABurstCanBeTakenForAFinalMessage) {
  vclassroom::WarningLimiter lim(1'000);
  uint64_t count;
  int64_t span;
  ASSERT_TRUE(lim.note(0, &count, &span));
  EXPECT_FALSE(lim.note(10, &count, &span));
  EXPECT_FALSE(lim.note(20, &count, &span));
  EXPECT_EQ(lim.take_pending(), 2u);
  EXPECT_EQ(lim.pending(), 0u);
  lim.reset();
  EXPECT_EQ(lim.total(), 0u);
  ASSERT_TRUE(lim.note(30, &count, &span));  // after a reset the first is posted again
  EXPECT_EQ(count, 1u);
}
