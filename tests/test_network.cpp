// The pose back channel: posesend -> RTP -> poserecv gives back the same pose
// event upstream on the server; latest wins through loss, reordering, damage.
#include <gtest/gtest.h>

#include <gio/gio.h>
#include <gst/check/gstharness.h>
#include <gst/check/gsttestclock.h>
#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/rtp/rtp.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/net/pose_wire.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/synthetic/classroom.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <set>
#include <utility>

#include "test_util.h"

using namespace vclassroom;
using vctest::pose_with_seq;

namespace {

// Collects what a pad receives (posesend pushes from its rtp pad's own
// thread: wait_for() waits, bounded, for a number of buffers).
struct Capture {
  GstPad* pad = nullptr;
  std::vector<GstBuffer*> buffers;
  bool eos = false;
  GMutex lock;
  GCond cond;
  Capture() {
    g_mutex_init(&lock);
    g_cond_init(&cond);
  }
  static GstFlowReturn chain(GstPad* pad, GstObject*, GstBuffer* buf) {
    auto* self = static_cast<Capture*>(gst_pad_get_element_private(pad));
    g_mutex_lock(&self->lock);
    self->buffers.push_back(buf);
    g_cond_broadcast(&self->cond);
    g_mutex_unlock(&self->lock);
    return GST_FLOW_OK;
  }
  static gboolean event(GstPad* pad, GstObject*, GstEvent* ev) {
    auto* self = static_cast<Capture*>(gst_pad_get_element_private(pad));
    g_mutex_lock(&self->lock);
    if (GST_EVENT_TYPE(ev) == GST_EVENT_EOS) self->eos = true;
    g_cond_broadcast(&self->cond);
    g_mutex_unlock(&self->lock);
    gst_event_unref(ev);
    return TRUE;
  }
  // True when `n` buffers (or EOS, with want_eos) arrived within 20 s.
  bool wait_for(size_t n, bool want_eos = false) {
    const gint64 deadline = g_get_monotonic_time() + 20 * G_TIME_SPAN_SECOND;
    g_mutex_lock(&lock);
    while (buffers.size() < n || (want_eos && !eos))
      if (!g_cond_wait_until(&cond, &lock, deadline)) break;
    const bool ok = buffers.size() >= n && (!want_eos || eos);
    g_mutex_unlock(&lock);
    return ok;
  }
  void clear() {
    g_mutex_lock(&lock);
    for (GstBuffer* b : buffers) gst_buffer_unref(b);
    buffers.clear();
    g_mutex_unlock(&lock);
  }
  void attach(GstElement* element, const char* pad_name) {
    // Any caps, as udpsink takes: a restarted posesend sends a new SSRC in its caps.
    GstCaps* any = gst_caps_new_any();
    GstPadTemplate* templ = gst_pad_template_new("capture", GST_PAD_SINK, GST_PAD_ALWAYS, any);
    gst_caps_unref(any);
    pad = gst_pad_new_from_template(templ, "capture");
    gst_object_unref(templ);
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
    g_mutex_clear(&lock);
    g_cond_clear(&cond);
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
  ASSERT_TRUE(packets.wait_for(10));
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
  packets.clear();
  gst_buffer_unref(gst_harness_push_and_pull(lect, gst_harness_create_buffer(lect, 48)));
  ASSERT_TRUE(packets.wait_for(1));
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
// payloader and depayloader enable it from the extmap field in the caps. So
// does the pose as the server rendered it, clamped or not (the long form, in
// RFC 8285's two-byte header).
TEST(PoseHeaderExtension, SeqViewerTimeAndTheRenderedPoseCrossRtp) {
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
    // Frame 1: rendered before any pose; frame 2 names only seq and time (an older server).
    Pose rendered;
    rendered.position = Eigen::Vector3d(0.25 * i, -0.5, 1.5);
    rendered.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitX()));
    rendered.clamped = i == 3;
    if (i != 1) buffer_add_pose_meta(b, 100 + i, 5000000000ll + i, i == 2 ? RenderedPose{} : rendered_pose_of(rendered));
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
    EXPECT_EQ(m->rendered.known, i != 2);
    if (i == 2) continue;
    EXPECT_EQ(m->rendered.clamped, i == 3);
    EXPECT_FLOAT_EQ(m->rendered.position[0], 0.25f * i);
    EXPECT_FLOAT_EQ(m->rendered.position[2], 1.5f);
    EXPECT_FLOAT_EQ(m->rendered.orientation[1], float(std::sin(0.05 * i)));
  }
  gst_object_unref(src);
  gst_object_unref(out);
  gst_object_unref(p);
}

