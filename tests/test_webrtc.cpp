// The browser lecturer's signalling and pose data channel (issue 13): WHEP
// request decisions (token first, bounded offers, session cap), the session
// table, and the pose / frame-echo messages the page exchanges.
#include <gtest/gtest.h>

#include <gst/app/gstappsink.h>
#include <gst/check/gstharness.h>
#include <gst/rtp/rtp.h>
#include <gst/video/navigation.h>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/webrtc/lecturer_silence.h>
#include <gst/vclassroom/webrtc/loss_rate.h>
#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/send_gate.h>
#include <gst/vclassroom/webrtc/whep.h>

#include <arpa/inet.h>
#include <gio/gio.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/wait.h>

#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "test_util.h"

using namespace vclassroom;

namespace {

const std::string kOffer = "v=0\r\no=- 1 2 IN IP4 127.0.0.1\r\ns=-\r\nt=0 0\r\n";

// The body is a view: string literals and named strings outlive the request, a temporary would not.
WhepRequest post(const std::string& token, std::string_view body = kOffer) {
  WhepRequest r;
  r.method = "POST";
  r.path = "/whep";
  r.token = token;
  r.content_type = "application/sdp";
  r.body_size = body.size();
  r.body = body;
  return r;
}

}  // namespace

TEST(WebrtcToken, EqualOnlyWhenIdenticalAndNonEmpty) {
  EXPECT_TRUE(token_equal("s3cret", "s3cret"));
  EXPECT_FALSE(token_equal("s3cret", "s3cres"));
  EXPECT_FALSE(token_equal("s3cret", "s3cre"));
  EXPECT_FALSE(token_equal("s3cret", "s3crett"));
  EXPECT_FALSE(token_equal("s3cret", ""));
  EXPECT_FALSE(token_equal("", ""));  // no secret configured: nobody is let in
  const std::string with_nul("ab\0c", 4);
  EXPECT_FALSE(token_equal(with_nul, "ab"));
}

TEST(WebrtcWhep, WrongOrMissingTokenIs401WhateverElseTheRequestSays) {
  const WhepLimits limits;
  for (const std::string& token : {std::string(), std::string("nope"), std::string("tok"), std::string("tokenx")}) {
    WhepRequest r = post(token);
    EXPECT_EQ(check_whep_request(r, "token", limits, 0).status, 401) << token;
    r.method = "DELETE";
    r.path = "/whep/" + std::string(32, 'a');
    EXPECT_EQ(check_whep_request(r, "token", limits, 0).status, 401);
    r.path = "/../../etc/passwd";
    EXPECT_EQ(check_whep_request(r, "token", limits, 0).status, 401);
    r = post(token, std::string(1 << 20, 'x'));
    EXPECT_EQ(check_whep_request(r, "token", limits, 99).status, 401);
    EXPECT_EQ(check_whep_request(r, "token", limits, 0).action, WhepAction::kRefuse);
  }
}

TEST(WebrtcWhep, PostOfAnOfferJoins) {
  const WhepDecision d = check_whep_request(post("token"), "token", {}, 0);
  EXPECT_EQ(d.action, WhepAction::kJoin);
  EXPECT_EQ(d.status, 201);
}

TEST(WebrtcWhep, MalformedRequestsAreRefusedWithTheirStatus) {
  const WhepLimits limits;
  WhepRequest r = post("t");
  r.content_type = "text/plain";
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 415);
  r = post("t", "hello");
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 400);
  const std::string big = "v=0\r\n" + std::string(limits.max_offer_bytes, 'a');
  r = post("t", big);
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 413);
  r = post("t");
  r.body_size += 1;  // the declared size must be the size received
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 413);
  r = post("t");
  r.method = "GET";
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 405);
  r.path = "/whepx";
  EXPECT_EQ(check_whep_request(r, "t", limits, 0).status, 404);
}

TEST(WebrtcWhep, TheSessionCapRefusesWith503) {
  WhepLimits limits;
  limits.max_sessions = 2;
  EXPECT_EQ(check_whep_request(post("t"), "t", limits, 1).status, 201);
  EXPECT_EQ(check_whep_request(post("t"), "t", limits, 2).status, 503);
}

TEST(WebrtcWhep, DeleteNamesAWellFormedSession) {
  WhepRequest r = post("t");
  r.method = "DELETE";
  r.body = "";
  r.body_size = 0;
  const std::string id = new_whep_session_id();
  r.path = std::string("/whep/") + id;
  const WhepDecision d = check_whep_request(r, "t", {}, 1);
  EXPECT_EQ(d.action, WhepAction::kLeave);
  EXPECT_EQ(d.session_id, id);
  for (const std::string& bad : {std::string("/whep/"), std::string("/whep/../x"), "/whep/" + std::string(32, 'G'),
                                 "/whep/" + id + "/x", "/whep/" + id.substr(1)}) {
    r.path = bad;
    EXPECT_EQ(check_whep_request(r, "t", {}, 1).status, 404) << bad;
  }
}

TEST(WebrtcWhep, SessionIdsAreWellFormedAndDistinct) {
  std::set<std::string> ids;
  for (int i = 0; i < 200; ++i) {
    const std::string id = new_whep_session_id();
    EXPECT_TRUE(is_whep_session_id(id)) << id;
    ids.insert(id);
  }
  EXPECT_EQ(ids.size(), 200u);
}

TEST(WebrtcWhep, SessionTableHoldsAtMostItsCapacity) {
  WhepSessionTable table(2);
  EXPECT_TRUE(table.add("a"));
  EXPECT_FALSE(table.add("a"));
  EXPECT_TRUE(table.add("b"));
  EXPECT_FALSE(table.add("c"));
  EXPECT_EQ(table.size(), 2u);
  ASSERT_NE(table.find("a"), nullptr);
  EXPECT_TRUE(table.remove("a"));
  EXPECT_FALSE(table.remove("a"));
  EXPECT_EQ(table.find("a"), nullptr);
  EXPECT_TRUE(table.add("c"));
}

TEST(WebrtcPoseMessage, RoundTripsThroughTheWireFormatAndThePoseEvent) {
  Pose p;
  p.position = Eigen::Vector3d(0.25, -0.5, 1.5);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0).normalized()));
  p.seq = 41;
  p.viewer_time_ns = 12'345'678'000;
  Pose q;
  std::string why;
  ASSERT_TRUE(parse_pose_message(format_pose_message(p), &q, &why)) << why;
  EXPECT_EQ(q.seq, 41u);
  EXPECT_EQ(q.viewer_time_ns, p.viewer_time_ns);
  EXPECT_NEAR((q.position - p.position).norm(), 0, 1e-12);
  EXPECT_NEAR(q.orientation.angularDistance(p.orientation), 0, 1e-9);
  // The same event the RTP pose channel sends upstream.
  GstEvent* event = pose_event_new(q);
  Pose r;
  ASSERT_TRUE(pose_event_parse(event, &r, &why)) << why;
  gst_event_unref(event);
  EXPECT_EQ(r.seq, 41u);
}

TEST(WebrtcPoseMessage, MalformedOrInvalidMessagesAreRefusedWithAReason) {
  const std::string good = "pose 1 10.5 0 0 0 0 0 0 1";
  Pose p;
  std::string why;
  ASSERT_TRUE(parse_pose_message(good, &p, &why)) << why;
  p.seq = 777;
  for (const std::string& bad :
       {std::string(), std::string("pose"), std::string("pose 1 10.5 0 0 0 0 0 0"), good + " 1", " " + good,
        good + " ", std::string("pose  1 10.5 0 0 0 0 0 0 1"), std::string("posx 1 10.5 0 0 0 0 0 0 1"),
        std::string("pose -1 10.5 0 0 0 0 0 0 1"), std::string("pose 1 -3 0 0 0 0 0 0 1"),
        std::string("pose 1 10.5 nan 0 0 0 0 0 1"), std::string("pose 1 10.5 inf 0 0 0 0 0 1"),
        std::string("pose 1 10.5 0 0 0 0 0 0 2"),       // not a unit quaternion
        std::string("pose 1 10.5 1e9 0 0 0 0 0 1"),     // absurd position
        std::string("pose 1 10.5 0x1 0 0 0 0 0 1"), std::string("pose 99999999999999999999999 1 0 0 0 0 0 0 1"),
        "pose 1 1 " + std::string(600, '0') + " 0 0 0 0 0 1"}) {
    why.clear();
    EXPECT_FALSE(parse_pose_message(bad, &p, &why)) << bad;
    EXPECT_FALSE(why.empty()) << bad;
    EXPECT_EQ(p.seq, 777u) << "a refused message must leave the pose alone";
  }
}

TEST(WebrtcPoseMessage, RandomBytesNeverParseNorCrash) {
  std::mt19937 rng(13);
  Pose p;
  std::string why;
  for (int i = 0; i < 2000; ++i) {
    std::string s(rng() % 80, ' ');
    for (char& c : s) c = static_cast<char>("pose 0123456789.-e \x01\xff"[rng() % 21]);
    if (i % 2) s = "pose " + s;
    parse_pose_message(s, &p, &why);  // must not crash nor read outside `s` (ASan)
  }
  SUCCEED();
}

TEST(WebrtcPoseMessage, EachWhepSessionIsItsOwnPoseSessionAndLatestWins) {
  PoseSession sessions;
  const std::string a = new_whep_session_id(), b = new_whep_session_id();
  Pose p;
  std::string why;
  ASSERT_TRUE(parse_pose_message("pose 5 100 0 0 0 0 0 0 1", &p, &why));
  EXPECT_TRUE(pose_verdict_obeys(sessions.offer(a, p.seq, p.viewer_time_ns, 0)));
  ASSERT_TRUE(parse_pose_message("pose 4 90 0 0 0 0 0 0 1", &p, &why));
  EXPECT_EQ(sessions.offer(a, p.seq, p.viewer_time_ns, 1), PoseVerdict::kStale);
  EXPECT_EQ(sessions.offer(b, 1, 5, 2), PoseVerdict::kOtherSession);
}

TEST(WebrtcFrameEcho, RoundTripsAndRefusesGarbage) {
  const std::string m = format_frame_echo(4294967295u, 12, 1'500'000);
  EXPECT_EQ(m, "frame 4294967295 12 1.500");
  uint32_t ts = 0;
  uint64_t seq = 0;
  double t = 0;
  ASSERT_TRUE(parse_frame_echo(m, &ts, &seq, &t));
  EXPECT_EQ(ts, 4294967295u);
  EXPECT_EQ(seq, 12u);
  EXPECT_DOUBLE_EQ(t, 1.5);
  EXPECT_FALSE(parse_frame_echo("frame 4294967296 12 1.5", &ts, &seq, &t));
  EXPECT_FALSE(parse_frame_echo("frame 1 2", &ts, &seq, &t));
  EXPECT_FALSE(parse_frame_echo("pose 1 2 3", &ts, &seq, &t));
}

