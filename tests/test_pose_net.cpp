// The net family's pose channel, without GStreamer: the wire format and its key, pose sessions, replay
// protection and what PoseChannel makes of each packet (poserecv and posesend themselves: test_network.cpp).
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <vector>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/net/pose_wire.h>

#include "test_util.h"

using namespace vclassroom;
using vctest::expect_same_pose;
using vctest::pose_with_seq;
using vctest::sample_pose;

// ---- Pose sessions (gst/vclassroom/net/pose_session.h): times are given, no sleeps.

namespace {
constexpr int64_t kMs = 1'000'000;
constexpr int64_t kFrame = 33 * kMs;  // a lecturer repeating its pose with every frame at 30 fps
}  // namespace

TEST(PoseSession, SeqFarAheadIsRejectedNeverAdopted) {
  PoseSession s;
  int64_t t = 0;
  for (uint64_t seq = 1; seq <= 5; ++seq, t += kFrame) ASSERT_TRUE(pose_verdict_obeys(s.offer("A", seq, t, t)));
  EXPECT_EQ(s.offer("A", UINT64_MAX, t, t), PoseVerdict::kAheadOfWindow);
  EXPECT_EQ(s.offer("A", 5 + s.config().seq_window + 1, t, t), PoseVerdict::kAheadOfWindow);
  EXPECT_EQ(s.last_seq(), 5u);
  // The real lecturer goes on, obeyed at once.
  for (uint64_t seq = 6; seq <= 10; ++seq, t += kFrame) EXPECT_EQ(s.offer("A", seq, t, t), PoseVerdict::kAccepted);
  EXPECT_EQ(s.offer("A", 10 + s.config().seq_window, t, t), PoseVerdict::kAccepted);  // the window's edge
  EXPECT_EQ(s.switches(), 0u);
}

TEST(PoseSession, LateRepeatedAndReorderedPosesAreNotObeyed) {
  PoseSession s;
  EXPECT_EQ(s.offer("A", 10, 100, 0), PoseVerdict::kAccepted);
  EXPECT_EQ(s.offer("A", 10, 100, kFrame), PoseVerdict::kRepeat);
  EXPECT_EQ(s.offer("A", 12, 120, 2 * kFrame), PoseVerdict::kAccepted);
  EXPECT_EQ(s.offer("A", 11, 110, 2 * kFrame), PoseVerdict::kStale);  // reordered: sampled before 12
  EXPECT_EQ(s.offer("A", 3, -1, 2 * kFrame), PoseVerdict::kStale);     // no viewer time: nothing says restart
  EXPECT_EQ(s.last_seq(), 12u);
}

TEST(PoseSession, AnotherSessionCannotStealAnAliveOne) {
  PoseSession s;
  int64_t t = 0;
  uint64_t seq = 1;
  // An idle lecturer sends only repeats of one pose: still alive.
  s.offer("A", seq, 0, t);
  for (int i = 0; i < 100; ++i) {
    t += kFrame;
    EXPECT_EQ(s.offer("B", 1000 + i, t, t), PoseVerdict::kOtherSession);
    EXPECT_EQ(s.offer("A", seq, 0, t), PoseVerdict::kRepeat);
  }
  EXPECT_EQ(s.current(), "A");
  EXPECT_EQ(s.switches(), 0u);
}

TEST(PoseSession, ASilentSessionGivesWayAfterTheTimeout) {
  PoseSessionConfig c;
  c.timeout_ns = 500 * kMs;
  PoseSession s(c);
  EXPECT_EQ(s.offer("A", 900, 0, 0), PoseVerdict::kAccepted);
  // A stops (it restarted as B, counting from 1 again).
  EXPECT_EQ(s.offer("B", 1, 1, 499 * kMs), PoseVerdict::kOtherSession);
  EXPECT_EQ(s.offer("B", 2, 2, 500 * kMs), PoseVerdict::kTookOver);
  EXPECT_EQ(s.current(), "B");
  EXPECT_EQ(s.switches(), 1u);
  EXPECT_EQ(s.offer("B", 3, 3, 510 * kMs), PoseVerdict::kAccepted);
  // The old session is now the other one.
  EXPECT_EQ(s.offer("A", 901, 4, 520 * kMs), PoseVerdict::kOtherSession);
}