// ---- Pose sessions, authentication, plausibility and messages through poserecv

namespace {
constexpr GstClockTime kFrameTime = 33 * GST_MSECOND;  // a lecturer at 30 poses per second

// An RTP packet (12-byte header, version 2, payload type 96) around `payload`.
GstBuffer* rtp_packet(const uint8_t* payload, size_t size, guint32 ssrc) {
  static guint16 rtp_seq = 0;
  std::vector<uint8_t> bytes(12 + size, 0);
  bytes[0] = 0x80;
  bytes[1] = 0x80 | 96;  // marker, payload type
  bytes[2] = static_cast<uint8_t>(rtp_seq >> 8);
  bytes[3] = static_cast<uint8_t>(rtp_seq++);
  for (int i = 0; i < 4; ++i) bytes[8 + i] = static_cast<uint8_t>(ssrc >> (24 - 8 * i));
  std::memcpy(bytes.data() + 12, payload, size);
  return gst_buffer_new_memdup(bytes.data(), bytes.size());
}

// One pose packet as a lecturer with this SSRC and session number sends it.
GstBuffer* pose_packet(const Pose& p, guint32 ssrc, uint64_t session, const PoseKey* key = nullptr) {
  uint8_t wire[kPoseWireMaxSize];
  const size_t n = pose_to_wire(p, wire, session, key);
  return rtp_packet(wire, n, ssrc);
}

// poserecv in a harness whose clock is a test clock (the session timeout runs
// on injected time) and whose messages land on a bus of ours.
struct Server {
  GstHarness* h = nullptr;
  GstBus* bus = nullptr;
  GstTestClock* clock = nullptr;
  Feeder link;
  using Props = std::vector<std::pair<const char*, std::string>>;
  explicit Server(const Props& props = Props()) {
    GstElement* e = gst_element_factory_make("poserecv", nullptr);
    for (const auto& [name, value] : props) gst_util_set_object_arg(G_OBJECT(e), name, value.c_str());
    bus = gst_bus_new();
    gst_element_set_bus(e, bus);
    h = gst_harness_new_with_element(e, "sink", "src");
    gst_object_unref(e);
    gst_harness_use_testclock(h);
    clock = gst_harness_get_testclock(h);
    gst_harness_set_src_caps_str(h, kVideoCaps);
    link.attach(h->element, "rtp", "application/x-rtp,media=application,clock-rate=90000,"
                                   "encoding-name=X-VCLASSROOM-POSE,payload=96");
  }
  ~Server() {
    for (GstStructure* s : stats_) gst_structure_free(s);
    // Messages hold the element and the element holds the bus: drop them all.
    gst_bus_set_flushing(bus, TRUE);
    gst_object_unref(clock);
    gst_harness_teardown(h);
    gst_object_unref(bus);
  }
  void at(GstClockTime t) { gst_test_clock_set_time(clock, t); }
  // Pushes one packet; the seqs of the poses it made poserecv send upstream.
  std::vector<uint64_t> push(GstBuffer* packet) {
    EXPECT_EQ(gst_pad_push(link.pad, packet), GST_FLOW_OK);
    return injected_seqs(h);
  }
  // Pushes one packet; the pose events it made poserecv send upstream (the caller's to forward or unref).
  std::vector<GstEvent*> push_for_events(GstBuffer* packet) {
    EXPECT_EQ(gst_pad_push(link.pad, packet), GST_FLOW_OK);
    std::vector<GstEvent*> out;
    while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
      if (is_pose_event(ev))
        out.push_back(ev);
      else
        gst_event_unref(ev);
    }
    return out;
  }
  guint64 count(const char* property) {
    guint64 v = 0;
    g_object_get(h->element, property, &v, nullptr);
    return v;
  }
  // The warnings and vclassroom-pose-stats structures posted since the last call.
  std::vector<std::string> warnings() {
    drain();
    return std::exchange(warnings_, {});
  }
  std::vector<GstStructure*> stats() {  // caller frees
    drain();
    return std::exchange(stats_, {});
  }

