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

const char* replay_verdict_name(ReplayVerdict v) {
  switch (v) {
    case ReplayVerdict::kFresh: return "fresh";
    case ReplayVerdict::kReplayed: return "replayed";
    case ReplayVerdict::kTooOld: return "below the replay window";
    case ReplayVerdict::kHeldBack: return "held back";
  }
  return "?";
}

namespace {
// a - b, wrapping instead of overflowing: the two clocks are unrelated and an authenticated sender may still
// send any number.
int64_t wrapping_difference(int64_t a, int64_t b) {
  return static_cast<int64_t>(static_cast<uint64_t>(a) - static_cast<uint64_t>(b));
}
}  // namespace

void ReplayGuard::forget_least_recent() {
  auto oldest = sessions_.begin();
  for (auto it = sessions_.begin(); it != sessions_.end(); ++it)
    if (it->second.heard_ns < oldest->second.heard_ns) oldest = it;
  if (oldest != sessions_.end()) sessions_.erase(oldest);
}

ReplayVerdict ReplayGuard::check(uint64_t session, uint64_t packet, int64_t sent_ns, int64_t now_ns) {
  auto it = sessions_.find(session);
  if (it == sessions_.end()) {
    if (sessions_.size() >= config_.max_sessions) forget_least_recent();
    State first;
    first.highest = packet;
    first.seen = 1;
    first.timed = sent_ns >= 0;
    first.min_delay_ns = wrapping_difference(now_ns, sent_ns);
    first.heard_ns = now_ns;
    sessions_.emplace(session, first);
    return ReplayVerdict::kFresh;
  }
  State& st = it->second;
  if (packet <= st.highest) {
    const uint64_t behind = st.highest - packet;
    if (behind >= kWindow) return ReplayVerdict::kTooOld;
    if (st.seen & (uint64_t{1} << behind)) return ReplayVerdict::kReplayed;
  }
  // The smallest delay seen is the clock offset plus the fastest path: a
  // packet much slower than that was held back on the way.
  if (sent_ns >= 0 && st.timed) {
    const int64_t delay = wrapping_difference(now_ns, sent_ns);
    const int64_t slower_by = wrapping_difference(delay, st.min_delay_ns);
    if (slower_by > config_.max_delay_ns) return ReplayVerdict::kHeldBack;
    if (slower_by < 0) st.min_delay_ns = delay;
  } else if (sent_ns >= 0) {
    st.timed = true;
    st.min_delay_ns = wrapping_difference(now_ns, sent_ns);
  }
  if (packet > st.highest) {
    const uint64_t ahead = packet - st.highest;
    st.seen = ahead >= kWindow ? 0 : st.seen << ahead;
    st.seen |= 1;
    st.highest = packet;
  } else {
    st.seen |= uint64_t{1} << (st.highest - packet);
  }
  st.heard_ns = now_ns;
  return ReplayVerdict::kFresh;
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
                                     "a rejected pose", "a replayed pose packet"};
constexpr const char* kPlural[] = {"damaged pose packets", "unauthenticated pose packets", "implausible poses",
                                   "rejected poses", "replayed pose packets"};
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
  const bool keyed = !config_.key.empty();
  const PoseWireStamp& stamp = info.stamp;
  char session[24];
  std::snprintf(session, sizeof session, "%016llx", static_cast<unsigned long long>(stamp.session));
  if (keyed) {
    const ReplayVerdict r = replay_.check(stamp.session, stamp.packet, stamp.sent_ns, now_ns);
    if (r != ReplayVerdict::kFresh)
      return refuse(kReplayed,
                    "packet " + std::to_string(stamp.packet) + " of session " + session + ": " + replay_verdict_name(r),
                    now_ns);
  }
  if (!pose_is_plausible(out.pose, config_.max_distance_m, &why)) return refuse(kImplausible, why, now_ns);
  const std::string key = keyed ? std::string("session ") + session : sender + "/" + session;
  out.pose.session = pose_session_id(key);
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
  c.replayed = refused_[kReplayed];
  c.session_switches = session_.switches();
  return c;
}

}  // namespace vclassroom