// The echo names the pose as the server rendered it (after its navigation bounds) and whether it clamped
// it; what is not a usable pose is refused.
TEST(WebrtcFrameEcho, CarriesTheRenderedPoseAndTheClampedFlag) {
  Pose p;
  p.position = Eigen::Vector3d(0.2, -0.05, 1.25);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()));
  p.clamped = true;
  const std::string m = format_frame_echo(90000, 7, 2'000'000, rendered_pose_of(p));
  EXPECT_EQ(m.rfind("frame 90000 7 2.000 0.200000003 -0.0500000007 1.25 0 ", 0), 0u) << m;
  EXPECT_EQ(m.back(), '1');
  uint32_t ts = 0;
  uint64_t seq = 0;
  double t = 0;
  RenderedPose r;
  ASSERT_TRUE(parse_frame_echo(m, &ts, &seq, &t, &r)) << m;
  EXPECT_TRUE(r.known);
  EXPECT_TRUE(r.clamped);
  EXPECT_FLOAT_EQ(r.position[2], 1.25f);
  EXPECT_FLOAT_EQ(r.orientation[0], float(std::cos(0.2)));
  EXPECT_FLOAT_EQ(r.orientation[2], float(std::sin(0.2)));
  // The short form leaves the pose unknown.
  ASSERT_TRUE(parse_frame_echo("frame 1 2 3.5", &ts, &seq, &t, &r));
  EXPECT_FALSE(r.known);
  for (const char* bad : {"frame 1 2 3 0 0 0 0 0 0 1 2",          // flag neither 0 nor 1
                          "frame 1 2 3 0 0 0 0 0 0 2 0",          // not a unit quaternion
                          "frame 1 2 3 5000 0 0 0 0 0 1 0",       // 5 km away
                          "frame 1 2 3 nan 0 0 0 0 0 1 0",        // not a number
                          "frame 1 2 3 0 0 0 0 0 0 1",            // a field short
                          "frame 1 2 3 0 0 0 0 0 0 1 0 0"})       // a field too many
    EXPECT_FALSE(parse_frame_echo(bad, &ts, &seq, &t, &r)) << bad;
}

// posenav on X11: a wheel notch arrives as a press and release of button 4
// (away: forward) or 5 (towards: back), and moves like a scroll notch.
TEST(WebrtcIceServers, StunAndTurnUrisAreCheckedAndBecomeWhepLinkHeaders) {
  IceServer s;
  std::string why;
  ASSERT_TRUE(parse_ice_server("stun://stun.example.net:3478", &s, &why)) << why;
  EXPECT_EQ(ice_server_link(s), "<stun:stun.example.net:3478>; rel=\"ice-server\"");
  ASSERT_TRUE(parse_ice_server("turn://al%2Dice:pa%2Bss@[2001:db8::1]:3478", &s, &why)) << why;
  EXPECT_EQ(s.username, "al-ice");
  EXPECT_EQ(s.credential, "pa+ss");
  EXPECT_EQ(s.host, "[2001:db8::1]");
  EXPECT_EQ(ice_server_link(s), "<turn:[2001:db8::1]:3478?transport=udp>; rel=\"ice-server\"; "
                                "username=\"al-ice\"; credential=\"pa+ss\"; credential-type=\"password\"");
  ASSERT_TRUE(parse_ice_server("turns://u:p@turn.example.net:5349", &s, &why)) << why;
  EXPECT_NE(ice_server_link(s).find("<turns:turn.example.net:5349?transport=tcp>"), std::string::npos);
  for (const char* bad : {"", "stun.example.net:3478", "http://x:1", "stun://u:p@x:1", "turn://x:1", "turn://u@x:1",
                          "stun://x", "stun://x:0", "stun://x:65536", "stun://x:12a", "stun://:1", "stun://[::1:1",
                          "stun://a b:1", "turn://u:p%22@x:1", "turn://u:p%0a@x:1", "turn://u:p%2@x:1",
                          "turn://u\":p@x:1", "stun://x:1,<evil>", "turn://1700000000%3Aalice:p@x:1"})
    EXPECT_FALSE(parse_ice_server(bad, &s, &why)) << bad;
  EXPECT_FALSE(parse_ice_server(std::string(600, 'a'), &s, &why));
}

// A STUN or TURN server the element cannot use stops it at start with an error naming the property.
TEST(WebrtcIceServers, AMalformedServerIsAnErrorAtStart) {
  if (!gst_element_factory_find("whepviewsink")) GTEST_SKIP() << "the webrtc plugin is not built";
  for (const auto& [property, uri] : {std::pair<const char*, const char*>{"stun-server", "turn://u:p@x:1"},
                                      {"turn-server", "stun://x:1"}, {"turn-server", "turn://x:3478"}}) {
    GstElement* pipeline = gst_pipeline_new(nullptr);
    GstElement* sink = gst_element_factory_make("whepviewsink", nullptr);
    g_object_set(sink, "port", 0u, "token", "ice-test-token", property, uri, nullptr);
    gst_bin_add(GST_BIN(pipeline), sink);
    EXPECT_EQ(gst_element_set_state(pipeline, GST_STATE_READY), GST_STATE_CHANGE_FAILURE) << property << " " << uri;
    const std::optional<std::string> error = vctest::posted_error(pipeline);
    ASSERT_TRUE(error.has_value()) << property << " " << uri;
    EXPECT_NE(error->find(property), std::string::npos) << *error;
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);
  }
}

TEST(WebrtcWhep, OptionsNamesTheIceServersOnlyWithTheToken) {
  WhepRequest r = post("t");
  r.method = "OPTIONS";
  const WhepDecision d = check_whep_request(r, "t", WhepLimits(), 0);
  EXPECT_EQ(d.action, WhepAction::kIceServers);
  EXPECT_EQ(d.status, 204);
  EXPECT_EQ(check_whep_request(r, "other", WhepLimits(), 0).status, 401);
}

TEST(WebrtcPlayoutDelay, BytesRoundTripIn10MsStepsAndBoundsAreClamped) {
  uint8_t bytes[kPlayoutDelayBytes];
  PlayoutDelay back;
  write_playout_delay({0, 0}, bytes);
  EXPECT_EQ(bytes[0] | bytes[1] | bytes[2], 0);
  write_playout_delay({120, 1000}, bytes);  // 12 and 100 units: 0x00c 0x064
  EXPECT_EQ(bytes[0], 0x00);
  EXPECT_EQ(bytes[1], 0xc0);
  EXPECT_EQ(bytes[2], 0x64);
  ASSERT_TRUE(read_playout_delay(bytes, sizeof bytes, &back));
  EXPECT_EQ(back.min_ms, 120);
  EXPECT_EQ(back.max_ms, 1000);
  write_playout_delay({-5, 99999}, bytes);  // clamped to 0 .. 40950
  ASSERT_TRUE(read_playout_delay(bytes, sizeof bytes, &back));
  EXPECT_EQ(back.min_ms, 0);
  EXPECT_EQ(back.max_ms, kPlayoutDelayMaxMs);
  write_playout_delay({300, 100}, bytes);  // a maximum under the minimum is raised to it
  ASSERT_TRUE(read_playout_delay(bytes, sizeof bytes, &back));
  EXPECT_EQ(back.max_ms, 300);
  const uint8_t inverted[] = {0x01, 0x00, 0x05};  // min 16 units, max 5
  EXPECT_FALSE(read_playout_delay(inverted, sizeof inverted, &back));
  EXPECT_FALSE(read_playout_delay(bytes, 2, &back));
  EXPECT_FALSE(read_playout_delay(nullptr, 3, &back));
}

// Through GStreamer: where a payloader's downstream caps name the playout-delay URI, the payloader asks for
// the extension under the caps' id, gets a rtphdrextplayoutdelay (as the WHEP endpoint adds one under the
// offer's id), and every packet carries the delay its properties set.
TEST(WebrtcPlayoutDelay, APayloaderWritesItOnEveryPacketUnderTheNegotiatedId) {
  if (!gst_element_factory_find("rtphdrextplayoutdelay") || !gst_element_factory_find("x264enc"))
    GTEST_SKIP() << "needs the webrtc plugin and x264enc (gstreamer1.0-plugins-ugly)";
  GError* err = nullptr;
  GstElement* pipeline = gst_parse_launch(
      ("videotestsrc num-buffers=3 ! video/x-raw,width=320,height=240 ! x264enc ! rtph264pay name=pay mtu=600 ! "
       "application/x-rtp,extmap-9=(string)" + std::string(kPlayoutDelayUri) + " ! appsink name=out sync=false").c_str(),
      &err);
  ASSERT_TRUE(pipeline) << (err ? err->message : "");
  GstElement* pay = gst_bin_get_by_name(GST_BIN(pipeline), "pay");
  // The payloader asks for the extension when it negotiates: set its delay there.
  g_signal_connect(pay, "request-extension", G_CALLBACK(+[](GstElement*, guint id, const gchar* uri, gpointer) {
    GstElement* ext = gst_element_factory_make("rtphdrextplayoutdelay", nullptr);
    gst_rtp_header_extension_set_id(GST_RTP_HEADER_EXTENSION(ext), id);
    g_object_set(ext, "min-delay", 0, "max-delay", 100, nullptr);
    return g_strcmp0(uri, kPlayoutDelayUri) == 0 ? ext : (gst_object_unref(ext), nullptr);
  }), nullptr);
  gst_object_unref(pay);
  GstElement* out = gst_bin_get_by_name(GST_BIN(pipeline), "out");
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
  int packets = 0, with_delay = 0;
  while (GstSample* sample = gst_app_sink_pull_sample(GST_APP_SINK(out))) {
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    ASSERT_TRUE(gst_rtp_buffer_map(gst_sample_get_buffer(sample), GST_MAP_READ, &rtp));
    ++packets;
    gpointer data = nullptr;
    guint size = 0;
    PlayoutDelay delay;
    if (gst_rtp_buffer_get_extension_onebyte_header(&rtp, 9, 0, &data, &size) &&
        read_playout_delay(static_cast<const uint8_t*>(data), size, &delay) && delay.min_ms == 0 && delay.max_ms == 100)
      ++with_delay;
    gst_rtp_buffer_unmap(&rtp);
    gst_sample_unref(sample);
  }
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(out);
  gst_object_unref(pipeline);
  EXPECT_GT(packets, 3);  // several packets per frame at mtu 600
  EXPECT_EQ(with_delay, packets);
}

