#include <gst/vclassroom/vva/warp_start.h>

#include <algorithm>
#include <chrono>

namespace vclassroom {

void WarpStartBarrier::set_params(const WarpStartParams& params) {
  std::lock_guard<std::mutex> g(lock_);
  params_ = params;
  // A shorter wait (or none) applies to the cameras waiting now as well.
  open_next_round_locked(false);
}

WarpStartParams WarpStartBarrier::params() const {
  std::lock_guard<std::mutex> g(lock_);
  return params_;
}

// Every camera seen within forget_ns of the newest arrival has arrived.
bool WarpStartBarrier::round_complete_locked() const {
  for (const auto& [key, last_ns] : last_arrival_ns_)
    if (latest_ns_ - last_ns <= params_.forget_ns() && !arrived_.count(key)) return false;
  return true;
}

int64_t WarpStartBarrier::wait_ns_locked() const {
  int64_t sum = 0, n = 0;
  for (const auto& [key, interval] : interval_ns_)
    if (latest_ns_ - last_arrival_ns_.at(key) <= params_.forget_ns()) {
      sum += interval;
      ++n;
    }
  const int64_t longest = std::min(params_.max_wait_ns, WarpStartParams::kLongestWaitNs);
  if (!n) return longest;
  return std::min(longest, 2 * sum / (3 * n));
}

int64_t WarpStartBarrier::wait_ns() const {
  std::lock_guard<std::mutex> g(lock_);
  return wait_ns_locked();
}

void WarpStartBarrier::open_next_round_locked(bool together) {
  arrived_.clear();
  ++round_;
  last_round_together_ = together;
  next_round_.notify_all();
}

WarpStartBarrier::Start WarpStartBarrier::arrive(const void* key, int64_t now_ns, int64_t frame_ns, uint64_t* group) {
  uint64_t unused;
  if (!group) group = &unused;
  std::unique_lock<std::mutex> l(lock_);
  if (now_ns > latest_ns_) latest_ns_ = now_ns;
  const auto last = last_frame_ns_.find(key);
  if (frame_ns >= 0 && last != last_frame_ns_.end() && frame_ns > last->second &&
      frame_ns - last->second <= params_.forget_ns()) {
    const int64_t gap = frame_ns - last->second;
    const auto interval = interval_ns_.find(key);
    interval_ns_[key] = interval == interval_ns_.end() ? gap : (3 * interval->second + gap) / 4;
  }
  if (frame_ns >= 0) last_frame_ns_[key] = frame_ns;
  last_arrival_ns_[key] = now_ns;
  if (released_ || params_.max_wait_ns <= 0) {
    *group = lone_group_++;
    return Start::kAlone;
  }
  arrived_.insert(key);
  const uint64_t round = *group = round_;
  if (round_complete_locked()) {
    open_next_round_locked(true);
    return Start::kTogether;
  }
  ++waiting_;
  const bool woken =
      next_round_.wait_for(l, std::chrono::nanoseconds(wait_ns_locked()), [&] { return round_ != round; });
  --waiting_;
  if (woken) return last_round_together_ ? Start::kTogether : Start::kAlone;
  // Waited out: the cameras that came go now without the late one, whose
  // arrival opens a round of its own.
  open_next_round_locked(false);
  return Start::kAlone;
}

int WarpStartBarrier::waiting() const {
  std::lock_guard<std::mutex> g(lock_);
  return waiting_;
}

void WarpStartBarrier::forget(const void* key) {
  std::lock_guard<std::mutex> g(lock_);
  last_arrival_ns_.erase(key);
  last_frame_ns_.erase(key);
  interval_ns_.erase(key);
  arrived_.erase(key);
  if (!arrived_.empty() && round_complete_locked()) open_next_round_locked(true);
}

void WarpStartBarrier::release() {
  std::lock_guard<std::mutex> g(lock_);
  released_ = true;
  open_next_round_locked(false);
}

void WarpStartBarrier::resume() {
  std::lock_guard<std::mutex> g(lock_);
  released_ = false;
  last_arrival_ns_.clear();
  last_frame_ns_.clear();
  interval_ns_.clear();
  arrived_.clear();
  latest_ns_ = 0;
}

}  // namespace vclassroom
