#include <gst/vclassroom/net/pose_session.h>

#include <cstdio>
#include <sstream>

namespace vclassroom {

const char* pose_verdict_name(PoseVerdict v) {
  switch (v) {
    case PoseVerdict::kAccepted: return "accepted";
    case PoseVerdict::kTookOver: return "took over";
    case PoseVerdict::kRepeat: return "repeat";
    case PoseVerdict::kStale: return "stale";
    case PoseVerdict::kAheadOfWindow: return "ahead of the window";
    case PoseVerdict::kOtherSession: return "another session";
  }
  return "?";
}

PoseVerdict PoseSession::adopt(const std::string& key, uint64_t seq, int64_t viewer_time_ns, int64_t now_ns) {
  const bool first = !has_;
  if (!first) ++switches_;
  has_ = true;
  key_ = key;
  last_seq_ = seq;
  last_viewer_time_ns_ = viewer_time_ns;
  alive_ns_ = now_ns;
  return first ? PoseVerdict::kAccepted : PoseVerdict::kTookOver;
}

PoseVerdict PoseSession::offer(const std::string& key, uint64_t seq, int64_t viewer_time_ns, int64_t now_ns) {
  const bool alive = has_ && now_ns - alive_ns_ < config_.timeout_ns;
  const bool same = has_ && key == key_;
  if (same && seq > last_seq_ && seq - last_seq_ <= config_.seq_window) {
    last_seq_ = seq;
    last_viewer_time_ns_ = viewer_time_ns;
    alive_ns_ = now_ns;
    return PoseVerdict::kAccepted;
  }
  if (same && seq == last_seq_) {
    alive_ns_ = now_ns;
    return PoseVerdict::kRepeat;
  }
  // Silent for `timeout`: whoever speaks next is obeyed, wherever its seq
  // stands (a lecturer back after an outage may be far ahead; one that
  // restarted counts from 1 again).
  if (!alive) return adopt(key, seq, viewer_time_ns, now_ns);
  if (!same) return PoseVerdict::kOtherSession;
  if (seq > last_seq_) return PoseVerdict::kAheadOfWindow;
  // seq went back. A late or reordered packet was sampled before the latest;
  // a restarted sender numbers from 1 again but samples later.
  if (viewer_time_ns >= 0 && last_viewer_time_ns_ >= 0 && viewer_time_ns > last_viewer_time_ns_)
    return adopt(key, seq, viewer_time_ns, now_ns);
  return PoseVerdict::kStale;
}

bool pose_is_plausible(const Pose& pose, double max_distance_m, std::string* why) {
  const double d = pose.position.norm();
  if (d <= max_distance_m) return true;
  if (why) {
    std::ostringstream os;
    os << "pose at (" << pose.position.x() << ", " << pose.position.y() << ", " << pose.position.z() << ") is " << d
       << " m from the rig origin (max-distance " << max_distance_m << " m)";
    *why = os.str();
  }
  return false;
}

namespace {
constexpr const char* kSingular[] = {"a damaged pose packet", "an unauthenticated pose packet", "an implausible pose",
                                     "a rejected pose"};
constexpr const char* kPlural[] = {"damaged pose packets", "unauthenticated pose packets", "implausible poses",
                                   "rejected poses"};
constexpr const char* kSource = "the pose link";
}  // namespace

PoseChannel::Outcome PoseChannel::refuse(Kind kind, const std::string& why, int64_t now_ns) {
  Outcome out;
  refused_[kind]++;
  uint64_t count = 0;
  int64_t span = 0;
  if (limiters_[kind].note(now_ns, &count, &span))
    out.warning = describe_occurrences(count, kSingular[kind], kPlural[kind], kSource, span) + " (dropped; latest: " +
                  why + ")";
  return out;
}

PoseChannel::Outcome PoseChannel::damaged(const std::string& why, int64_t now_ns) {
  received_++;
  return refuse(kDamaged, why, now_ns);
}

PoseChannel::Outcome PoseChannel::receive(const uint8_t* payload, size_t size, const std::string& sender,
                                          int64_t now_ns) {
  received_++;
  Outcome out;
  PoseWireInfo info;
  std::string why;
  if (!pose_from_wire(payload, size, &out.pose, &why, &config_.key, &info))
    return refuse(info.error == PoseWireError::kUnauthenticated ? kUnauthenticated
                  : info.error == PoseWireError::kInvalid       ? kImplausible
                                                                : kDamaged,
                  why, now_ns);
  if (!pose_is_plausible(out.pose, config_.max_distance_m, &why)) return refuse(kImplausible, why, now_ns);
  char session[24];
  std::snprintf(session, sizeof session, "/%016llx", static_cast<unsigned long long>(info.session));
  const std::string key = sender + session;
  const PoseVerdict v = session_.offer(key, out.pose.seq, out.pose.viewer_time_ns, now_ns);
  if (v == PoseVerdict::kAheadOfWindow || v == PoseVerdict::kOtherSession)
    return refuse(kRejected,
                  "seq " + std::to_string(out.pose.seq) + " of " + key + ": " + pose_verdict_name(v) +
                      " (the session obeyed is " + session_.current() + " at seq " +
                      std::to_string(session_.last_seq()) + ")",
                  now_ns);
  out.obey = pose_verdict_obeys(v);
  if (out.obey) injected_++;
  return out;
}

std::vector<std::string> PoseChannel::final_warnings() {
  std::vector<std::string> out;
  for (int k = 0; k < kKinds; ++k)
    if (const uint64_t n = limiters_[k].take_pending())
      out.push_back(describe_occurrences(n, kSingular[k], kPlural[k], kSource, 0) + " since the last report (dropped)");
  return out;
}

PoseChannelCounts PoseChannel::counts() const {
  PoseChannelCounts c;
  c.received = received_;
  c.injected = injected_;
  c.damaged = refused_[kDamaged];
  c.unauthenticated = refused_[kUnauthenticated];
  c.implausible = refused_[kImplausible];
  c.rejected = refused_[kRejected];
  c.session_switches = session_.switches();
  return c;
}

}  // namespace vclassroom