// The sound pads of both WHEP sinks: one `audio` (the classroom's sound in) and one `voice` (the lecturers'
// voices out) each, released and requested again, and left to the element's own disposal, which releases
// them after its children are gone (that once crashed: the release touched the disposed mixer).
TEST(WhepSound, TheSoundPadsAreRequestedOnceReleasedAndDisposedWithTheElement) {
  for (const char* factory : {"whepserversink", "whepviewsink"}) {
    GstElement* sink = gst_element_factory_make(factory, nullptr);
    if (!sink) GTEST_SKIP() << "the webrtc plugin is not built (no webrtcbin)";
    for (int round = 0; round < 2; ++round) {
      GstPad* audio = gst_element_request_pad_simple(sink, "audio");
      GstPad* voice = gst_element_request_pad_simple(sink, "voice");
      ASSERT_NE(audio, nullptr) << factory;
      ASSERT_NE(voice, nullptr) << factory;
      EXPECT_EQ(GST_PAD_DIRECTION(audio), GST_PAD_SINK);
      EXPECT_EQ(GST_PAD_DIRECTION(voice), GST_PAD_SRC);
      {
        // GStreamer itself complains (a critical) when a pad of the asked name exists; what the element
        // does is what is tested, and the noise is kept out of the program's output.
        const guint quiet = g_log_set_handler(
            "GStreamer", G_LOG_LEVEL_CRITICAL,
            [](const gchar* domain, GLogLevelFlags level, const gchar* message, gpointer) {
              if (!message || !std::strstr(message, "already has a pad named"))
                g_log_default_handler(domain, level, message, nullptr);
            },
            nullptr);
        EXPECT_EQ(gst_element_request_pad_simple(sink, "audio"), nullptr) << "a second audio pad";
        EXPECT_EQ(gst_element_request_pad_simple(sink, "voice"), nullptr) << "a second voice pad";
        g_log_remove_handler("GStreamer", quiet);
      }
      GstCaps* caps = gst_pad_query_caps(voice, nullptr);
      EXPECT_TRUE(gst_caps_is_fixed(caps)) << factory << ": " << GST_PTR_FORMAT << caps;
      gst_caps_unref(caps);
      if (round == 0) {
        gst_element_release_request_pad(sink, audio);
        gst_element_release_request_pad(sink, voice);
      }
      gst_object_unref(audio);
      gst_object_unref(voice);
    }
    gst_object_unref(sink);  // the second round's pads go with it
  }
}

TEST(WebrtcLossRate, HighLossCutsTheRateLowLossGrowsItBackWithinTheBounds) {
  LossBasedRate rate(LossRateParams{4000, 250});
  EXPECT_EQ(rate.kbit(), 4000);
  EXPECT_EQ(rate.on_report(0.0), 4000) << "never above the element's bitrate";
  EXPECT_EQ(rate.on_report(0.40), 3200) << "40 % lost: down by 20 %";
  EXPECT_EQ(rate.on_report(0.05), 3200) << "between 2 and 10 %: held";
  EXPECT_EQ(rate.on_report(0.01), 3360) << "under 2 %: up by 5 %";
  for (int i = 0; i < 40; ++i) rate.on_report(1.0);
  EXPECT_EQ(rate.kbit(), 250) << "never below the floor";
  for (double junk : {-0.5, 1.5, std::nan(""), HUGE_VAL}) EXPECT_EQ(rate.on_report(junk), 250) << junk;
  for (int i = 0; i < 200; ++i) rate.on_report(0.0);
  EXPECT_EQ(rate.kbit(), 4000) << "a link that recovers gets the whole rate back";
}

// The link's loss is what the receiver report says, unless the browser asked for more of the packets again
// (a report counts a resent packet as received).
TEST(WebrtcLossRate, TheLinksLossIsTheReportOrTheShareAskedForAgainWhicheverIsLarger) {
  EXPECT_DOUBLE_EQ(link_loss(0.0, 20, 100), 0.2) << "all resent: the report says nothing was lost";
  EXPECT_DOUBLE_EQ(link_loss(0.3, 20, 100), 0.3) << "the report says more";
  EXPECT_DOUBLE_EQ(link_loss(0.05, 0, 0), 0.05) << "nothing sent: the report alone";
  EXPECT_DOUBLE_EQ(link_loss(0.0, 300, 100), 1.0) << "a packet asked for many times: at most all";
}

// Resent packets take at most their share of the current rate: at 1000 kbit/s and 15 %, 18750 bytes a
// second, half a second's worth at once; a slower rate gives less, time gives more back, never more than the
// bucket holds.
TEST(WebrtcRetransmitBudget, ResentPacketsTakeAtMostTheirShareOfTheRate) {
  RetransmitBudget budget(0.15);
  const int64_t s = 1000000000;
  int sent = 0;
  while (budget.admit(1000, 0, 1000)) ++sent;
  EXPECT_EQ(sent, 9) << "half a second's 9375 bytes at once";
  EXPECT_FALSE(budget.admit(1000, s / 100, 1000)) << "10 ms give back 187 bytes";
  EXPECT_TRUE(budget.admit(1000, s / 10, 1000)) << "100 ms give back 1875 bytes";
  sent = 0;
  for (int64_t t = s; t < 11 * s; t += s / 100)
    if (budget.admit(1000, t, 1000)) ++sent;
  EXPECT_NEAR(sent, 188, 10) << "over 10 s: the share of the rate, 18750 bytes a second";
  RetransmitBudget slow(0.15);
  sent = 0;
  for (int64_t t = 0; t < 10 * s; t += s / 100)
    if (slow.admit(1000, t, 250)) ++sent;
  EXPECT_NEAR(sent, 49, 6) << "a quarter of the rate, a quarter of the resending";
  EXPECT_FALSE(RetransmitBudget(0.15).admit(1, 0, 0)) << "no rate, no resending";
}

// A lecturer is gone only when no receiver report came for the timeout while frames were being sent: a
// stalled view (no frames) does not count against them, a report starts the count again, 0 never ends.
TEST(WebrtcLecturerSilence, GoneOnlyAfterTheTimeoutWhileFramesWereSent) {
  constexpr int64_t kSecond = 1000000000;
  LecturerSilence silence(15 * kSecond, 30);
  silence.start(100 * kSecond);
  for (int i = 0; i < 1000; ++i) silence.on_frame();
  EXPECT_FALSE(silence.gone(114 * kSecond)) << "before the timeout";
  EXPECT_TRUE(silence.gone(115 * kSecond));
  EXPECT_EQ(silence.silent_ns(115 * kSecond), 15 * kSecond);
  silence.on_report(116 * kSecond);
  EXPECT_FALSE(silence.gone(200 * kSecond)) << "no frame sent since the report: the view stalled, not the lecturer";
  for (int i = 0; i < 29; ++i) silence.on_frame();
  EXPECT_FALSE(silence.gone(200 * kSecond)) << "29 frames";
  silence.on_frame();
  EXPECT_TRUE(silence.gone(200 * kSecond));
  LecturerSilence never(0);
  never.start(0);
  for (int i = 0; i < 1000; ++i) never.on_frame();
  EXPECT_FALSE(never.gone(3600 * kSecond));
}

// A lecturer's send queue: frames pass while there is room; once one is dropped the rest of its GOP is
// dropped too (the decoder never gets a frame whose reference is gone), a key frame is asked for once, and
// sending resumes with the next key frame that finds room.
TEST(WebrtcSendGate, ADroppedFrameTakesTheRestOfItsGopAndAsksForOneKeyFrame) {
  GopSendGate gate;
  EXPECT_TRUE(gate.admit(true, false));
  EXPECT_TRUE(gate.admit(false, false));
  EXPECT_FALSE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.admit(false, true));  // full: dropped, and a key frame asked for
  EXPECT_TRUE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.admit(false, false));  // room again, but this frame refers to the dropped one
  EXPECT_FALSE(gate.admit(false, false));
  EXPECT_FALSE(gate.take_key_frame_request());  // asked once per run
  EXPECT_TRUE(gate.waiting_for_key_frame());
  EXPECT_TRUE(gate.admit(true, false));  // the key frame: sending resumes
  EXPECT_TRUE(gate.admit(false, false));
  EXPECT_FALSE(gate.waiting_for_key_frame());
  EXPECT_EQ(gate.dropped(), 3u);
}

// A lecturer whose link is not up yet (webrtcbin holds the first packet until DTLS is done): the queue stays
// full past the key frame asked for; when it has room again the gate asks once more instead of waiting for
// the next GOP, and resumes with that key frame.
TEST(WebrtcSendGate, AKeyFrameThatFoundNoRoomIsAskedForAgainWhenThereIsRoom) {
  GopSendGate gate;
  EXPECT_FALSE(gate.admit(false, true));
  EXPECT_TRUE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.admit(true, true));  // the key frame asked for: still no room
  EXPECT_FALSE(gate.admit(false, true));
  EXPECT_FALSE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.admit(false, false));  // room now: ask again
  EXPECT_TRUE(gate.take_key_frame_request());
  EXPECT_FALSE(gate.admit(false, false));
  EXPECT_FALSE(gate.take_key_frame_request());
  EXPECT_TRUE(gate.admit(true, false));
  EXPECT_EQ(gate.dropped(), 5u);
}

TEST(PoseNavWheel, X11WheelButtonsMoveForwardAndBack) {
  GstHarness* h = gst_harness_new_parse("posenav");
  gst_harness_set_src_caps_str(h, "video/x-raw,format=RGB,width=8,height=8,framerate=30/1");
  gst_buffer_unref(gst_harness_push_and_pull(h, gst_harness_create_buffer(h, 8 * 8 * 3)));
  auto next_pose = [&](Pose* p) {
    while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
      const bool pose = is_pose_event(ev);
      std::string err;
      if (pose) {
        EXPECT_TRUE(pose_event_parse(ev, p, &err)) << err;
      }
      gst_event_unref(ev);
      if (pose) return true;
    }
    return false;
  };
  Pose p;
  ASSERT_TRUE(next_pose(&p));  // the start pose
  EXPECT_NEAR(p.position.z(), 0, 1e-12);
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_button_press(4, 10, 10, GST_NAVIGATION_MODIFIER_NONE)));
  ASSERT_TRUE(next_pose(&p));
  EXPECT_NEAR(p.position.z(), -0.1, 1e-12);  // the level reference looks along -Z: forward
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_button_release(4, 10, 10, GST_NAVIGATION_MODIFIER_NONE)));
  EXPECT_FALSE(next_pose(&p));  // swallowed, nothing new
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(gst_harness_push_upstream_event(
        h, gst_navigation_event_new_mouse_button_press(5, 10, 10, GST_NAVIGATION_MODIFIER_NONE)));
  Pose last = p;
  while (next_pose(&p)) last = p;
  EXPECT_NEAR(last.position.z(), 0.2, 1e-12);
  gst_harness_teardown(h);
}

