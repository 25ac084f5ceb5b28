#include <gst/vclassroom/vva/fuse_inputs.h>

#include <algorithm>
#include <cstdio>

namespace vclassroom {

FuseInputs::FuseInputs(const FuseInputsParams& params) : params_(params), liveness_(params.camera_timeout_ns) {}

void FuseInputs::set_params(const FuseInputsParams& params) {
  params_ = params;
  liveness_.set_timeout(params.camera_timeout_ns);
}

std::string FuseInputs::configure(InputKey key, int camera_id, int width, int height) {
  std::string left_out;
  for (const auto& [k, other] : inputs_)
    if (k != key && other.has_caps && other.left_out.empty() && (other.width != width || other.height != height)) {
      left_out = "its view is " + std::to_string(width) + "x" + std::to_string(height) + ", the others' " +
                 std::to_string(other.width) + "x" + std::to_string(other.height) +
                 " (every viewwarp must render the same virtual size)";
      break;
    }
  const bool existed = inputs_.count(key) > 0;
  Input& in = inputs_[key];
  // An expected input was watched under a guessed id: if its caps name
  // another camera, the guess is no camera at all and must not be missed.
  if (existed && !in.has_caps && in.camera_id != camera_id && !liveness_.ever_seen(in.camera_id)) {
    const int guess = in.camera_id;
    const bool shared = std::any_of(inputs_.begin(), inputs_.end(), [&](const auto& kv) {
      return kv.first != key && kv.second.camera_id == guess;
    });
    if (!shared) liveness_.forget(guess);
  }
  in.has_caps = true;
  in.camera_id = camera_id;
  in.width = width;
  in.height = height;
  in.left_out = left_out;
  return left_out;
}

void FuseInputs::expect(InputKey key, int camera_id) {
  if (!inputs_.count(key)) inputs_[key].camera_id = camera_id;
}

InputKey FuseInputs::first_accepted() const {
  for (const auto& [k, in] : inputs_)
    if (in.has_caps && in.left_out.empty()) return k;
  return nullptr;
}

void FuseInputs::release(InputKey key) {
  const auto it = inputs_.find(key);
  if (it == inputs_.end()) return;
  liveness_.forget(it->second.camera_id);
  inputs_.erase(it);
}

void FuseInputs::clear() {
  inputs_.clear();
  liveness_.clear();
}

FuseRound FuseInputs::decide(const std::vector<PendingFrame>& frames, const RoundContext& ctx) {
  FuseRound round;
  round.verdicts.assign(frames.size(), FrameVerdict::kFuse);
  // An input without caps yet counts as camera 0 of an accepted size.
  const auto input = [&](InputKey key) -> const Input* {
    const auto it = inputs_.find(key);
    return it == inputs_.end() ? nullptr : &it->second;
  };
  // Live, a camera silent for the timeout is lost until its next frame (a
  // left-out frame still shows the camera is there).
  const bool clocked = ctx.live && ctx.now_ns >= 0;
  if (clocked) {
    // Every input is watched from the first round that has a clock, frames or not.
    for (const auto& [key, in] : inputs_) liveness_.expect(in.camera_id, ctx.now_ns);
    if (params_.camera_timeout_ns > 0) liveness_.set_timeout(std::max(params_.camera_timeout_ns, ctx.latency_ns));
    for (const PendingFrame& f : frames) {
      const Input* in = input(f.key);
      const int id = in ? in->camera_id : 0;
      const int64_t silent = liveness_.silent_for(id, ctx.now_ns);
      if (liveness_.seen(id, ctx.now_ns)) round.status_changes.push_back({id, false, silent});
    }
    for (int id : liveness_.newly_lost(ctx.now_ns))
      round.status_changes.push_back({id, true, liveness_.silent_for(id, ctx.now_ns), !liveness_.ever_seen(id)});
  }
  round.missing = liveness_.missing();
  round.all_lost = liveness_.all_lost();
  round.banner = params_.show_missing ? missing_cameras_text(round.missing) : "";

  // A camera of another view size: its frames are left out, counted in the warnings.
  size_t kept = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto it = inputs_.find(frames[i].key);
    if (it == inputs_.end() || it->second.left_out.empty()) {
      ++kept;
      continue;
    }
    uint64_t count;
    int64_t span;
    if (it->second.warnings.note(ctx.monotonic_ns, &count, &span))
      round.warnings.push_back(describe_occurrences(count, "a frame left out", "frames left out",
                                                    "camera " + std::to_string(it->second.camera_id), span) +
                               ": " + it->second.left_out);
    round.verdicts[i] = FrameVerdict::kLeftOut;
  }

