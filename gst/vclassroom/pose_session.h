// Which pose packets the server obeys: one lecturer's stream at a time (a
// session), latest seq wins inside it, a seq far ahead is never adopted, and
// a silent session gives way to the next one within `timeout` (docs/network.md,
// "Sessions"). GStreamer-free; the caller passes its monotonic time, so tests
// need no sleeps. Not thread-safe: callers lock.
#pragma once

#include <cstdint>
#include <string>

#include "pose.h"

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

// The room's plausible volume: false, with a message for a person, when the
// pose's position is more than max_distance_m from the rig origin.
bool pose_is_plausible(const Pose& pose, double max_distance_m, std::string* why);

}  // namespace vclassroom