 private:
  std::vector<std::string> warnings_;
  std::vector<GstStructure*> stats_;
  void drain() {
    while (GstMessage* m = gst_bus_pop(bus)) {
      if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING) {
        GError* err = nullptr;
        gst_message_parse_warning(m, &err, nullptr);
        warnings_.push_back(err->message);
        g_clear_error(&err);
      } else if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ELEMENT &&
                 gst_structure_has_name(gst_message_get_structure(m), "vclassroom-pose-stats")) {
        stats_.push_back(gst_structure_copy(gst_message_get_structure(m)));
      }
      gst_message_unref(m);
    }
  }
};
}  // namespace

namespace {
// A lecturer's posesend signing with `key_file`, in a harness; its packets land in `packets`.
struct SignedLecturer {
  GstHarness* h = nullptr;
  Capture packets;
  explicit SignedLecturer(const std::string& key_file) {
    GstElement* e = gst_element_factory_make("posesend", nullptr);
    g_object_set(e, "key-file", key_file.c_str(), nullptr);
    h = gst_harness_new_with_element(e, "sink", "src");
    gst_object_unref(e);
    gst_harness_set_src_caps_str(h, kVideoCaps);
    packets.attach(h->element, "rtp");
  }
  ~SignedLecturer() { gst_harness_teardown(h); }
};
}  // namespace

TEST(PoseSessions, ASeqOf2To64Minus1DoesNotLockOutTheLecturer) {
  Server srv;
  GstClockTime t = 0;
  for (uint64_t seq = 1; seq <= 5; ++seq, t += kFrameTime) {
    srv.at(t);
    EXPECT_EQ(srv.push(pose_packet(pose_with_seq(seq), 0x1111, 77)), std::vector<uint64_t>{seq});
  }
  // A forged packet in the lecturer's own stream (SSRC and session copied).
  EXPECT_TRUE(srv.push(pose_packet(pose_with_seq(UINT64_MAX), 0x1111, 77)).empty());
  for (uint64_t seq = 6; seq <= 10; ++seq, t += kFrameTime) {
    srv.at(t);
    EXPECT_EQ(srv.push(pose_packet(pose_with_seq(seq), 0x1111, 77)), std::vector<uint64_t>{seq});
  }
  EXPECT_EQ(srv.count("rejected"), 1u);
  EXPECT_EQ(srv.count("last-seq"), 10u);
  EXPECT_EQ(srv.count("injected"), 10u);
}

TEST(PoseSessions, ARestartedLecturerIsObeyedWithinASecond) {
  // The lecturer is a real posesend; restarting it (READY and back) is what
  // restarting lecturer.sh does: a new SSRC and session, seq from 1 again.
  GstHarness* lect = gst_harness_new("posesend");
  gst_harness_set_src_caps_str(lect, kVideoCaps);
  Capture packets;
  packets.attach(lect->element, "rtp");
  Server srv;
  GstClockTime t = 0;
  size_t forwarded = 0;
  // Sends pose `seq` from the lecturer and forwards its packet at time t.
  auto send = [&](uint64_t seq) {
    Pose p = pose_with_seq(seq);
    p.viewer_time_ns = static_cast<int64_t>(t);
    EXPECT_TRUE(gst_harness_push_upstream_event(lect, pose_event_new(p)));
    if (!packets.wait_for(forwarded + 1)) {
      ADD_FAILURE() << "posesend sent no packet for pose " << seq;
      return std::vector<uint64_t>{};
    }
    srv.at(t);
    return srv.push(gst_buffer_ref(packets.buffers[forwarded++]));
  };
  for (uint64_t seq = 1; seq <= 300; ++seq, t += kFrameTime) EXPECT_EQ(send(seq), std::vector<uint64_t>{seq});
  const GstClockTime stopped = t - kFrameTime;  // the last pose before the restart
  ASSERT_EQ(gst_element_set_state(lect->element, GST_STATE_READY), GST_STATE_CHANGE_SUCCESS);
  ASSERT_EQ(gst_element_set_state(lect->element, GST_STATE_PLAYING), GST_STATE_CHANGE_SUCCESS);
  GstClockTime obeyed_at = GST_CLOCK_TIME_NONE;
  for (uint64_t seq = 1; seq <= 60; ++seq, t += kFrameTime) {
    const std::vector<uint64_t> got = send(seq);
    if (!got.empty() && obeyed_at == GST_CLOCK_TIME_NONE) obeyed_at = t;
    if (obeyed_at != GST_CLOCK_TIME_NONE) {
      EXPECT_EQ(got, std::vector<uint64_t>{seq});  // and from then on, every pose
    }
  }
  ASSERT_NE(obeyed_at, GST_CLOCK_TIME_NONE) << "the restarted lecturer was never obeyed";
  EXPECT_LE(obeyed_at - stopped, GST_SECOND);
  EXPECT_EQ(srv.count("session-switches"), 1u);
  gst_harness_teardown(lect);
}