TEST(PoseSession, ARestartUnderTheSameKeyIsSeenByItsViewerTime) {
  PoseSession s;
  EXPECT_EQ(s.offer("A", 500, 5'000 * kMs, 0), PoseVerdict::kAccepted);
  // seq back to 1 but sampled later: the sender restarted; obeyed at once.
  EXPECT_EQ(s.offer("A", 1, 5'100 * kMs, kFrame), PoseVerdict::kTookOver);
  EXPECT_EQ(s.offer("A", 2, 5'133 * kMs, 2 * kFrame), PoseVerdict::kAccepted);
  EXPECT_EQ(s.last_seq(), 2u);
}

TEST(PoseSession, AfterAnOutageTheLecturerIsObeyedWhereverItsSeqStands) {
  PoseSession s;
  s.offer("A", 10, 0, 0);
  // 10 s without packets; meanwhile the lecturer moved on far beyond the window.
  const uint64_t far = 10 + 10 * s.config().seq_window;
  EXPECT_EQ(s.offer("A", far, 1, 10'000 * kMs), PoseVerdict::kTookOver);
  EXPECT_EQ(s.last_seq(), far);
}

TEST(PosePlausibility, FarAwayPosesAreImplausible) {
  Pose p;
  p.position = Eigen::Vector3d(999, 0, 0);
  std::string why;
  EXPECT_FALSE(pose_is_plausible(p, 20.0, &why));
  EXPECT_NE(why.find("999 m"), std::string::npos) << why;
  p.position = Eigen::Vector3d(3, -1.5, 19);
  EXPECT_TRUE(pose_is_plausible(p, 20.0, nullptr));
}

TEST(PoseKey, LoadsRawBytesAndRejectsBadFiles) {
  vctest::TempDir dir;
  const std::string good = dir / "pose.key", short_key = dir / "short.key", huge = dir / "huge.key";
  vctest::write_text(good, std::string("0123456789abcdef0123456789abcdef"));
  vctest::write_text(short_key, "tooshort");
  vctest::write_text(huge, std::string(kPoseKeyMaxSize + 1, 'k'));
  EXPECT_EQ(load_pose_key(good).bytes.size(), 32u);
  for (const std::string& bad : {dir / "missing.key", short_key, huge}) {
    try {
      load_pose_key(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
}

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
  wire[48] ^= 0x01;  // one bit of y
  EXPECT_FALSE(pose_from_wire(wire, sizeof wire, &back, &err));
  EXPECT_NE(err.find("checksum"), std::string::npos) << err;
  // Version 1 is refused with a message that says so.
  std::memcpy(wire, "VCP1", 4);
  EXPECT_FALSE(pose_from_wire(wire, 88, &back, &err));
  EXPECT_NE(err.find("version 1"), std::string::npos) << err;
}

TEST(PoseWire, TaggedPacketsNeedTheRightKey) {
  PoseKey key, other;
  key.bytes.assign(32, 7);
  other.bytes.assign(32, 8);
  Pose p = sample_pose();
  uint8_t tagged[kPoseWireMaxSize], plain[kPoseWireMaxSize];
  ASSERT_EQ(pose_to_wire(p, tagged, 42, &key), kPoseWireMaxSize);
  ASSERT_EQ(pose_to_wire(p, plain, 42), kPoseWireSize);
  Pose back;
  std::string err;
  PoseWireInfo info;
  ASSERT_TRUE(pose_from_wire(tagged, kPoseWireMaxSize, &back, &err, &key, &info)) << err;
  expect_same_pose(back, p);
  EXPECT_EQ(info.stamp.session, 42u);
  EXPECT_TRUE(info.tagged);
  EXPECT_FALSE(pose_from_wire(tagged, kPoseWireMaxSize, &back, &err, &other, &info));
  EXPECT_EQ(info.error, PoseWireError::kUnauthenticated);
  EXPECT_FALSE(pose_from_wire(plain, kPoseWireSize, &back, &err, &key, &info));
  EXPECT_EQ(info.error, PoseWireError::kUnauthenticated);
  // Without a key, both are read (the documented risk: anyone can steer).
  EXPECT_TRUE(pose_from_wire(tagged, kPoseWireMaxSize, &back, &err));
  EXPECT_TRUE(pose_from_wire(plain, kPoseWireSize, &back, &err));
  // A flipped bit of the tag, and a tag cut short.
  tagged[kPoseWireMaxSize - 1] ^= 0x80;
  EXPECT_FALSE(pose_from_wire(tagged, kPoseWireMaxSize, &back, &err, &key, &info));
  EXPECT_EQ(info.error, PoseWireError::kUnauthenticated);
  EXPECT_FALSE(pose_from_wire(tagged, kPoseWireMaxSize - 1, &back, &err, &key, &info));
  EXPECT_EQ(info.error, PoseWireError::kDamaged);
  // A NaN pose with a right checksum and tag is invalid, not damaged.
  Pose bad = sample_pose();
  bad.position.x() = std::numeric_limits<double>::quiet_NaN();
  uint8_t nan_wire[kPoseWireMaxSize];
  pose_to_wire(bad, nan_wire, 1, &key);
  EXPECT_FALSE(pose_from_wire(nan_wire, kPoseWireMaxSize, &back, &err, &key, &info));
  EXPECT_EQ(info.error, PoseWireError::kInvalid);
}

TEST(PoseChannel, CountsEachKindAndWarnsOncePerIntervalWithTheRestAtTheEnd) {
  PoseChannelConfig c;
  c.key.bytes.assign(32, 3);
  PoseChannel ch(c);
  PoseKey wrong;
  wrong.bytes.assign(32, 4);
  uint8_t wire[kPoseWireMaxSize];
  Pose p = sample_pose();
  p.position = Eigen::Vector3d(1, 0, 2);
  p.seq = 1;
  uint64_t packet = 0;  // a sender numbers its packets (the replay window's)
  pose_to_wire(p, wire, PoseWireStamp(5, ++packet), &c.key);
  PoseChannel::Outcome o = ch.receive(wire, kPoseWireMaxSize, "ssrc 1", 0);
  EXPECT_TRUE(o.obey);
  EXPECT_TRUE(o.warning.empty());
  // Ten poses tagged with another key within a second: one warning, ten counted.
  int warnings = 0;
  for (int i = 0; i < 10; ++i) {
    p.seq = 2 + i;
    pose_to_wire(p, wire, PoseWireStamp(5, ++packet), &wrong);
    o = ch.receive(wire, kPoseWireMaxSize, "ssrc 1", i * 100 * kMs);
    EXPECT_FALSE(o.obey);
    warnings += !o.warning.empty();
  }
  EXPECT_EQ(warnings, 1);
  // A far pose and a far-ahead seq, rightly tagged; and garbage.
  Pose far = p;
  far.position = Eigen::Vector3d(0, 0, 999);
  far.seq = 20;
  pose_to_wire(far, wire, PoseWireStamp(5, ++packet), &c.key);
  EXPECT_FALSE(ch.receive(wire, kPoseWireMaxSize, "ssrc 1", kMs).obey);
  p.seq = UINT64_MAX;
  pose_to_wire(p, wire, PoseWireStamp(5, ++packet), &c.key);
  EXPECT_FALSE(ch.receive(wire, kPoseWireMaxSize, "ssrc 1", kMs).obey);
  EXPECT_FALSE(ch.receive(wire, 7, "ssrc 1", kMs).obey);
  const PoseChannelCounts n = ch.counts();
  EXPECT_EQ(n.received, 14u);
  EXPECT_EQ(n.injected, 1u);
  EXPECT_EQ(n.unauthenticated, 10u);
  EXPECT_EQ(n.implausible, 1u);
  EXPECT_EQ(n.rejected, 1u);
  EXPECT_EQ(n.damaged, 1u);
  EXPECT_EQ(ch.last_seq(), 1u);
  const std::vector<std::string> rest = ch.final_warnings();
  ASSERT_EQ(rest.size(), 1u);  // the 9 unauthenticated ones after the first message
  EXPECT_NE(rest[0].find("9 unauthenticated pose packets"), std::string::npos) << rest[0];
}

// ---- Replay-proof signed poses (ReplayGuard, PoseChannel with a key): times are given, no sleeps.

namespace {
// A signed pose packet of `session`, numbered `packet`, sent at `sent_ns`.
std::vector<uint8_t> signed_packet(const PoseKey& key, uint64_t session, uint64_t packet, int64_t sent_ns,
                                   uint64_t seq) {
  Pose p = sample_pose();
  p.position = Eigen::Vector3d(0.01 * double(seq % 50), 0, 1);
  p.seq = seq;
  p.viewer_time_ns = sent_ns;
  std::vector<uint8_t> wire(kPoseWireMaxSize);
  wire.resize(pose_to_wire(p, wire.data(), PoseWireStamp(session, packet, sent_ns), &key));
  return wire;
}
}  // namespace

TEST(PoseWire, TheTagCoversTheSessionThePacketNumberAndTheTimes) {
  PoseKey key;
  key.bytes.assign(32, 9);
  Pose p = sample_pose();
  p.seq = 77;
  p.viewer_time_ns = 123456789;
  uint8_t wire[kPoseWireMaxSize];
  ASSERT_EQ(pose_to_wire(p, wire, PoseWireStamp(0x1122334455667788ull, 42, 987654321), &key), kPoseWireMaxSize);
  Pose back;
  std::string err;
  PoseWireInfo info;
  ASSERT_TRUE(pose_from_wire(wire, kPoseWireMaxSize, &back, &err, &key, &info)) << err;
  EXPECT_EQ(info.stamp.session, 0x1122334455667788ull);
  EXPECT_EQ(info.stamp.packet, 42u);
  EXPECT_EQ(info.stamp.sent_ns, 987654321);
  EXPECT_EQ(back.seq, 77u);
  EXPECT_EQ(back.viewer_time_ns, 123456789);
  // Each field changed by someone without the key (the checksum written again, as anyone can): the tag refuses it.
  for (size_t offset : {8u, 16u, 24u, 32u, 40u}) {  // session, packet, sent time, seq, viewer time
    uint8_t forged[kPoseWireMaxSize];
    std::memcpy(forged, wire, sizeof forged);
    forged[offset] ^= 1;
    const uint32_t crc = crc32(forged, kPoseWireSize - 4);
    for (int b = 0; b < 4; ++b) forged[kPoseWireSize - 4 + b] = static_cast<uint8_t>(crc >> (8 * b));
    EXPECT_FALSE(pose_from_wire(forged, kPoseWireMaxSize, &back, &err, &key, &info)) << "byte " << offset;
    EXPECT_EQ(info.error, PoseWireError::kUnauthenticated) << "byte " << offset;
  }
  // The version before (VCP2) is named when refused.
  std::memcpy(wire, "VCP2", 4);
  EXPECT_FALSE(pose_from_wire(wire, kPoseWireMaxSize, &back, &err, &key, &info));
  EXPECT_NE(err.find("version 2"), std::string::npos) << err;
}

TEST(ReplayGuard, EachPacketNumberOnceWithinTheWindowAndNothingBelowIt) {
  ReplayGuard g;
  int64_t t = 0;
  for (uint64_t n = 1; n <= 100; ++n, t += kFrame) EXPECT_EQ(g.check(7, n, t, t), ReplayVerdict::kFresh);
  EXPECT_EQ(g.check(7, 100, t, t), ReplayVerdict::kReplayed);
  EXPECT_EQ(g.check(7, 60, t, t), ReplayVerdict::kReplayed);  // inside the window, seen
  EXPECT_EQ(g.check(7, 100 - ReplayGuard::kWindow, t, t), ReplayVerdict::kTooOld);
  EXPECT_EQ(g.check(7, 1, t, t), ReplayVerdict::kTooOld);
  // Reordering inside the window: a skipped number arriving late is taken once.
  EXPECT_EQ(g.check(7, 103, t, t), ReplayVerdict::kFresh);
  EXPECT_EQ(g.check(7, 102, t, t), ReplayVerdict::kFresh);
  EXPECT_EQ(g.check(7, 102, t, t), ReplayVerdict::kReplayed);
  EXPECT_EQ(g.check(7, 101, t, t), ReplayVerdict::kFresh);
  // A jump far ahead clears the window; what was below it is too old now.
  EXPECT_EQ(g.check(7, 10'000, t, t), ReplayVerdict::kFresh);
  EXPECT_EQ(g.check(7, 103, t, t), ReplayVerdict::kTooOld);
  // Another session has numbers of its own.
  EXPECT_EQ(g.check(8, 1, t, t), ReplayVerdict::kFresh);
  EXPECT_EQ(g.sessions(), 2u);
}

TEST(ReplayGuard, APacketHeldBackLongerThanTheLimitIsRefused) {
  ReplayGuardConfig c;
  c.max_delay_ns = 2'000 * kMs;
  ReplayGuard g(c);
  // The sender's clock runs 5000 s ahead of ours (unrelated monotonic clocks); the path takes 10-30 ms.
  const int64_t ahead = 5'000'000 * kMs;
  for (int i = 0; i < 30; ++i) {
    const int64_t sent = ahead + i * kFrame;
    EXPECT_EQ(g.check(1, uint64_t(i + 1), sent, sent - ahead + (10 + i % 3 * 10) * kMs), ReplayVerdict::kFresh);
  }
  // Packet 31 was held on the way (never delivered) and is released 2.5 s after it was sent.
  const int64_t sent31 = ahead + 30 * kFrame;
  EXPECT_EQ(g.check(1, 31, sent31, sent31 - ahead + 2'500 * kMs), ReplayVerdict::kHeldBack);
  // 1.9 s late is within the limit.
  const int64_t sent32 = ahead + 31 * kFrame;
  EXPECT_EQ(g.check(1, 32, sent32, sent32 - ahead + 1'900 * kMs), ReplayVerdict::kFresh);
  // A packet without a sending time is judged by its number alone.
  EXPECT_EQ(g.check(1, 33, -1, 1'000'000 * kMs), ReplayVerdict::kFresh);
}

TEST(ReplayGuard, BeyondItsSessionLimitTheLeastRecentlyHeardIsForgotten) {
  ReplayGuardConfig c;
  c.max_sessions = 3;
  ReplayGuard g(c);
  for (uint64_t s = 1; s <= 3; ++s) EXPECT_EQ(g.check(s, 1, -1, int64_t(s)), ReplayVerdict::kFresh);
  EXPECT_EQ(g.check(1, 2, -1, 10), ReplayVerdict::kFresh);  // session 1 heard again: 2 is now the least recent
  EXPECT_EQ(g.check(4, 1, -1, 11), ReplayVerdict::kFresh);
  EXPECT_EQ(g.sessions(), 3u);
  EXPECT_EQ(g.check(1, 2, -1, 12), ReplayVerdict::kReplayed);  // still remembered
  EXPECT_EQ(g.check(3, 1, -1, 13), ReplayVerdict::kReplayed);
}

// The attack of issue 29: a captured signed pose replayed every 100 ms under a new SSRC, from when the
// lecturer held still (sent nothing) for a second, used to take the view over and lock the lecturer out.
TEST(PoseChannel, ACapturedSignedPoseReplayedUnderAnotherSsrcNeverSteers) {
  PoseChannelConfig c;
  c.key.bytes.assign(32, 5);
  PoseChannel ch(c);
  const uint64_t session = 0xC0FFEE;
  uint64_t packet = 0, seq = 0;
  int64_t t = 0;
  std::vector<uint8_t> captured;
  for (int i = 0; i < 30; ++i, t += kFrame) {
    const std::vector<uint8_t> w = signed_packet(c.key, session, ++packet, t, ++seq);
    if (i == 10) captured = w;
    ASSERT_TRUE(ch.receive(w.data(), w.size(), "ssrc 0000aaaa", t).obey);
  }
  // One second of silence from the lecturer, the replay every 100 ms.
  for (int i = 0; i < 10; ++i) {
    t += 100 * kMs;
    EXPECT_FALSE(ch.receive(captured.data(), captured.size(), "ssrc 0000eeee", t).obey);
  }
  // The lecturer moves again: every one of its 120 poses is obeyed while the replay goes on.
  int obeyed = 0;
  for (int i = 0; i < 120; ++i, t += kFrame) {
    const std::vector<uint8_t> w = signed_packet(c.key, session, ++packet, t, ++seq);
    obeyed += ch.receive(w.data(), w.size(), "ssrc 0000aaaa", t).obey;
    if (i % 3 == 0) {
      EXPECT_FALSE(ch.receive(captured.data(), captured.size(), "ssrc 0000eeee", t).obey);
    }
  }
  EXPECT_EQ(obeyed, 120);
  EXPECT_EQ(ch.counts().replayed, 50u);
  EXPECT_EQ(ch.counts().session_switches, 0u);
}

// A lecturer who left: replaying its last packet must not keep its session alive against the next lecturer.
TEST(PoseChannel, ReplayingALecturerWhoLeftDoesNotHoldTheViewAgainstTheNextOne) {
  PoseChannelConfig c;
  c.key.bytes.assign(32, 6);
  PoseChannel ch(c);
  int64_t t = 0;
  std::vector<uint8_t> last;
  for (uint64_t n = 1; n <= 10; ++n, t += kFrame) {
    last = signed_packet(c.key, 1, n, t, n);
    ASSERT_TRUE(ch.receive(last.data(), last.size(), "ssrc 1", t).obey);
  }
  // The first lecturer is gone; its last packet comes again every 100 ms; the next lecturer starts.
  bool next_obeyed = false;
  for (uint64_t n = 1; n <= 30 && !next_obeyed; ++n) {
    t += 100 * kMs;
    EXPECT_FALSE(ch.receive(last.data(), last.size(), "ssrc 1", t).obey);
    const std::vector<uint8_t> w = signed_packet(c.key, 2, n, t, n);
    next_obeyed = ch.receive(w.data(), w.size(), "ssrc 2", t).obey;
  }
  EXPECT_TRUE(next_obeyed) << "the replayed packets kept the departed lecturer's session alive";
  EXPECT_LE(t, 1'100 * kMs);  // within the session timeout of the first lecturer's last real packet
}

TEST(PoseChannel, ObeyedPosesNameTheirSessionAndASignedSessionIsOneWhateverItsSsrc) {
  PoseChannel open;
  Pose p = sample_pose();
  p.position = Eigen::Vector3d(0, 0, 1);
  p.seq = 1;
  uint8_t wire[kPoseWireMaxSize];
  size_t n = pose_to_wire(p, wire, PoseWireStamp(3, 1));
  const PoseChannel::Outcome a = open.receive(wire, n, "ssrc 1", 0);
  ASSERT_TRUE(a.obey);
  EXPECT_NE(a.pose.session, 0u);
  // Unsigned, the SSRC is part of the session: another SSRC is another session.
  p.seq = 2;
  n = pose_to_wire(p, wire, PoseWireStamp(3, 2));
  EXPECT_FALSE(open.receive(wire, n, "ssrc 2", kFrame).obey);
  // Signed, the session number alone (authenticated) is the session.
  PoseChannelConfig c;
  c.key.bytes.assign(32, 1);
  PoseChannel keyed(c);
  p.seq = 1;
  n = pose_to_wire(p, wire, PoseWireStamp(3, 1), &c.key);
  const PoseChannel::Outcome k1 = keyed.receive(wire, n, "ssrc 1", 0);
  p.seq = 2;
  n = pose_to_wire(p, wire, PoseWireStamp(3, 2), &c.key);
  const PoseChannel::Outcome k2 = keyed.receive(wire, n, "ssrc 2", kFrame);
  ASSERT_TRUE(k1.obey);
  ASSERT_TRUE(k2.obey);
  EXPECT_EQ(k1.pose.session, k2.pose.session);
}