namespace {

// What a browser script printed and whether it exited 0; `skip` says why it could not run.
struct BrowserRun {
  std::string skip, output;
  bool ok = false;
};

std::string browser_dir() {
  const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
  return std::string(source_dir ? source_dir : ".") + "/tests/browser";
}

// Why the browser tests cannot run here ("" when they can).
std::string browser_skip_reason() {
  const char* chromium = g_getenv("CHROMIUM") ? g_getenv("CHROMIUM") : "/usr/bin/chromium";
  gchar* node = g_find_program_in_path("node");
  const bool have = node && g_file_test(chromium, G_FILE_TEST_IS_EXECUTABLE) &&
                    g_file_test((browser_dir() + "/node_modules/puppeteer-core").c_str(), G_FILE_TEST_IS_DIR);
  g_free(node);
  if (!have) return std::string("needs node, ") + chromium + " and tests/browser/node_modules (scripts/setup.sh runs npm ci)";
  if (!gst_element_factory_find("webrtcbin") || !gst_element_factory_find("whepserversink"))
    return "needs webrtcbin (gstreamer1.0-plugins-bad, gstreamer1.0-nice) and the webrtc plugin";
  return "";
}

// `node tests/browser/<script> <base> <args...>` against a server running at `base`: what it printed, and
// whether it exited 0.
BrowserRun run_node_script(const std::string& script, const std::string& base, const std::vector<std::string>& args) {
  BrowserRun run;
  const std::string dir = browser_dir(), script_path = dir + "/" + script;
  gchar* node = g_find_program_in_path("node");
  std::vector<const gchar*> argv = {node, script_path.c_str(), base.c_str()};
  for (const std::string& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);
  gchar* output = nullptr;
  gchar* errors = nullptr;  // the script's "FAIL ..." line goes there: kept with the output
  gint status = 0;
  GError* err = nullptr;
  // Node and Chromium are not ours: no sanitizer runtime preloaded into them (the sanitizer build's env).
  gchar** browser_env = g_environ_unsetenv(g_get_environ(), "LD_PRELOAD");
  const gboolean spawned = g_spawn_sync(dir.c_str(), const_cast<gchar**>(argv.data()), browser_env, G_SPAWN_DEFAULT,
                                        nullptr, nullptr, &output, &errors, &status, &err);
  g_strfreev(browser_env);
  g_free(node);
  EXPECT_TRUE(spawned) << (err ? err->message : "");
  g_clear_error(&err);
  run.output = std::string(output ? output : "") + (errors ? errors : "");
  g_free(output);
  g_free(errors);
  run.ok = spawned && g_spawn_check_wait_status(status, nullptr);
  // On standard error as well: a CI log that keeps only the start of it then shows why the script failed.
  if (!run.ok) std::fprintf(stderr, "%s failed:\n%s\n", script.c_str(), run.output.c_str());
  return run;
}

// Runs `gst-launch-1.0 <server>` (with {PORT} replaced by a free TCP port) as a process of its own (webrtcbin
// 1.22 keeps its ICE and DTLS agents alive past gst_deinit(), which this program's leaks tracer would count
// as ours), then `node tests/browser/<script> http://127.0.0.1:PORT <args...>`, then stops the server. The
// server gets `server_env` besides this program's environment, and `preload` after what this program
// preloads (the sanitizer build's runtime).
BrowserRun run_browser_script(const std::string& server, const std::string& script, const std::vector<std::string>& args,
                              const std::vector<std::pair<std::string, std::string>>& server_env = {},
                              const std::string& preload = "") {
  BrowserRun run;
  run.skip = browser_skip_reason();
  if (!run.skip.empty()) return run;
  GError* err = nullptr;
  const int port = vctest::free_tcp_port();
  std::string launch = "gst-launch-1.0 " + server;
  launch.replace(launch.find("{PORT}"), 6, std::to_string(port));
  gchar** server_argv = nullptr;
  EXPECT_TRUE(g_shell_parse_argv(launch.c_str(), nullptr, &server_argv, &err));
  gchar** env = g_get_environ();
  for (const auto& [key, value] : server_env) env = g_environ_setenv(env, key.c_str(), value.c_str(), TRUE);
  if (!preload.empty()) {
    const gchar* before = g_environ_getenv(env, "LD_PRELOAD");
    env = g_environ_setenv(env, "LD_PRELOAD", (before ? std::string(before) + ":" + preload : preload).c_str(), TRUE);
  }
  GPid server_pid = 0;
  const gboolean started =
      g_spawn_async(nullptr, server_argv, env,
                    GSpawnFlags(G_SPAWN_SEARCH_PATH | G_SPAWN_DO_NOT_REAP_CHILD | G_SPAWN_STDOUT_TO_DEV_NULL), nullptr,
                    nullptr, &server_pid, &err);
  g_strfreev(server_argv);
  g_strfreev(env);
  EXPECT_TRUE(started) << (err ? err->message : "");
  g_clear_error(&err);
  if (!started) return run;
  const BrowserRun browser = run_node_script(script, "http://127.0.0.1:" + std::to_string(port), args);
  kill(server_pid, SIGTERM);
  waitpid(server_pid, nullptr, 0);
  g_spawn_close_pid(server_pid);
  run.output = browser.output;
  run.ok = browser.ok;
  return run;
}

// The classroom's rig (optionally at a smaller size) with navigation bounds around its centre camera (at the
// rig origin, looking 20° down): the page's first view (the origin, level) is inside; a headset 0.3 m to the
// right is not.
std::string bounded_classroom_rig(const vctest::TempDir& dir, int width, int height) {
  Rig rig = default_classroom_rig();
  for (CameraCalib& c : rig.cameras) c = scale_camera(c, width, height);
  NavigationBounds bounds;
  bounds.reference_camera = 0;
  bounds.min = {-0.2, -0.3, -0.5, -60, -10, -20};
  bounds.max = {0.2, 0.3, 0.5, 60, 30, 20};
  rig.navigation = bounds;
  const std::string path = dir / "rig.yaml";
  save_rig(rig, path);
  return path;
}

}  // namespace

// The whole path in a real browser: the synthetic classroom rendered through viewfuse into whepserversink,
// headless Chromium driven by tests/browser/lecturer-test.mjs (puppeteer-core): a wrong token
// gets 401 and nothing else; the page joins (its first join lost on the way: it sends it again) and frames
// decode at 960x540; a
// scripted drag sends poses whose seq comes back with the frames and changes
// the picture; a drag past the server's navigation bounds stops at the edge;
// the XR frame loop's pose path (onXRPose) with a scripted headset pose does
// the same. The script waits on page conditions, not sleeps.
TEST(WebrtcBrowser, ChromiumJoinsDragsStopsAtTheBoundsAndTheXRPosePathMovesTheView) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 960, 540);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const BrowserRun run = run_browser_script(
      "rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! viewwarp rig=" + rig +
          " ! queue ! f.cam_0 viewfuse name=f rig=" + rig +
          " ! whepserversink port={PORT} token=secret-token web-root=" + web,
      "lecturer-test.mjs", {"secret-token", "960", "540"});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok wrong token: 401", "ok joined after a join lost on the way, frames 960x540",
                            "ok playout delay answered", "ok first view:", "ok panel:", "ok drag:", "ok level:",
                            "ok idle:", "ok soft stop:", "ok XR pose:", "ok XR eyes:", "latency samples, none negative",
                            "ok left:"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  std::printf("%s", run.output.c_str());
}

// A server none of whose cameras sends: the page joins and says no camera is sending instead of showing a
// black view that only says "joined" (tests/browser/no-camera-test.mjs); viewfuse says so on the bus
// (CameraLivenessElement.AViewNoCameraEverSentToSaysSo).
TEST(WebrtcBrowser, APageWithoutCamerasSaysNoCameraIsSending) {
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const BrowserRun run = run_browser_script(
      "appsrc is-live=true format=time ! viewfuse ! whepserversink port={PORT} token=secret-token web-root=" + web,
      "no-camera-test.mjs", {"secret-token"});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  EXPECT_NE(run.output.find("ok no camera:"), std::string::npos) << run.output;
  std::printf("%s", run.output.c_str());
}

// Several lecturers at once through whepviewsink: two pages each get their own view (poses 0.2 m apart show
// different pictures, and each page's echo names its own pose); a third is refused with 503 while two
// watch; when one leaves, the other goes on and a new page joins in the freed place.
TEST(WebrtcBrowser, TwoLecturersGetTheirOwnViewsAndALeaverFreesItsPlace) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 320, 180);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const BrowserRun run = run_browser_script(
      "whepviewsink name=w port={PORT} token=secret-token max-sessions=2 rig=" + rig + " navigation-rig=" + rig +
          " web-root=" + web + " rgbdtestsrc camera-id=0 is-live=true rig=" + rig +
          " ! learnerseg ! w.cam_0 rgbdtestsrc camera-id=1 is-live=true rig=" + rig + " ! learnerseg ! w.cam_1",
      "lecturers-test.mjs", {"secret-token", "320", "180"});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok two joined", "ok own views:", "ok third refused: 503", "ok one left, the other goes on",
                            "ok a new page joined in the freed place"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  std::printf("%s", run.output.c_str());
}

// The headset path on an emulated headset (tests/browser/xr-test.mjs: the WebXR emulation runtime iwer, a
// Meta Quest 3 with both eyes, installed into the page by the test): the page enters immersive-vr by its
// button and hides its panel, a scripted head path reaches the server and comes back rendered for the head,
// both eyes' viewports of the XR layer show the received frame, pose to photon is measured on that path, and
// leaving VR brings the page back to the mouse. Nothing of this was tried on a real headset.
TEST(XrBrowser, AnEmulatedHeadsetSteersTheViewAndSeesItInBothEyes) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 320, 180);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  if (access((browser_dir() + "/node_modules/iwer/build/iwer.min.js").c_str(), R_OK) != 0)
    GTEST_SKIP() << "no iwer in tests/browser/node_modules (scripts/setup.sh installs it with npm)";
  const BrowserRun run = run_browser_script(
      "rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! viewwarp rig=" + rig +
          " ! queue ! f.cam_0 viewfuse name=f rig=" + rig +
          " ! whepserversink port={PORT} token=secret-token web-root=" + web,
      "xr-test.mjs", {"secret-token"});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok entered immersive-vr", "ok head path:", "ok both eyes show the view",
                            "ok pose to photon in VR:", "ok left VR:"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  std::printf("%s", run.output.c_str());
}