TEST(PoseSessions, ASecondSsrcCannotStealAnActiveSessionButTakesOverWhenItFallsSilent) {
  Server srv;
  GstClockTime t = 0;
  for (uint64_t i = 1; i <= 60; ++i, t += kFrameTime) {
    srv.at(t);
    EXPECT_EQ(srv.push(pose_packet(pose_with_seq(i), 0xAAAA, 1)), std::vector<uint64_t>{i});
    EXPECT_TRUE(srv.push(pose_packet(pose_with_seq(1000 + i), 0xBBBB, 2)).empty());  // seq far newer: still not obeyed
  }
  EXPECT_EQ(srv.count("rejected"), 60u);
  EXPECT_EQ(srv.count("session-switches"), 0u);
  // The first lecturer falls silent: the second is obeyed within a second.
  const GstClockTime silent_since = t - kFrameTime;
  GstClockTime obeyed_at = GST_CLOCK_TIME_NONE;
  for (uint64_t i = 61; i <= 120 && obeyed_at == GST_CLOCK_TIME_NONE; ++i, t += kFrameTime) {
    srv.at(t);
    if (!srv.push(pose_packet(pose_with_seq(1000 + i), 0xBBBB, 2)).empty()) obeyed_at = t;
  }
  ASSERT_NE(obeyed_at, GST_CLOCK_TIME_NONE);
  EXPECT_LE(obeyed_at - silent_since, GST_SECOND);
  EXPECT_EQ(srv.count("session-switches"), 1u);
}

TEST(PoseAuthentication, WithAKeyOnlyTaggedPosesAreObeyed) {
  vctest::TempDir dir;
  const std::string key_file = dir / "pose.key", other_file = dir / "other.key";
  vctest::write_text(key_file, "the classroom's 32-byte pose key");
  vctest::write_text(other_file, "somebody else's 32-byte pose key");
  const PoseKey other = load_pose_key(other_file);
  Server srv(Server::Props{{"key-file", key_file}});
  // Foreign poses first, while no session exists (they would be adopted otherwise).
  EXPECT_TRUE(srv.push(pose_packet(pose_with_seq(1), 0x5555, 9)).empty());          // no tag
  EXPECT_TRUE(srv.push(pose_packet(pose_with_seq(2), 0x5555, 9, &other)).empty());  // another key
  EXPECT_EQ(srv.count("unauthenticated"), 2u);
  EXPECT_EQ(srv.count("injected"), 0u);
  // The lecturer's posesend, given the same key file, is obeyed.
  SignedLecturer lect(key_file);
  EXPECT_TRUE(gst_harness_push_upstream_event(lect.h, pose_event_new(pose_with_seq(3))));
  ASSERT_TRUE(lect.packets.wait_for(1));
  EXPECT_EQ(srv.push(gst_buffer_ref(lect.packets.buffers[0])), std::vector<uint64_t>{3});
}

TEST(PoseAuthentication, AMissingOrShortKeyFileIsAnErrorAtStart) {
  vctest::TempDir dir;
  vctest::write_text(dir / "short.key", "0123456789");
  for (const char* element : {"posesend", "poserecv"})
    for (const std::string& file : {dir / "missing.key", dir / "short.key"}) {
      const auto r = vctest::run_launch("videotestsrc num-buffers=1 ! " + std::string(element) + " key-file=" + file +
                                            " ! fakesink",
                                        10 * GST_SECOND);
      EXPECT_NE(r.error.find(file), std::string::npos) << element << ": '" << r.error << "'";
    }
}

