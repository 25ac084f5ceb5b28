#include "pose_session.h"

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

}  // namespace vclassroom