// Sound both ways (tests/browser/audio-test.mjs): whepviewsink's audio pad (a test tone coded as Opus) goes
// to every session whose offer takes Opus, and Chromium receives, decodes and plays it; the page's microphone
// (Chromium's fake capture device, a beep) comes out of the voice pad, mixed, into a file the test reads back;
// a lecturer who refuses the microphone keeps the view and the sound and is told the class does not hear them.
TEST(AudioBrowser, TheClassroomAndTheLecturerHearEachOther) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 320, 180);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const std::string voice = dir / "voice.raw";
  const BrowserRun run = run_browser_script(
      "whepviewsink name=w port={PORT} token=secret-token rig=" + rig + " web-root=" + web +
          " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! w.cam_0" +
          " audiotestsrc is-live=true wave=sine freq=440 ! audioconvert ! opusenc ! w.audio" +
          " w.voice ! queue ! filesink buffer-mode=unbuffered location=" + voice,
      "audio-test.mjs", {"secret-token"});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok the answer sends Opus and takes the microphone", "ok sound played:", "ok voice sent:",
                            "ok microphone refused:"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  std::printf("%s", run.output.c_str());
  // The voice pad runs on the clock (silence between words) and carries the lecturer's beeps.
  const std::vector<int16_t> samples = vctest::read_s16_samples(voice);
  int loud = 0;
  for (int16_t s : samples) loud += std::abs(int(s)) > 1000;
  EXPECT_GT(samples.size(), 48000u) << "less than a second came out of the voice pad";
  EXPECT_GT(loud, 480) << "the lecturer's microphone was not heard (" << samples.size() << " samples)";
  std::printf("voice pad: %zu samples, %d above 1000\n", samples.size(), loud);
}

namespace {

// The power of `freq` Hz in samples [from, from + n) of 48 kHz audio (Goertzel), normalised by n².
double tone_power(const std::vector<int16_t>& x, size_t from, size_t n, double freq) {
  const double w = 2 * M_PI * freq / 48000.0, c = 2 * std::cos(w);
  double s1 = 0, s2 = 0;
  for (size_t i = from; i < from + n && i < x.size(); ++i) {
    const double s0 = x[i] / 32768.0 + c * s1 - s2;
    s2 = s1;
    s1 = s0;
  }
  return (s1 * s1 + s2 * s2 - c * s1 * s2) / (double(n) * double(n));
}

}  // namespace

// Two lecturers speak at once (each browser's fake microphone plays a file of its own tone: 300 Hz ticks for
// the first, 1200 Hz for the second), then the first leaves (tests/browser/two-voices-test.mjs). The voice pad
// carries both mixed, and after the first left the second alone: its voice left the mix, the rest went on.
TEST(AudioBrowser, TwoLecturersAreMixedForTheRoomAndOneWhoLeavesDropsOut) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 160, 90);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const std::string voice = dir / "voice.raw", low = dir / "low.wav", high = dir / "high.wav";
  for (const auto& [file, freq] : {std::pair{low, 300}, std::pair{high, 1200}}) {
    g_autofree gchar* launch = g_find_program_in_path("gst-launch-1.0");
    ASSERT_NE(launch, nullptr);
    const vctest::Exit made = vctest::run_tool(
        {launch, "-q", "audiotestsrc", "wave=ticks", "tick-interval=250000000", "freq=" + std::to_string(freq),
         "volume=0.8", "num-buffers=200", "!", "audio/x-raw,format=S16LE,rate=48000,channels=1", "!", "wavenc", "!",
         "filesink", "location=" + file});
    ASSERT_EQ(made.status, 0) << made.err;
  }
  const BrowserRun run = run_browser_script(
      "whepviewsink name=w port={PORT} token=secret-token rig=" + rig + " web-root=" + web +
          " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! w.cam_0" +
          " w.voice ! queue ! filesink buffer-mode=unbuffered location=" + voice,
      "two-voices-test.mjs", {"secret-token", low, high});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  EXPECT_NE(run.output.find("ok the second speaks on after the first left"), std::string::npos) << run.output;
  const std::vector<int16_t> x = vctest::read_s16_samples(voice);
  // Second by second: which tones are there (well above the other's leak into its band).
  const size_t second = 48000;
  ASSERT_GT(x.size(), 6 * second) << "less than 6 s came out of the voice pad";
  int both = 0, high_alone_after_both = 0;
  for (size_t from = 0; from + second <= x.size(); from += second) {
    const double l = tone_power(x, from, second, 300), h = tone_power(x, from, second, 1200);
    const bool has_high = h > 1e-6, high_alone = has_high && l < h / 100;
    if (l > 1e-6 && has_high && !high_alone) both += 1;
    if (both > 0 && high_alone) high_alone_after_both += 1;
  }
  EXPECT_GE(both, 2) << "the two voices were never heard together";
  EXPECT_GE(high_alone_after_both, 2) << "after the first left, the second was not heard alone";
  std::printf("voice pad: %zu s, %d s of both voices, then %d s of the second alone\n", x.size() / second, both,
              high_alone_after_both);
}

// The classroom's sound does not wait for the view: with 90 % of the camera's frames lost before the view,
// the page still gets its 50 sound packets a second, and with 5 % of the server's RTP lost on the way
// (tools/lossy_udp.cpp) the sound lost is concealed and plays on (tests/browser/audio-drops-test.mjs).
TEST(AudioBrowser, SoundKeepsFlowingWhileTheViewDropsFramesAndPacketsAreLost) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 320, 180);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const BrowserRun run = run_browser_script(
      "whepviewsink name=w port={PORT} token=secret-token rig=" + rig + " web-root=" + web +
          " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! identity drop-probability=0.9 ! learnerseg ! w.cam_0" +
          " audiotestsrc is-live=true ! audioconvert ! opusenc inband-fec=true packet-loss-percentage=10 ! w.audio",
      "audio-drops-test.mjs", {"secret-token"}, {{"VCLASSROOM_LOSS_PERCENT", "5"}},
      std::string(g_getenv("VCLASSROOM_TOOLS_DIR")) + "/liblossyudp.so");
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  EXPECT_NE(run.output.find("ok sound flows while the view drops frames"), std::string::npos) << run.output;
  std::printf("%s", run.output.c_str());
}

// The processes of process group `group` still running (not those ended and waiting to be reaped), from /proc.
std::vector<std::string> running_in_group(pid_t group) {
  std::vector<std::string> found;
  GDir* proc = g_dir_open("/proc", 0, nullptr);
  if (!proc) return found;
  while (const gchar* name = g_dir_read_name(proc)) {
    gchar* stat = nullptr;
    if (!g_ascii_isdigit(name[0]) || !g_file_get_contents((std::string("/proc/") + name + "/stat").c_str(), &stat,
                                                          nullptr, nullptr))
      continue;
    // pid (comm) state ppid pgrp ...: the fields after the last ')'.
    const std::string line = stat;
    g_free(stat);
    const size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    char state = 0;
    int ppid = 0, pgrp = 0;
    if (std::sscanf(line.c_str() + close + 1, " %c %d %d", &state, &ppid, &pgrp) == 3 && pgrp == group && state != 'Z')
      found.push_back(line.substr(0, close + 1));
  }
  g_dir_close(proc);
  return found;
}

// README's one command to a lesson: pipelines/lesson.sh starts the synthetic classroom's three cameras and
// the server as processes of their own and prints the URL; a browser opening it sees the classroom, with
// every camera's learners moving in it (tests/browser/lesson-test.mjs); Ctrl-C (SIGINT) ends every part.
TEST(Lesson, OneCommandGivesTheLecturerAMovingClassroomInTheBrowser) {
  const std::string skip = browser_skip_reason();
  if (!skip.empty()) GTEST_SKIP() << skip;
#if defined(__SANITIZE_ADDRESS__)
  // Measured: four sanitized pipelines and Chromium on two cores showed the page no moving classroom within
  // the waits' bounds (159 s). The pipelines are the ones test_flow and the WebRTC tests above run sanitized.
  GTEST_SKIP() << "not under the sanitizers: the whole lesson is too slow there (the release build runs it)";
#endif
  const std::string source = g_getenv("VCLASSROOM_SOURCE_DIR");
  const int port = vctest::free_tcp_port();
  const std::string camera_ports = std::to_string(vctest::free_udp_port()) + " " +
                                   std::to_string(vctest::free_udp_port()) + " " + std::to_string(vctest::free_udp_port());
  gchar** env = g_get_environ();
  for (const auto& [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"TOKEN", "lesson-token"}, {"WHEP_PORT", std::to_string(port)}, {"CAMERA_PORTS", camera_ports},
           {"WIDTH", "480"}, {"HEIGHT", "270"}})
    env = g_environ_setenv(env, key.c_str(), value.c_str(), TRUE);
  const std::string script = source + "/pipelines/lesson.sh";
  const gchar* argv[] = {script.c_str(), nullptr};
  GPid pid = 0;
  GError* err = nullptr;
  // In a process group of its own, as a terminal runs a command: Ctrl-C is SIGINT to the whole group.
  ASSERT_TRUE(g_spawn_async(nullptr, const_cast<gchar**>(argv), env,
                            GSpawnFlags(G_SPAWN_DO_NOT_REAP_CHILD | G_SPAWN_STDOUT_TO_DEV_NULL),
                            [](gpointer) { setpgid(0, 0); }, nullptr, &pid, &err))
      << (err ? err->message : "");
  g_strfreev(env);
  const BrowserRun run = run_node_script("lesson-test.mjs", "http://127.0.0.1:" + std::to_string(port),
                                         {"lesson-token", "480", "270"});
  kill(-pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  g_spawn_close_pid(pid);
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok joined, frames 480x270", "ok the classroom moves:"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  // lesson.sh waits for every part before it exits: nothing of the lesson is left running.
  const std::vector<std::string> left = running_in_group(pid);
  if (!left.empty()) kill(-pid, SIGKILL);
  EXPECT_TRUE(left.empty()) << "still running after lesson.sh ended: " << left.size() << ", e.g. " << left.front();
  EXPECT_TRUE(WIFEXITED(status)) << "lesson.sh did not exit by itself";
  std::printf("%s", run.output.c_str());
}