TEST(PosePlausibility, APose999MetresAwayIsRejected) {
  Server srv;
  Pose far = pose_with_seq(1);
  far.position = Eigen::Vector3d(999, 0, 0);
  EXPECT_TRUE(srv.push(pose_packet(far, 1, 1)).empty());
  EXPECT_EQ(srv.count("implausible"), 1u);
  Pose near = pose_with_seq(2);
  near.position = Eigen::Vector3d(3, -1, 4);
  EXPECT_EQ(srv.push(pose_packet(near, 1, 1)), std::vector<uint64_t>{2});
  g_object_set(srv.h->element, "max-distance", 2.0, nullptr);
  near.seq = 3;
  EXPECT_TRUE(srv.push(pose_packet(near, 1, 1)).empty());
  EXPECT_EQ(srv.count("implausible"), 2u);
  const auto w = srv.warnings();
  ASSERT_EQ(w.size(), 1u);  // the second within 5 s is counted, not posted
  EXPECT_NE(w[0].find("999"), std::string::npos) << w[0];
}

TEST(PoseMessages, BadPacketsWarnOncePerIntervalWithCountsAndStats) {
  Server srv(Server::Props{{"stats-interval", "10"}});
  std::mt19937 rng(17);
  const auto garbage = [&] {
    std::vector<uint8_t> bytes(kPoseWireSize);
    for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
    std::memcpy(bytes.data(), "VCP2", 4);  // looks like a pose, but the flags/checksum do not add up
    return rtp_packet(bytes.data(), bytes.size(), 1);
  };
  for (int i = 0; i < 50; ++i) {
    srv.at(i * GST_MSECOND);
    EXPECT_TRUE(srv.push(garbage()).empty());
  }
  std::vector<std::string> w = srv.warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("a damaged pose packet from the pose link"), std::string::npos) << w[0];
  EXPECT_EQ(srv.count("damaged"), 50u);
  srv.at(5 * GST_SECOND);
  EXPECT_TRUE(srv.push(garbage()).empty());
  w = srv.warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("50 damaged pose packets from the pose link in the last 5 s"), std::string::npos) << w[0];
  // A good pose, then the stats: one message per 10 packets.
  srv.at(6 * GST_SECOND);
  EXPECT_EQ(srv.push(pose_packet(pose_with_seq(8), 1, 1)), std::vector<uint64_t>{8});
  std::vector<GstStructure*> stats = srv.stats();
  ASSERT_EQ(stats.size(), 5u);
  guint64 received = 0, damaged = 0, injected = 1;
  gst_structure_get_uint64(stats.back(), "received", &received);
  gst_structure_get_uint64(stats.back(), "damaged", &damaged);
  gst_structure_get_uint64(stats.back(), "injected", &injected);
  EXPECT_EQ(received, 50u);
  EXPECT_EQ(damaged, 50u);
  EXPECT_EQ(injected, 0u);
  for (const char* f : {"unauthenticated", "implausible", "rejected", "session-switches"})
    EXPECT_TRUE(gst_structure_has_field(stats.back(), f)) << f;
  for (GstStructure* s : stats) gst_structure_free(s);
  EXPECT_EQ(srv.count("received"), 52u);
}

// ---- posesend starting and stopping

TEST(PoseSendLifecycle, EndOfStreamReachesThePoseSinkWhenNoPoseWasEverSent) {
  for (const char* live : {"false", "true"}) {
    const auto r = vctest::run_launch(std::string("videotestsrc num-buffers=3 is-live=") + live +
                                          " ! video/x-raw,width=32,height=24 ! posesend name=s ! fakesink  "
                                          "s.rtp ! fakesink",
                                      10 * GST_SECOND);
    EXPECT_EQ(r.error, "") << "is-live=" << live;
  }
}

