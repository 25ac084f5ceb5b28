// Several lecturers' views on one server take turns to warp (docs/lecturer.md,
// "Several lecturers on few cores"). Every view's cameras start warping when
// the cameras' frames arrive (WarpStartBarrier), so with several views all of
// them start at the same moments and share the cores: each frame takes as long
// as all views' frames together, and that whole time lies between the pose a
// frame is rendered for and its photon. Taking turns, a view's cameras warp on
// all cores while the other views wait *before* reading their poses: a
// lecturer's frame then shows a pose as old as one view's warps, and the views
// still share the cores as before. GStreamer-free: a view is a number, a turn
// is one round of its cameras (the group WarpStartBarrier::arrive() gives
// them). Thread-safe: every camera's thread calls begin() and end().
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <set>

namespace vclassroom {

struct ViewTurnsParams {
  // A view that holds the turn longer than this loses it to the next (0:
  // views never wait for each other), so a holder that never ends its turn
  // (a frame lost in its warp) holds the others back no longer than this.
  int64_t longest_turn_ns = 100'000'000;
  static constexpr int64_t kLongestTurnNs = 10'000'000'000;  // what longest_turn_ns may be at most
};

class ViewTurns {
 public:
  void set_params(const ViewTurnsParams& params);
  ViewTurnsParams params() const;

  // A camera of view `view` is about to warp the frames of round `group`
  // (its cameras that go together): returns when the turn is its view's.
  // It is when nobody holds it and no view asked before, when the view holds
  // it for the same round, or for another round while no other view waits,
  // and when its holder has held it for longest_turn_ns. Views get the turn
  // in the order they asked for it.
  void begin(uint64_t view, uint64_t group);
  // One warp that begin() let through for `view` is done (its frame is out);
  // the view's last one passes the turn on.
  void end(uint64_t view);
  // The view is gone: its turn is free, its waiting cameras go now and later
  // ones pass without waiting.
  void forget(uint64_t view);
  // Stopping: every waiting camera goes now, and later ones pass without
  // waiting, until resume().
  void release();
  void resume();
  // How many cameras wait now.
  int waiting() const;
  // The view holding the turn, or 0 when it is free (views are numbered from 1).
  uint64_t holder() const;

 private:
  void take_locked(uint64_t view, uint64_t group);

  mutable std::mutex lock_;
  std::condition_variable changed_;
  ViewTurnsParams params_;
  uint64_t holder_ = 0;  // 0: free
  uint64_t group_ = 0;   // the holder's round
  std::chrono::steady_clock::time_point taken_;  // when the holder took it
  std::map<uint64_t, int> warping_;  // per view, its warps let through and not yet ended
  std::deque<uint64_t> queue_;       // the views waiting, in the order they asked
  std::set<uint64_t> gone_;
  int waiting_ = 0;
  bool released_ = false;
};

}  // namespace vclassroom