// A lecturer on a lossy link: the server drops 5 % of the video packets it sends (tools/lossy_udp.cpp
// preloaded: the datagrams never reach the socket, as on a Wi-Fi link that loses them; ICE, DTLS and RTCP
// pass). The page asks for each lost packet again (NACK) and the server sends it on the RTX stream the
// browser's offer named (webrtcbin's transceiver with do-nack), so the picture goes on: the answer names the
// RTX stream's SSRC, and the page shows 150 frames and counts retransmissions received
// (tests/browser/lossy-link-test.mjs). Without them every loss spoils the frames up to the next key frame,
// whose many packets are likely to lose one too: the same run without retransmission showed 156 frames in
// 165 s, 108 s of it frozen (docs/lecturer.md).
TEST(WebrtcBrowser, PacketsLostOnTheWayToTheLecturerAreSentAgainAndThePictureGoesOn) {
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 640, 360);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const std::string shim = std::string(g_getenv("VCLASSROOM_TOOLS_DIR")) + "/liblossyudp.so";
  ASSERT_TRUE(g_file_test(shim.c_str(), G_FILE_TEST_EXISTS)) << shim;
  const BrowserRun run = run_browser_script(
      "whepviewsink name=w port={PORT} token=secret-token rig=" + rig + " web-root=" + web +
          " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! w.cam_0",
      "lossy-link-test.mjs", {"secret-token", "150"}, {{"VCLASSROOM_LOSS_PERCENT", "5"}}, shim);
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  EXPECT_NE(run.output.find("ok repaired:"), std::string::npos) << run.output;
  std::printf("%s", run.output.c_str());
}

namespace {

// This machine's first IPv4 address that is up and not loopback ("" when none): libnice asks no STUN or TURN
// server on loopback.
std::string own_ipv4_address() {
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return "";
  std::string found;
  for (ifaddrs* a = list; a && found.empty(); a = a->ifa_next) {
    if (!a->ifa_addr || a->ifa_addr->sa_family != AF_INET || (a->ifa_flags & IFF_LOOPBACK) || !(a->ifa_flags & IFF_UP))
      continue;
    char text[INET_ADDRSTRLEN] = {};
    if (inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(a->ifa_addr)->sin_addr, text, sizeof text)) found = text;
  }
  freeifaddrs(list);
  return found;
}

}  // namespace

// A lecturer behind a NAT: whepserversink with a STUN and a TURN server (stand-ins in the test script that
// answer the real STUN messages, tests/browser/ice-test.mjs). OPTIONS on the WHEP endpoint names both as
// Link headers (TURN with its credentials) only with the token; the page's peer connection takes them; the
// server's ICE agent asks the STUN server and the TURN server, the latter with the credentials after its
// challenge. (No relay is made: the stand-in refuses the allocation.)
TEST(WebrtcBrowser, StunAndTurnServersReachTheServersIceAndThePage) {
  const std::string host = own_ipv4_address();
  if (host.empty()) GTEST_SKIP() << "no IPv4 address besides loopback (libnice asks no server on loopback)";
  const std::string stun_port = std::to_string(vctest::free_udp_port()), turn_port = std::to_string(vctest::free_udp_port());
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const BrowserRun run = run_browser_script(
      "videotestsrc is-live=true ! video/x-raw,width=320,height=180 ! whepserversink port={PORT} token=secret-token "
      "web-root=" + web + " stun-server=stun://" + host + ":" + stun_port + " turn-server=turn://alice:s3cret@" + host +
          ":" + turn_port,
      "ice-test.mjs", {"secret-token", host, stun_port, turn_port});
  if (!run.skip.empty()) GTEST_SKIP() << run.skip;
  EXPECT_TRUE(run.ok) << run.output;
  for (const char* check : {"ok OPTIONS: 204", "ok the page uses", "ok the server asked the TURN server as alice"})
    EXPECT_NE(run.output.find(check), std::string::npos) << check << " missing in:\n" << run.output;
  std::printf("%s", run.output.c_str());
}

namespace {

// Runs `script` (tests/browser/slow-link.sh, turn-relay.sh) in a network namespace of its own (unshare -rn)
// with `args`: what it printed (stdout, then stderr), and its status.
struct NamespaceRun {
  std::string output;
  gint status = 0;
};
NamespaceRun run_in_namespace(const std::string& script, const std::vector<std::string>& args) {
  const std::string path = browser_dir() + "/" + script;
  std::vector<const gchar*> argv = {"unshare", "-rn", "sh", path.c_str()};
  for (const std::string& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);
  // Node and Chromium are not ours: no sanitizer runtime preloaded into them; the server gets it back.
  gchar** env = g_get_environ();
  if (const gchar* preload = g_environ_getenv(env, "LD_PRELOAD"))
    env = g_environ_setenv(env, "VCLASSROOM_SERVER_PRELOAD", preload, TRUE);
  env = g_environ_unsetenv(env, "LD_PRELOAD");
  gchar *output = nullptr, *errors = nullptr;
  NamespaceRun run;
  GError* err = nullptr;
  if (!g_spawn_sync(browser_dir().c_str(), const_cast<gchar**>(argv.data()), env, G_SPAWN_SEARCH_PATH, nullptr,
                    nullptr, &output, &errors, &run.status, &err)) {
    run.output = std::string("unshare failed to start: ") + (err ? err->message : "");
    run.status = 77 << 8;
  }
  g_strfreev(env);
  if (output) run.output += output;
  if (errors) run.output += errors;
  g_free(output);
  g_free(errors);
  return run;
}

// Runs tests/browser/slow-link.sh with the server `server` ({PORT} its port) behind a link of `kbit` kbit/s.
NamespaceRun run_behind_slow_link(std::string server, int kbit) {
  const std::string port = std::to_string(vctest::free_tcp_port());
  server.replace(server.find("{PORT}"), 6, port);
  return run_in_namespace("slow-link.sh", {std::to_string(kbit), port, server, "slow-link-test.mjs", "secret-token"});
}

}  // namespace

// A lecturer behind a slow link: server and browser in a network namespace of their own whose loopback
// carries a few hundred kbit/s (tests/browser/slow-link.sh: unshare -rn, tc tbf), the server at its default
// 4000. The browser's receiver reports first tell of most packets lost; the session's rate comes down
// (LossBasedRate) until the page sees five seconds with under 10 % lost and at least 15 frames shown
// (tests/browser/slow-link-test.mjs). At a fixed 4000 kbit/s the loss stays and the page never settles.
// Both sinks: whepserversink's shared encoder (fed noise, which x264 cannot code below its target, so the
// link is overrun whatever this machine's speed) and whepviewsink's encoder of the lecturer's own view of
// a camera (small, so that the sanitizer build renders it fast enough to overrun its link too).
TEST(WebrtcBrowser, ALecturerBehindASlowLinkGetsTheRateTheLinkCarries) {
  const std::string skip = browser_skip_reason();
  if (!skip.empty()) GTEST_SKIP() << skip;
  vctest::TempDir dir;
  const std::string rig = bounded_classroom_rig(dir, 320, 180);
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const std::pair<std::string, int> servers[] = {
      {"videotestsrc is-live=true pattern=snow ! video/x-raw,width=640,height=360,framerate=30/1 ! "
       "whepserversink port={PORT} token=secret-token web-root=" + web, 1000},
      {"whepviewsink name=w port={PORT} token=secret-token rig=" + rig + " web-root=" + web +
           " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! w.cam_0", 400}};
  for (const auto& [server, kbit] : servers) {
    const NamespaceRun run = run_behind_slow_link(server, kbit);
    const std::string& out = run.output;
    if (WIFEXITED(run.status) && WEXITSTATUS(run.status) == 77) GTEST_SKIP() << out;
    if (out.find("unshare failed") != std::string::npos) GTEST_SKIP() << "no user namespaces here: " << out;
    EXPECT_TRUE(g_spawn_check_wait_status(run.status, nullptr)) << server << "\n" << out;
    EXPECT_NE(out.find("ok settled"), std::string::npos) << server << "\n" << out;
    // The server's side: a report of heavy loss, and the rate down to half of 4000 or less (the encoder's
    // output may fall well below its target on this simple picture, so the page may settle before the
    // target reaches the link's 1000).
    double worst_loss = 0;
    int lowest_kbit = 1 << 30;
    for (size_t at = out.find("vclassroom-lecturer-bitrate"); at != std::string::npos;
         at = out.find("vclassroom-lecturer-bitrate", at + 1)) {
      const size_t k = out.find("kbit=(int)", at), f = out.find("fraction-lost=(double)", at);
      if (k != std::string::npos) lowest_kbit = std::min(lowest_kbit, std::atoi(out.c_str() + k + 10));
      if (f != std::string::npos) worst_loss = std::max(worst_loss, std::atof(out.c_str() + f + 22));
    }
    EXPECT_GT(worst_loss, 0.10) << out;
    EXPECT_LE(lowest_kbit, 2000) << out;
    std::printf("%s", out.c_str());
  }
}

// A lecturer with no route to the server, as behind two NATs that map no port, reaches it through a real TURN
// server (coturn's turnserver): tests/browser/turn-relay.sh puts server and browser in network namespaces of
// their own that reach only a middle one, which runs the TURN server and passes the page's HTTP on. The page
// takes the TURN server from the WHEP endpoint's OPTIONS, whepserversink's ICE agent from turn-server, and the
// page shows frames over a candidate pair with a relayed side. Skips, saying why, without user namespaces,
// nsenter or turnserver.
TEST(WebrtcBrowser, ALecturerWithNoRouteToTheServerIsRelayedByATurnServer) {
  const std::string skip = browser_skip_reason();
  if (!skip.empty()) GTEST_SKIP() << skip;
  const std::string web = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/web/lecturer";
  const std::string port = "8080";  // the namespaces' own
  const NamespaceRun run = run_in_namespace(
      "turn-relay.sh", {port,
                        "videotestsrc is-live=true ! video/x-raw,width=320,height=180 ! whepserversink port=" + port +
                            " token=secret-token web-root=" + web + " turn-server=turn://alice:s3cret@10.1.0.1:3478",
                        "turn-relay-test.mjs", "secret-token"});
  if (WIFEXITED(run.status) && WEXITSTATUS(run.status) == 77) GTEST_SKIP() << run.output;
  if (run.output.find("unshare failed") != std::string::npos) GTEST_SKIP() << "no user namespaces here: " << run.output;
  EXPECT_TRUE(g_spawn_check_wait_status(run.status, nullptr)) << "wait status " << run.status << ":\n" << run.output;
  EXPECT_NE(run.output.find("ok relayed"), std::string::npos) << run.output;
  std::printf("%s", run.output.c_str());
}