TEST(PoseSendLifecycle, RunsToTheEndInANonLivePipelineWithoutAQueueAfterItsRtpPad) {
  vctest::TempDir dir;
  std::vector<PoseSample> trace(3);
  for (size_t i = 0; i < trace.size(); ++i) trace[i].pose = pose_with_seq(i);
  save_pose_trace(trace, dir / "walk.csv");
  GstElement* p = gst_parse_launch(("videotestsrc num-buffers=20 ! video/x-raw,width=32,height=24 ! posesend name=s ! "
                                    "videoconvert ! posenav pose-trace=" + (dir / "walk.csv") +
                                    " ! fakesink  s.rtp ! fakesink name=poses")
                                       .c_str(),
                                   nullptr);
  ASSERT_NE(p, nullptr);
  const auto r = vctest::run_pipeline(p, 10 * GST_SECOND);
  EXPECT_EQ(r.error, "");
  GstElement* s = gst_bin_get_by_name(GST_BIN(p), "s");
  guint64 sent = 0;
  g_object_get(s, "sent", &sent, nullptr);
  EXPECT_GE(sent, 20u);  // a pose per frame from posenav (plus repeats)
  gst_object_unref(s);
  gst_object_unref(p);
}

TEST(PoseSendTrace, TheLecturerRecordsEveryPoseItSentWithItsRunningTime) {
  vctest::TempDir dir;
  std::vector<PoseSample> walk(5);
  for (size_t i = 0; i < walk.size(); ++i) {
    walk[i].pose = pose_with_seq(i + 1);
    walk[i].pose.position.x() = 0.1 * double(i);
  }
  save_pose_trace(walk, dir / "walk.csv");
  const auto r = vctest::run_launch("videotestsrc num-buffers=5 ! video/x-raw,width=32,height=24,framerate=30/1 ! "
                                    "posesend name=s trace-location=" + (dir / "sent.csv") +
                                    " ! videoconvert ! posenav pose-trace=" + (dir / "walk.csv") +
                                    " ! fakesink  s.rtp ! fakesink");
  ASSERT_EQ(r.error, "");
  const std::vector<PoseSample> sent = load_pose_trace(dir / "sent.csv");
  // One pose per frame, in order, each as it was sent; the times never go back.
  ASSERT_EQ(sent.size(), walk.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_NEAR(sent[i].pose.position.x(), walk[i].pose.position.x(), 1e-12) << i;
    EXPECT_GT(sent[i].pose.seq, i == 0 ? 0 : sent[i - 1].pose.seq) << i;
    EXPECT_FALSE(std::isnan(sent[i].t));
    if (i > 0) {
      EXPECT_GE(sent[i].t, sent[i - 1].t) << i;
    }
  }
  // A trace that cannot be written stops the lecturer at start with a clear error.
  const auto bad = vctest::run_launch("videotestsrc num-buffers=1 ! posesend name=s trace-location=" +
                                      (dir / "no-such-dir/sent.csv") + " ! fakesink  s.rtp ! fakesink");
  EXPECT_NE(bad.error.find("cannot write pose trace"), std::string::npos) << bad.error;
}

// ---- Pose sessions end to end: the receiver's pose events steer the renderers (viewwarp, viewfuse)

namespace {
// One camera's viewwarp in a harness, fed what poserecv sends upstream, as the fuse forwards it.
struct Renderer {
  vctest::TempDir dir;
  GstHarness* h = nullptr;
  RgbdInfo info;
  Renderer() {
    h = gst_harness_new_parse(("viewwarp rig=" + vctest::small_classroom_rig(dir, 32, 18)).c_str());
    info.camera = scale_camera(default_classroom_rig().camera(1), 32, 18);
    info.planes = {Plane::Color, Plane::Depth};
    gst_harness_set_src_caps(h, rgbd_caps_new(info));
  }
  ~Renderer() { gst_harness_teardown(h); }
  void steer(const std::vector<GstEvent*>& events) {
    for (GstEvent* ev : events) EXPECT_TRUE(gst_harness_push_upstream_event(h, ev));
  }
  // The pose (session, seq) the next camera frame is rendered for.
  std::pair<uint64_t, uint64_t> next_frame() {
    GstBuffer* in = rgbd_buffer_new(info);
    gst_buffer_memset(in, 0, 0, gst_buffer_get_size(in));
    EXPECT_EQ(gst_harness_push(h, in), GST_FLOW_OK);
    GstBuffer* out = gst_harness_pull(h);
    const PoseMeta* m = out ? buffer_get_pose_meta(out) : nullptr;
    EXPECT_NE(m, nullptr);
    const std::pair<uint64_t, uint64_t> shown(m ? m->session : 0, m ? m->seq : 0);
    if (out) gst_buffer_unref(out);
    return shown;
  }
};
}  // namespace