  if (kept == 0) {
    // Every camera gone: the lecturer keeps getting the last picture, marked,
    // rather than a silently frozen one.
    if (ctx.timeout && round.all_lost && !round.banner.empty() && ctx.have_picture && clocked)
      round.action = RoundAction::kRepeatLast;
    return round;
  }

  // One output frame shows one pose. Live, a frame warped for an older pose
  // than the others (or not newer than the last output) is stale: it is
  // dropped and its fresh one awaited, fusing only the consistent ones when
  // the latency runs out. Not live, everything is fused.
  std::vector<WarpedPose> poses;
  std::vector<size_t> index;
  for (size_t i = 0; i < frames.size(); ++i)
    if (round.verdicts[i] == FrameVerdict::kFuse) {
      poses.push_back(frames[i].pose);
      index.push_back(i);
    }
  const std::vector<bool> stale = stale_poses(poses, params_.pose_window_ns, ctx.steering_session);
  bool dropped = false;
  for (size_t j = 0; ctx.live && j < index.size(); ++j) {
    const PendingFrame& f = frames[index[j]];
    const bool late = ctx.last_out_ns >= 0 && f.running_time_ns >= 0 && f.running_time_ns <= ctx.last_out_ns;
    if (stale[j] || late) {
      round.verdicts[index[j]] = stale[j] ? FrameVerdict::kOlderPose : FrameVerdict::kLate;
      dropped = true;
      --kept;
    }
  }
  if ((dropped && !ctx.timeout) || kept == 0) return round;
  round.action = RoundAction::kFuse;
  return round;
}

std::string camera_status_text(const CameraStatusChange& change, const std::vector<int>& missing, bool all_lost) {
  char silent[32];
  std::snprintf(silent, sizeof silent, "%.1f", double(change.silent_ns) / 1e9);
  const std::string camera = "camera " + std::to_string(change.camera_id);
  if (!change.lost) return camera + " is back after " + silent + " s without frames";
  const std::string lost = change.never_seen
                               ? camera + " has sent no frame in the " + silent + " s since the view started: "
                               : camera + " lost (no frame for " + silent + " s): ";
  if (all_lost)
    return lost + "no camera left, the lecturer sees the last picture marked '" + missing_cameras_text(missing) + "'";
  return lost + "the view goes on without it";
}

std::string camera_id_list(const std::vector<int>& ids) {
  std::string s;
  for (int id : ids) s += (s.empty() ? "" : ",") + std::to_string(id);
  return s;
}

OutputStamp output_stamp(const std::vector<FrameStamp>& fused) {
  OutputStamp out;
  for (size_t i = 0; i < fused.size(); ++i) {
    const FrameStamp& f = fused[i];
    if (f.running_time_ns >= 0 && (out.time_from < 0 || f.running_time_ns > fused[out.time_from].running_time_ns))
      out.time_from = int(i);
    // Seqs order poses of one session only; a round of mixed sessions (no steering session known) names
    // the first input's.
    if (f.pose.known && (out.pose_from < 0 || (f.pose.session == fused[out.pose_from].pose.session &&
                                               f.pose.seq < fused[out.pose_from].pose.seq)))
      out.pose_from = int(i);
  }
  return out;
}

int64_t fuse_wake_time(int64_t next_ns, int64_t now_ns, bool any_input, int64_t idle_wake_ns) {
  if (next_ns < 0 || now_ns < 0 || any_input) return next_ns;
  return std::max(next_ns, now_ns + idle_wake_ns);
}

int64_t next_output_time(int64_t last_out_ns, int64_t rt_ns) {
  if (last_out_ns >= 0 && (rt_ns < 0 || rt_ns <= last_out_ns)) return last_out_ns + 1;
  return rt_ns;
}

}  // namespace vclassroom
