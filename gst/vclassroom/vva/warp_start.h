// The cameras of one view start warping together (docs/vva.md, viewfuse,
// "The cameras start warping together"). A live view shows a lecturer's pose once every camera has warped
// a frame for it. Each camera's warp reads the newest pose when its next frame
// arrives, and under load the cameras' frames arrive at scattered moments: the
// pose then waits for the last of several scattered arrivals, most of a frame
// interval. Here each camera's warp waits, before it reads the pose, until the
// other cameras' next frames have arrived too (or a short wait runs out); all
// then read the same newest pose, and the pose waits for one arrival, not for
// the last of several. GStreamer-free: a camera is an opaque key (viewfuse's
// sink pad), times are nanoseconds passed in, so tests pass their own.
// Thread-safe: every camera's thread calls arrive().
#pragma once

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>

namespace vclassroom {

// The downstream query a viewwarp sends before it reads the pose; viewfuse
// answers it once the view's other cameras are there too (WarpStartBarrier).
inline constexpr const char* kWarpStartQueryName = "vclassroom/warp-start";

struct WarpStartParams {
  // The longest a camera waits for the others (0: never waits). Within it a
  // camera waits two thirds of the interval between the frames the cameras
  // bring (their running times): the others' next frames are due within one
  // interval, and a camera whose partner dropped a frame should not hold its
  // own for a whole one.
  int64_t max_wait_ns = 100'000'000;
  static constexpr int64_t kLongestWaitNs = 60'000'000'000;  // what max_wait_ns may be at most
  // A camera that has not arrived for 15 waits, and at least 500 ms (lost,
  // ended, or far slower than the others), is not waited for until it arrives
  // again.
  int64_t forget_ns() const {
    const int64_t waits = 15 * std::min(max_wait_ns, kLongestWaitNs);
    return waits > 500'000'000 ? waits : 500'000'000;
  }
};

class WarpStartBarrier {
 public:
  enum class Start {
    kTogether,  // every camera seen lately arrived: all go now
    kAlone,     // the wait ran out (or the barrier is off or released): this one goes
  };

  void set_params(const WarpStartParams& params);
  WarpStartParams params() const;

  // Camera `key` has a frame to warp at `now_ns` (a monotonic time), the frame
  // of running time `frame_ns` (< 0: unknown): returns when every camera that
  // arrived within forget_ns before now has arrived in this round, or after
  // wait_ns(). A camera arrives once per frame. `group`, when given, is set
  // to a number the cameras that go together share (one round), and no
  // other camera's.
  Start arrive(const void* key, int64_t now_ns, int64_t frame_ns = -1, uint64_t* group = nullptr);
  // A camera that is gone for good (its pad released): not waited for again.
  void forget(const void* key);
  // Stopping: every waiting camera goes now, and arrivals pass without waiting
  // until resume().
  void release();
  void resume();
  // How many cameras wait now.
  int waiting() const;
  // How long a camera that arrives now waits at most (ns).
  int64_t wait_ns() const;

 private:
  bool round_complete_locked() const;
  int64_t wait_ns_locked() const;
  void open_next_round_locked(bool together);

  mutable std::mutex lock_;
  std::condition_variable next_round_;
  WarpStartParams params_;
  std::map<const void*, int64_t> last_arrival_ns_;
  std::map<const void*, int64_t> last_frame_ns_;
  std::map<const void*, int64_t> interval_ns_;  // each camera's time between frames, smoothed
  std::set<const void*> arrived_;  // in the current round
  int64_t latest_ns_ = 0;          // the newest arrival's time
  uint64_t round_ = 0;
  uint64_t lone_group_ = uint64_t(1) << 63;  // the groups of cameras that go alone, above every round's
  int waiting_ = 0;
  bool last_round_together_ = false;  // how the last round ended
  bool released_ = false;
};

}  // namespace vclassroom