namespace {
// Pose `seq` of the lecturer (ssrc, session) reaches poserecv at time t; what poserecv obeys steers `view`, as
// the fuse forwards it. Returns how many poses were obeyed (0 or 1).
size_t deliver(Server& srv, Renderer& view, GstClockTime t, uint64_t seq, guint32 ssrc, uint64_t session) {
  srv.at(t);
  const std::vector<GstEvent*> obeyed = srv.push_for_events(pose_packet(pose_with_seq(seq), ssrc, session));
  view.steer(obeyed);
  return obeyed.size();
}
}  // namespace

// issue 29: viewwarp kept the highest seq it had ever seen, across sessions: a restarted lecturer (seq from
// 1 again) was ignored by the renderer although poserecv obeyed it.
TEST(PoseSessions, ARestartedLecturerSteersTheViewFromItsFirstPose) {
  Server srv;
  Renderer view;
  GstClockTime t = 0;
  for (uint64_t seq = 1; seq <= 41; ++seq, t += kFrameTime) {
    deliver(srv, view, t, seq, 0xAAAA, 1);
  }
  const std::pair<uint64_t, uint64_t> before = view.next_frame();
  EXPECT_EQ(before.second, 41u);
  // The lecturer restarts: a new SSRC and session, seq from 1, after the session timeout.
  t += 600 * GST_MSECOND;
  for (uint64_t seq = 1; seq <= 5; ++seq, t += kFrameTime) {
    ASSERT_EQ(deliver(srv, view, t, seq, 0xBBBB, 2), 1u) << "poserecv did not obey seq " << seq;
    const std::pair<uint64_t, uint64_t> shown = view.next_frame();
    EXPECT_EQ(shown.second, seq) << "the renderer did not follow the restarted lecturer";
    EXPECT_NE(shown.first, before.first);
  }
}

// issue 29: one pose with seq 2^64-1 froze the view until the server restarted.
TEST(PoseSessions, ASeqOf2To64Minus1FromAnotherSessionDoesNotFreezeTheView) {
  Server srv;
  Renderer view;
  GstClockTime t = 0;
  for (uint64_t seq = 1; seq <= 10; ++seq, t += kFrameTime) {
    deliver(srv, view, t, seq, 0x1111, 7);
  }
  // The lecturer pauses; a stranger's single pose takes over (the session rule allows it) ...
  t += 600 * GST_MSECOND;
  deliver(srv, view, t, UINT64_MAX, 0x6666, 66);
  EXPECT_EQ(view.next_frame().second, UINT64_MAX);
  // ... and once it is silent, the lecturer steers again, from where its seq stands.
  t += 600 * GST_MSECOND;
  for (uint64_t seq = 11; seq <= 15; ++seq, t += kFrameTime) {
    deliver(srv, view, t, seq, 0x1111, 7);
    EXPECT_EQ(view.next_frame().second, seq);
  }
}

// A pose of another session than the obeyed one never reaches the renderer, and so never moves the view.
TEST(PoseSessions, APoseOfASessionThatIsNotSteeringNeverMovesTheView) {
  Server srv;
  Renderer view;
  GstClockTime t = 0;
  for (uint64_t seq = 1; seq <= 30; ++seq, t += kFrameTime) {
    deliver(srv, view, t, seq, 0xAAAA, 1);
    deliver(srv, view, t, 1000 + seq, 0xBBBB, 2);
    EXPECT_EQ(view.next_frame().second, seq);
  }
}