namespace {

// POSTs to the WHEP endpoint at `port` a browser's offer as webrtcbin needs it (ICE credentials, a DTLS
// fingerprint) from a peer that never connects: the session's view is built and fed as soon as the answer is
// made, and no receiver report ever comes. Returns the response's status line.
// `pt` replaces the H.264 payload type 102 (a hostile offer's).
std::string post_dead_offer(guint port, const std::string& token, const std::string& pt = "102") {
  std::string offer =
      "v=0\r\no=- 1 2 IN IP4 127.0.0.1\r\ns=-\r\nt=0 0\r\na=group:BUNDLE 0\r\nm=video 9 UDP/TLS/RTP/SAVPF " + pt + "\r\n"
      "c=IN IP4 0.0.0.0\r\na=ice-ufrag:dead\r\na=ice-pwd:deadpeertestpassword0000\r\n"
      "a=fingerprint:sha-256 ";
  for (int i = 0; i < 32; ++i) offer += (i ? ":" : "") + std::string("A5");
  offer += "\r\na=setup:actpass\r\na=mid:0\r\na=recvonly\r\na=rtcp-mux\r\na=rtpmap:" + pt + " H264/90000\r\n"
           "a=fmtp:" + pt + " level-asymmetry-allowed=1;packetization-mode=1;profile-level-id=42e01f\r\n";
  return vctest::first_response_line(
      int(port), false, "POST /whep?token=" + token + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
      "application/sdp\r\nContent-Length: " + std::to_string(offer.size()) + "\r\nConnection: close\r\n\r\n" + offer);
}

// The elements of `bin` (not recursing) made by `factory`.
std::set<GstElement*> elements_made_by(GstElement* bin, const char* factory) {
  std::set<GstElement*> found;
  GstIterator* it = gst_bin_iterate_elements(GST_BIN(bin));
  GValue v = G_VALUE_INIT;
  while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
    GstElement* e = GST_ELEMENT(g_value_get_object(&v));
    GstElementFactory* f = gst_element_get_factory(e);
    if (f && g_strcmp0(GST_OBJECT_NAME(f), factory) == 0) found.insert(e);
    g_value_reset(&v);
  }
  g_value_unset(&v);
  gst_iterator_free(it);
  return found;
}

// A death-test child's failure: says why on stderr and exits 1.
// Counts the buffers leaving an element's src pad (a probe, from the streaming thread); wait_for() waits,
// bounded, for a number of them. Lives as long as the child process that uses it.
struct FrameCounter {
  GMutex lock;
  GCond cond;
  int frames = 0;
  FrameCounter() {
    g_mutex_init(&lock);
    g_cond_init(&cond);
  }
  void attach(GstElement* element) {
    GstPad* pad = gst_element_get_static_pad(element, "src");
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, [](GstPad*, GstPadProbeInfo*, gpointer data) {
      FrameCounter* c = static_cast<FrameCounter*>(data);
      g_mutex_lock(&c->lock);
      ++c->frames;
      g_cond_signal(&c->cond);
      g_mutex_unlock(&c->lock);
      return GST_PAD_PROBE_OK;
    }, this, nullptr);
    gst_object_unref(pad);
  }
  // How many had come when `n` had, or `seconds` passed.
  int wait_for(int n, int seconds) {
    const gint64 deadline = g_get_monotonic_time() + seconds * G_TIME_SPAN_SECOND;
    g_mutex_lock(&lock);
    while (frames < n && g_cond_wait_until(&cond, &lock, deadline)) {
    }
    const int seen = frames;
    g_mutex_unlock(&lock);
    return seen;
  }
};

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "%s\n", why.c_str());
  _exit(1);
}

// For the death tests' children: a playing whepviewsink `w` (with `properties`) fed by live camera 0 of the
// classroom at 320x180.
struct ViewsChild {
  vctest::TempDir dir;
  std::string rig = bounded_classroom_rig(dir, 320, 180);
  GstElement* pipeline = nullptr;
  GstElement* sink = nullptr;
  guint port = 0;
  explicit ViewsChild(const std::string& properties) {
    GError* err = nullptr;
    pipeline = gst_parse_launch(("whepviewsink name=w port=0 " + properties + " rig=" + rig +
                                 " rgbdtestsrc camera-id=0 is-live=true rig=" + rig + " ! learnerseg ! w.cam_0")
                                    .c_str(),
                                &err);
    if (!pipeline) fail(err ? err->message : "no pipeline");
    sink = gst_bin_get_by_name(GST_BIN(pipeline), "w");
    if (gst_element_set_state(pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) fail("not playing");
    g_object_get(sink, "bound-port", &port, nullptr);
  }
};

// The child's side of ALecturerWhoFallsSilentIsEndedAndTheirViewFreed: exits 0 once the endpoint has ended
// the session of a lecturer who never sent a receiver report, with a warning, and taken its view away.
[[noreturn]] void silent_lecturer_child() {
  ViewsChild child("token=silent-token lecturer-timeout=1");
  GstElement* sink = child.sink;
  GstBus* bus = gst_element_get_bus(child.pipeline);
  const std::string status = post_dead_offer(child.port, "silent-token");
  if (status != "HTTP/1.1 201 Created") fail("the offer got " + status);
  guint sessions = 0;
  g_object_get(sink, "sessions", &sessions, nullptr);
  if (sessions != 1 || elements_made_by(sink, "viewwarp").size() != 1)
    fail("after joining: " + std::to_string(sessions) + " sessions, " +
         std::to_string(elements_made_by(sink, "viewwarp").size()) + " warps");
  GstMessage* m =
      gst_bus_timed_pop_filtered(bus, 60 * GST_SECOND, GstMessageType(GST_MESSAGE_WARNING | GST_MESSAGE_ERROR));
  if (!m || GST_MESSAGE_TYPE(m) != GST_MESSAGE_WARNING)
    fail(m ? "an error came instead of the warning" : "no warning in 60 s");
  GError* warning = nullptr;
  gst_message_parse_warning(m, &warning, nullptr);
  const std::string text = warning->message;
  g_error_free(warning);
  gst_message_unref(m);
  if (text.find("is gone") == std::string::npos) fail("another warning: " + text);
  g_object_get(sink, "sessions", &sessions, nullptr);
  if (sessions != 0) fail("the session is still there after: " + text);
  if (elements_made_by(sink, "viewwarp").size() != 0) fail("the view is still there after: " + text);
  std::fprintf(stderr, "ended: %s\n", text.c_str());
  _exit(0);  // webrtcbin 1.22 outlives gst_deinit(): no teardown for the leaks tracer to count
}

// The child's side of ACameraLinkedWhileALecturerWatchesJoinsTheirView: exits 0 once camera 1, linked after
// the lecturer joined, has frames warped into that lecturer's view; 1 otherwise, saying why on stderr.
[[noreturn]] void late_camera_child() {
  ViewsChild child("token=late-camera-token background-memory=4");
  GstElement *pipeline = child.pipeline, *sink = child.sink;
  const std::string& rig = child.rig;
  const guint port = child.port;
  GError* err = nullptr;
  const std::string status = post_dead_offer(port, "late-camera-token");
  if (status != "HTTP/1.1 201 Created") fail("the offer got " + status);
  auto warps = [&] { return elements_made_by(sink, "viewwarp"); };
  const std::set<GstElement*> before = warps(), preps_before = elements_made_by(sink, "viewprep");
  if (before.size() != 1) fail("the view has " + std::to_string(before.size()) + " warps, not 1");
  // Camera 1 is linked now, while the lecturer watches.
  GstElement* camera = gst_parse_bin_from_description(
      ("rgbdtestsrc camera-id=1 is-live=true rig=" + rig + " ! learnerseg").c_str(), TRUE, &err);
  if (!camera) fail(err ? err->message : "no camera 1");
  gst_bin_add(GST_BIN(pipeline), camera);
  GstPad* cam_pad = gst_element_request_pad_simple(sink, "cam_1");
  GstPad* camera_src = gst_element_get_static_pad(camera, "src");
  if (!cam_pad || gst_pad_link(camera_src, cam_pad) != GST_PAD_LINK_OK) fail("cam_1 not linked");
  GstElement* added = nullptr;
  for (GstElement* e : warps())
    if (!before.count(e)) added = e;
  if (!added) fail("no viewwarp was added for camera 1");
  // The camera's memory is kept once for every view, by the viewprep before its tee.
  GstElement* prep = nullptr;
  for (GstElement* e : elements_made_by(sink, "viewprep"))
    if (!preps_before.count(e)) prep = e;
  if (!prep) fail("no viewprep was added for camera 1");
  gint memory = 0;
  g_object_get(prep, "background-memory", &memory, nullptr);
  if (memory != 4) fail("camera 1's viewprep has a background memory of " + std::to_string(memory) + ", not 4");
  FrameCounter seen;
  seen.attach(added);
  gst_element_sync_state_with_parent(camera);
  const int frames = seen.wait_for(3, 60);
  if (frames < 3) fail("camera 1's viewwarp warped " + std::to_string(frames) + " frames in 60 s");
  std::fprintf(stderr, "camera 1 reached the view: %d frames warped\n", frames);
  _exit(0);  // webrtcbin 1.22 outlives gst_deinit(): no teardown for the leaks tracer to count
}

// The child of AnOfferWithAnOutOfRangePayloadTypeIsRefusedAndTheRestGoesOn: a lecturer joins, then offers
// naming H.264 on payload types 200 and 99999 (7 bits in RTP) are refused 400; the lecturer's session stays
// and leaves normally, and no error reaches the bus (before, such an offer stopped the whole pipeline).
[[noreturn]] void bad_payload_child() {
  ViewsChild child("token=bad-pt-token");
  GstBus* bus = gst_element_get_bus(child.pipeline);
  std::string status = post_dead_offer(child.port, "bad-pt-token");
  if (status != "HTTP/1.1 201 Created") fail("the good offer got " + status);
  for (const char* pt : {"200", "99999", "-5"}) {
    status = post_dead_offer(child.port, "bad-pt-token", pt);
    if (status != "HTTP/1.1 400 Bad Request") fail(std::string("payload type ") + pt + " got " + status);
  }
  guint sessions = 0;
  g_object_get(child.sink, "sessions", &sessions, nullptr);
  if (sessions != 1) fail("after the bad offers: " + std::to_string(sessions) + " sessions");
  // The camera's frames still reach the lecturer's view: its warp keeps warping.
  std::set<GstElement*> warps = elements_made_by(child.sink, "viewwarp");
  if (warps.size() != 1) fail("the view has " + std::to_string(warps.size()) + " warps");
  GstElement* warp = *warps.begin();
  FrameCounter seen;
  seen.attach(warp);
  const int frames = seen.wait_for(3, 60);
  if (frames < 3) fail("the view warped " + std::to_string(frames) + " frames after the bad offers");
  GstMessage* error = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR);
  if (error) {
    GError* e = nullptr;
    gst_message_parse_error(error, &e, nullptr);
    fail(std::string("an error on the bus: ") + e->message);
  }
  std::fprintf(stderr, "refused, the session went on: %d frames\n", frames);
  _exit(0);  // webrtcbin 1.22 outlives gst_deinit(): no teardown for the leaks tracer to count
}

}  // namespace

