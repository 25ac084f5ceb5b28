// Which pose packets the server obeys: one lecturer's stream at a time (a
// session), latest seq wins inside it, a seq far ahead is never adopted, and
// a silent session gives way to the next one within `timeout` (docs/network.md,
// "Sessions"). GStreamer-free; the caller passes its monotonic time, so tests
// need no sleeps. Not thread-safe: callers lock.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/net/pose_wire.h>
#include <gst/vclassroom/core/warning_limiter.h>

namespace vclassroom {

struct PoseSessionConfig {
  // A session that sent no new pose nor a repeat of its latest one for this
  // long is abandoned: the next well-formed pose of any session takes over.
  int64_t timeout_ns = 500'000'000;
  // A seq more than this ahead of the session's latest is rejected.
  uint64_t seq_window = 1u << 16;
};

enum class PoseVerdict {
  kAccepted,      // newer than the latest, inside the window: obey it
  kTookOver,      // first pose of a new (or restarted) session, which replaces the old one: obey it
  kRepeat,        // the session's latest again (keeps the session alive, nothing new)
  kStale,         // older than the latest: late or reordered
  kAheadOfWindow, // more than seq_window ahead: rejected, never adopted
  kOtherSession,  // from another session while the current one is alive: rejected
};
// Whether the caller should send the pose on.
inline bool pose_verdict_obeys(PoseVerdict v) { return v == PoseVerdict::kAccepted || v == PoseVerdict::kTookOver; }
const char* pose_verdict_name(PoseVerdict v);

class PoseSession {
 public:
  explicit PoseSession(PoseSessionConfig config = {}) : config_(config) {}

  // One pose of the stream identified by `key`, an opaque identity (on RTP
  // the SSRC and the payload's session number; a WebRTC session id works the
  // same), arriving at `now_ns` (monotonic). A restart inside one key is
  // recognised when seq goes back while viewer_time_ns (if both are given,
  // >= 0) moves on.
  PoseVerdict offer(const std::string& key, uint64_t seq, int64_t viewer_time_ns, int64_t now_ns);

  bool has_session() const { return has_; }
  const std::string& current() const { return key_; }
  uint64_t last_seq() const { return last_seq_; }
  // Sessions adopted after the first one (takeovers and restarts).
  uint64_t switches() const { return switches_; }
  const PoseSessionConfig& config() const { return config_; }
  void set_config(const PoseSessionConfig& c) { config_ = c; }
  void reset() { *this = PoseSession(config_); }

 private:
  PoseVerdict adopt(const std::string& key, uint64_t seq, int64_t viewer_time_ns, int64_t now_ns);

  PoseSessionConfig config_;
  bool has_ = false;
  std::string key_;
  uint64_t last_seq_ = 0;
  int64_t last_viewer_time_ns_ = -1;
  int64_t alive_ns_ = 0;  // when the session last sent its latest pose or a newer one
  uint64_t switches_ = 0;
};

// Authenticated poses are replay-proof (docs/network.md, "Replayed packets"):
// every packet of a session carries a packet number and its sending time under
// the tag, and a receiver keeps, per session number, the window of numbers it
// has seen (as SRTP does, RFC 3711 §3.3.2) and the smallest delay it has seen
// (its receive time minus the sending time: the two hosts' clock offset plus
// the path's delay). A packet whose number was seen or lies below the window
// is a replay; one that arrives more than `max_delay_ns` later than the
// session's fastest packet was held back. The state is kept per session number
// alone, so a packet replayed under another SSRC meets its own session's state.
struct ReplayGuardConfig {
  int64_t max_delay_ns = 2'000'000'000;
  size_t max_sessions = 1024;  // the least recently heard is forgotten beyond this
};

enum class ReplayVerdict {
  kFresh,     // never seen: take it (recorded)
  kReplayed,  // its number was seen already
  kTooOld,    // its number lies below the window: too old to tell, refused
  kHeldBack,  // sent more than max_delay_ns before it arrived, by the session's own clock offset
};
const char* replay_verdict_name(ReplayVerdict v);

class ReplayGuard {
 public:
  static constexpr uint64_t kWindow = 64;  // packet numbers remembered below the highest
  explicit ReplayGuard(ReplayGuardConfig config = {}) : config_(config) {}
  // Judges a packet that passed its tag; `sent_ns` < 0: the sender gave no time (not checked).
  ReplayVerdict check(uint64_t session, uint64_t packet, int64_t sent_ns, int64_t now_ns);
  size_t sessions() const { return sessions_.size(); }