// With a key, the lecturer's repeats (posesend sends its latest pose again with every video frame) are
// fresh packets, never taken for replays, and keep its session while another sender is refused.
TEST(PoseAuthentication, TheLecturersRepeatsAreFreshPacketsNotReplays) {
  vctest::TempDir dir;
  const std::string key_file = dir / "pose.key";
  vctest::write_text(key_file, "the classroom's 32-byte pose key");
  Server srv(Server::Props{{"key-file", key_file}});
  SignedLecturer lect(key_file);
  const Capture& packets = lect.packets;
  EXPECT_TRUE(gst_harness_push_upstream_event(lect.h, pose_event_new(pose_with_seq(3))));
  for (int i = 0; i < 20; ++i)
    ASSERT_EQ(gst_harness_push(lect.h, gst_harness_create_buffer(lect.h, 48)), GST_FLOW_OK);
  ASSERT_TRUE(lect.packets.wait_for(21));
  // Received at the times they were sent (the receiver's clock set to the sender's).
  std::set<uint64_t> numbers;
  for (size_t i = 0; i < 21; ++i) {
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    ASSERT_TRUE(gst_rtp_buffer_map(packets.buffers[i], GST_MAP_READ, &rtp));
    Pose p;
    PoseWireInfo info;
    ASSERT_TRUE(pose_from_wire(static_cast<const uint8_t*>(gst_rtp_buffer_get_payload(&rtp)),
                               gst_rtp_buffer_get_payload_len(&rtp), &p, nullptr, nullptr, &info));
    gst_rtp_buffer_unmap(&rtp);
    EXPECT_EQ(p.seq, 3u);
    numbers.insert(info.stamp.packet);
    srv.at(GstClockTime(info.stamp.sent_ns));
    const std::vector<uint64_t> obeyed = srv.push(gst_buffer_ref(packets.buffers[i]));
    EXPECT_EQ(obeyed.size(), i == 0 ? 1u : 0u);  // the pose once; its repeats keep the session
  }
  EXPECT_EQ(numbers.size(), 21u) << "posesend numbered its repeats alike";
  EXPECT_EQ(srv.count("replayed"), 0u);
  EXPECT_EQ(srv.count("received"), 21u);
  // Replayed as they were captured, every one is refused.
  for (size_t i = 0; i < 21; ++i) EXPECT_TRUE(srv.push(gst_buffer_ref(packets.buffers[i])).empty());
  EXPECT_EQ(srv.count("replayed"), 21u);
}

// viewfuse with two cameras' viewwarps: a new session's first pose reaches every camera and the fused view
// shows it at once, whatever seq the session before had reached.
TEST(PoseSessions, TheFusedViewFollowsANewSessionAtOnce) {
  vctest::TempDir dir;
  const std::string r = vctest::small_classroom_rig(dir, 64, 36);
  const CameraCalib reference = default_classroom_rig().camera(0);  // its pose: the scaled rig's camera 0
  std::string desc = "viewfuse name=f ! appsink name=out sync=false max-buffers=1";
  for (int i = 1; i <= 2; ++i)
    desc += " rgbdtestsrc rig=" + r + " camera-id=" + std::to_string(i) + " learners=1 ! viewwarp rig=" + r +
            " ! queue max-size-buffers=1 ! f.cam_" + std::to_string(i);
  GError* err = nullptr;
  GstElement* pipe = gst_parse_launch(desc.c_str(), &err);
  ASSERT_EQ(err, nullptr) << err->message;
  GstElement* sink = gst_bin_get_by_name(GST_BIN(pipe), "out");
  GstPad* sinkpad = gst_element_get_static_pad(sink, "sink");
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  // Pulls frames until one shows (session, seq), then checks that the next ones do too.
  auto shows_from_now_on = [&](uint64_t session, uint64_t seq) {
    bool seen = false;
    for (int i = 0; i < 12; ++i) {
      GstSample* s = gst_app_sink_pull_sample(GST_APP_SINK(sink));
      if (!s) return false;
      const PoseMeta* m = buffer_get_pose_meta(gst_sample_get_buffer(s));
      const bool match = m && m->session == session && m->seq == seq;
      gst_sample_unref(s);
      if (seen && !match) return false;  // went back
      seen = seen || match;
    }
    return seen;
  };
  Pose a = sliders_to_pose(Sliders{60, 50, 55, 45, 50, 50}, reference);
  a.session = 0xA;
  a.seq = 41;
  ASSERT_TRUE(gst_pad_push_event(sinkpad, pose_event_new(a)));
  EXPECT_TRUE(shows_from_now_on(0xA, 41));
  Pose b = sliders_to_pose(Sliders{40, 50, 50, 55, 50, 50}, reference);
  b.session = 0xB;
  b.seq = 1;
  ASSERT_TRUE(gst_pad_push_event(sinkpad, pose_event_new(b)));
  EXPECT_TRUE(shows_from_now_on(0xB, 1)) << "the fused view did not follow the new session's first pose";
  gst_object_unref(sinkpad);
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(sink);
  gst_object_unref(pipe);
}