// whepviewsink: a camera linked while a lecturer watches joins that lecturer's view (a viewwarp for it, fed
// from its tee at once, its viewprep with the sink's settings such as background-memory); before, the views went on
// without it. The lecturer never finishes the DTLS
// handshake here, so this also holds that such a session does not stop its view's encoder (the send queue
// answers the encoder's serialized queries). In a child process of its own (gtest's threadsafe death-test
// style): the session's webrtcbin outlives gst_deinit() in GStreamer 1.22.
TEST(WebrtcViewsDeathTest, ACameraLinkedWhileALecturerWatchesJoinsTheirView) {
  for (const char* factory : {"whepviewsink", "webrtcbin", "x264enc"})
    if (!gst_element_factory_find(factory)) GTEST_SKIP() << "needs " << factory;
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(late_camera_child(), testing::ExitedWithCode(0), "camera 1 reached the view");
}

// A lecturer whose browser sends no receiver report while their view is sent (here a peer that never
// connects; as well a closed laptop or a lost network) is gone after lecturer-timeout: the session is ended
// with a warning, its place under the cap freed and its view taken out of whepviewsink. In a child process
// (webrtcbin 1.22 outlives gst_deinit()).
TEST(WebrtcViewsDeathTest, ALecturerWhoFallsSilentIsEndedAndTheirViewFreed) {
  for (const char* factory : {"whepviewsink", "webrtcbin", "x264enc"})
    if (!gst_element_factory_find(factory)) GTEST_SKIP() << "needs " << factory;
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(silent_lecturer_child(), testing::ExitedWithCode(0), "ended: Lecturer of session");
}

// An offer whose H.264 payload type is out of RTP's 7 bits (200, 99999) is refused 400 by the library's
// offer inspection before GstSDP or webrtcbin see it; a lecturer already there keeps their view, and the
// pipeline no error. In a child process (webrtcbin 1.22 outlives gst_deinit()).
TEST(WebrtcViewsDeathTest, AnOfferWithAnOutOfRangePayloadTypeIsRefusedAndTheRestGoesOn) {
  for (const char* factory : {"whepviewsink", "webrtcbin", "x264enc"})
    if (!gst_element_factory_find(factory)) GTEST_SKIP() << "needs " << factory;
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(bad_payload_child(), testing::ExitedWithCode(0), "refused, the session went on");
}

// whepviewsink without any camera linked cannot make a view: a lecturer's well-formed offer (H.264
// constrained baseline, packetization mode 1) gets 503 and nothing is built; the token is checked first.
TEST(WebrtcViews, ALecturerBeforeAnyCameraIsRefusedWith503) {
  if (!gst_element_factory_find("whepviewsink")) GTEST_SKIP() << "the webrtc plugin is not built";
  GstElement* sink = gst_element_factory_make("whepviewsink", nullptr);
  g_object_set(sink, "port", 0u, "token", "views-test-token", nullptr);
  ASSERT_NE(gst_element_set_state(sink, GST_STATE_READY), GST_STATE_CHANGE_FAILURE);
  guint port = 0;
  g_object_get(sink, "bound-port", &port, nullptr);
  ASSERT_GT(port, 0u);
  const std::string offer =
      "v=0\r\no=- 1 1 IN IP4 127.0.0.1\r\ns=-\r\nt=0 0\r\nm=video 9 UDP/TLS/RTP/SAVPF 102\r\n"
      "c=IN IP4 0.0.0.0\r\na=mid:0\r\na=recvonly\r\na=rtpmap:102 H264/90000\r\n"
      "a=fmtp:102 level-asymmetry-allowed=1;packetization-mode=1;profile-level-id=42e01f\r\n";
  auto post = [&](const std::string& token) {
    return vctest::first_response_line(int(port), false,
                                       "POST /whep?token=" + token + " HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                       "Content-Type: application/sdp\r\nContent-Length: " +
                                           std::to_string(offer.size()) + "\r\nConnection: close\r\n\r\n" + offer);
  };
  EXPECT_EQ(post("wrong"), "HTTP/1.1 401 Unauthorized");
  EXPECT_EQ(post("views-test-token"), "HTTP/1.1 503 Service Unavailable");
  guint sessions = 1;
  g_object_get(sink, "sessions", &sessions, nullptr);
  EXPECT_EQ(sessions, 0u);
  gst_element_set_state(sink, GST_STATE_NULL);
  gst_object_unref(sink);
}

// Both WHEP sinks started and stopped at once, again and again, as a pipeline that runs a few frames and
// ends does (the documentation's example line): the stop must end the server's thread however far it got.
// Its quit once reached the thread's main loop before the loop ran and was lost, and the stop waited for
// ever (one run of the whole suite in eight or so hung there). A race, so not certain to show: with that
// code this test hung in three runs of three here (the suite's timeout then names it).
TEST(WhepEndpoint, AServerStoppedRightAfterItStartedStops) {
  for (const char* factory : {"whepserversink", "whepviewsink"}) {
    GstElement* sink = gst_element_factory_make(factory, nullptr);
    if (!sink) GTEST_SKIP() << "the webrtc plugin is not built (no webrtcbin)";
    gst_object_ref_sink(sink);
    g_object_set(sink, "port", 0u, "listen-addresses", "127.0.0.1", "token", "cycle-test-token", nullptr);
    for (int round = 0; round < 200; ++round) {
      ASSERT_EQ(gst_element_set_state(sink, GST_STATE_READY), GST_STATE_CHANGE_SUCCESS) << factory << " round " << round;
      guint port = 0;
      g_object_get(sink, "bound-port", &port, nullptr);
      ASSERT_GT(port, 0u) << factory << " round " << round;
      if (round % 50 == 0)
        EXPECT_EQ(vctest::first_response_line(port, false, "GET /?token=wrong HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                                           "Connection: close\r\n\r\n"),
                  "HTTP/1.1 401 Unauthorized")
            << factory;
      ASSERT_EQ(gst_element_set_state(sink, GST_STATE_NULL), GST_STATE_CHANGE_SUCCESS) << factory << " round " << round;
    }
    gst_object_unref(sink);
  }
}

// With tls-certificate and tls-key the page and WHEP are served over HTTPS (what browsers need for WebXR off
// localhost), the token still checked; plain HTTP gets no page; a key that does not load stops the element
// at start with an error naming the port.
TEST(WebrtcTls, CertificateFilesServeHttpsAndABadOneIsAnError) {
  if (!gst_element_factory_find("whepserversink")) GTEST_SKIP() << "the webrtc plugin is not built";
  if (!g_tls_backend_supports_tls(g_tls_backend_get_default())) GTEST_SKIP() << "GIO has no TLS backend (glib-networking)";
  const std::string data = std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) + "/tests/data/tls/";
  GstElement* pipe = gst_parse_launch(("videotestsrc is-live=true ! video/x-raw,width=64,height=48 ! whepserversink "
                                       "name=w port=0 token=tls-test-token web-root=" + std::string(g_getenv("VCLASSROOM_SOURCE_DIR")) +
                                       "/web/lecturer tls-certificate=" + data +
                                       "test-cert.pem tls-key=" + data + "test-key.pem")
                                          .c_str(),
                                      nullptr);
  ASSERT_NE(pipe, nullptr);
  ASSERT_NE(gst_element_set_state(pipe, GST_STATE_PLAYING), GST_STATE_CHANGE_FAILURE);
  GstElement* sink = gst_bin_get_by_name(GST_BIN(pipe), "w");
  guint port = 0;
  g_object_get(sink, "bound-port", &port, nullptr);
  gst_object_unref(sink);
  ASSERT_GT(port, 0u);
  const std::string host = "Host: 127.0.0.1\r\nConnection: close\r\n\r\n";
  EXPECT_EQ(vctest::first_response_line(port, true, "GET /?token=tls-test-token HTTP/1.1\r\n" + host), "HTTP/1.1 200 OK");
  EXPECT_EQ(vctest::first_response_line(port, true, "GET /?token=wrong HTTP/1.1\r\n" + host), "HTTP/1.1 401 Unauthorized");
  EXPECT_EQ(vctest::first_response_line(port, false, "GET /?token=tls-test-token HTTP/1.1\r\n" + host).rfind("HTTP/1.1 200", 0),
            std::string::npos);
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(pipe);

  // The certificate given as the key: no HTTPS server, an error instead.
  GstElement* bad = gst_parse_launch(("videotestsrc is-live=true ! whepserversink port=0 token=tls-test-token "
                                      "tls-certificate=" + data + "test-cert.pem tls-key=" + data + "test-cert.pem")
                                         .c_str(),
                                     nullptr);
  ASSERT_NE(bad, nullptr);
  EXPECT_EQ(gst_element_set_state(bad, GST_STATE_PLAYING), GST_STATE_CHANGE_FAILURE);
  const std::optional<std::string> error = vctest::posted_error(bad);
  ASSERT_TRUE(error.has_value());
  EXPECT_NE(error->find("Cannot serve WHEP on port"), std::string::npos) << *error;
  gst_element_set_state(bad, GST_STATE_NULL);
  gst_object_unref(bad);
}

// The page steers like posenav: its NAV constants (web/lecturer/lecturer.js)
// are posenav's property defaults and the paper's slider scales.
TEST(WebrtcPage, NavigationConstantsAreThoseOfPosenavAndTheSliders) {
  const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
  ASSERT_NE(source_dir, nullptr);
  gchar* js = nullptr;
  ASSERT_TRUE(g_file_get_contents((std::string(source_dir) + "/web/lecturer/lecturer.js").c_str(), &js, nullptr,
                                  nullptr));
  const std::string text = js;
  g_free(js);
  auto constant = [&](const std::string& name) {
    const size_t at = text.find("  " + name + ": ");
    EXPECT_NE(at, std::string::npos) << name;
    return at == std::string::npos ? -1.0 : g_ascii_strtod(text.c_str() + at + name.size() + 4, nullptr);
  };
  GstElement* nav = gst_element_factory_make("posenav", nullptr);
  ASSERT_NE(nav, nullptr);
  double move_step = 0, turn_speed = 0;
  g_object_get(nav, "move-step", &move_step, "turn-speed", &turn_speed, nullptr);
  gst_object_unref(nav);
  EXPECT_DOUBLE_EQ(constant("moveStep"), move_step);
  EXPECT_DOUBLE_EQ(constant("turnSpeed"), turn_speed);
  EXPECT_DOUBLE_EQ(constant("sliderMetres"), kSliderMetres);
  EXPECT_DOUBLE_EQ(constant("sliderDegrees"), kSliderDegrees);
}
