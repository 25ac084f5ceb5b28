#include <gst/vclassroom/vva/view_turns.h>

#include <algorithm>
#include <chrono>

namespace vclassroom {

void ViewTurns::set_params(const ViewTurnsParams& params) {
  std::lock_guard<std::mutex> g(lock_);
  params_ = params;
  params_.longest_turn_ns = std::clamp<int64_t>(params_.longest_turn_ns, 0, ViewTurnsParams::kLongestTurnNs);
  changed_.notify_all();  // a shorter turn (or none) applies to the cameras waiting now as well
}

ViewTurnsParams ViewTurns::params() const {
  std::lock_guard<std::mutex> g(lock_);
  return params_;
}

void ViewTurns::take_locked(uint64_t view, uint64_t group) {
  queue_.erase(std::remove(queue_.begin(), queue_.end(), view), queue_.end());
  holder_ = view;
  group_ = group;
  taken_ = std::chrono::steady_clock::now();
  ++warping_[view];
  changed_.notify_all();  // the view's other cameras of this round may go too
}

void ViewTurns::begin(uint64_t view, uint64_t group) {
  std::unique_lock<std::mutex> l(lock_);
  for (;;) {
    if (released_ || params_.longest_turn_ns <= 0 || gone_.count(view)) return;
    if (holder_ == view && (group_ == group || queue_.empty())) {
      group_ = group;
      ++warping_[view];
      return;
    }
    const auto turn_over = taken_ + std::chrono::nanoseconds(params_.longest_turn_ns);
    const bool first = queue_.empty() || queue_.front() == view;
    const bool held = holder_ != 0 && std::chrono::steady_clock::now() < turn_over;
    if (first && !held) {
      take_locked(view, group);
      return;
    }
    if (std::find(queue_.begin(), queue_.end(), view) == queue_.end()) queue_.push_back(view);
    ++waiting_;
    if (held) changed_.wait_until(l, turn_over);
    else changed_.wait(l);  // for the view before this one to take the turn
    --waiting_;
  }
}

void ViewTurns::end(uint64_t view) {
  std::lock_guard<std::mutex> g(lock_);
  auto it = warping_.find(view);
  if (it == warping_.end()) return;
  if (--it->second > 0) return;
  warping_.erase(it);
  if (holder_ == view) {
    holder_ = 0;
    changed_.notify_all();
  }
}

void ViewTurns::forget(uint64_t view) {
  std::lock_guard<std::mutex> g(lock_);
  gone_.insert(view);
  warping_.erase(view);
  queue_.erase(std::remove(queue_.begin(), queue_.end(), view), queue_.end());
  if (holder_ == view) holder_ = 0;
  changed_.notify_all();
}

void ViewTurns::release() {
  std::lock_guard<std::mutex> g(lock_);
  released_ = true;
  changed_.notify_all();
}

void ViewTurns::resume() {
  std::lock_guard<std::mutex> g(lock_);
  released_ = false;
  holder_ = 0;
  warping_.clear();
  queue_.clear();
}

int ViewTurns::waiting() const {
  std::lock_guard<std::mutex> g(lock_);
  return waiting_;
}

uint64_t ViewTurns::holder() const {
  std::lock_guard<std::mutex> g(lock_);
  return holder_;
}

}  // namespace vclassroom