 private:
  struct State {
    uint64_t highest = 0;
    uint64_t seen = 0;  // bit i: packet number highest - i was seen
    bool timed = false;
    int64_t min_delay_ns = 0;
    int64_t heard_ns = 0;
  };
  void forget_least_recent();

  ReplayGuardConfig config_;
  std::unordered_map<uint64_t, State> sessions_;
};

// The room's plausible volume: false, with a message for a person, when the
// pose's position is more than max_distance_m from the rig origin.
bool pose_is_plausible(const Pose& pose, double max_distance_m, std::string* why);

// What a pose channel's receiver counted.
struct PoseChannelCounts {
  uint64_t received = 0;         // packets, good or not
  uint64_t injected = 0;         // poses obeyed
  uint64_t damaged = 0;          // wrong size, version, flags or checksum; not a packet at all
  uint64_t unauthenticated = 0;  // a key is set and the tag is missing or wrong
  uint64_t implausible = 0;      // invalid (NaN, not a unit quaternion, ...) or beyond max_distance_m
  uint64_t rejected = 0;         // seq far ahead, or another session while the obeyed one is alive
  uint64_t replayed = 0;         // a key is set and the packet was seen before, or held back (ReplayGuard)
  uint64_t session_switches = 0;
};

struct PoseChannelConfig {
  PoseSessionConfig session;
  double max_distance_m = 20.0;  // the room's plausible volume: a sphere around the rig origin
  PoseKey key;                   // empty: poses are not authenticated
  ReplayGuardConfig replay;      // with a key
};

// The receiving end of the pose back channel as a whole: wire format and tag,
// plausibility, the session rule, counts, and rate-limited warnings (one
// WarningLimiter per kind of refused packet). Not thread-safe: callers lock.
class PoseChannel {
 public:
  struct Outcome {
    bool obey = false;    // send `pose` on
    Pose pose;
    std::string warning;  // non-empty: post it (already rate-limited)
  };
  explicit PoseChannel(PoseChannelConfig config = {})
      : config_(std::move(config)), session_(config_.session), replay_(config_.replay) {}

  // One packet's payload from `sender`, the transport's identity of the
  // stream (on RTP its SSRC); the payload's own session number is added to it.
  // With a key the session is the payload's (authenticated) session number
  // alone: the transport's identity is anyone's to forge. The obeyed pose's
  // `session` names the session (pose_session_id).
  Outcome receive(const uint8_t* payload, size_t size, const std::string& sender, int64_t now_ns);
  // A packet the transport could not read at all (e.g. not RTP).
  Outcome damaged(const std::string& why, int64_t now_ns);
  // Refused packets not yet reported (a burst just before the end), one
  // message per kind; call at the end of the stream.
  std::vector<std::string> final_warnings();

  PoseChannelCounts counts() const;
  uint64_t last_seq() const { return session_.last_seq(); }
  void set_max_distance(double metres) { config_.max_distance_m = metres; }

 private:
  enum Kind { kDamaged, kUnauthenticated, kImplausible, kRejected, kReplayed, kKinds };
  Outcome refuse(Kind kind, const std::string& why, int64_t now_ns);

  PoseChannelConfig config_;
  PoseSession session_;
  ReplayGuard replay_;
  uint64_t received_ = 0, injected_ = 0;
  std::array<uint64_t, kKinds> refused_{};
  std::array<WarningLimiter, kKinds> limiters_;
};

}  // namespace vclassroom
