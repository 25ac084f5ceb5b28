// What viewfuse does with its camera inputs in each round (docs/vva.md): a
// view of another size is left out with a rate-limited warning, a camera
// silent for the camera timeout is lost and later back (reported), a frame
// warped for an older pose than the others' or not newer than the last output
// is stale, and with every camera lost the last picture is sent again marked
// with a banner. GStreamer-free: an input is an opaque key (the element's pad),
// times are nanoseconds with < 0 meaning unknown, so tests pass their own.
// Not thread-safe: callers lock.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gst/vclassroom/vva/camera_liveness.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/core/warning_limiter.h>

namespace vclassroom {

using InputKey = const void*;

struct FuseInputsParams {
  // Live: frames warped for poses the viewer took at most this far apart are
  // fused together (stale_poses()).
  int64_t pose_window_ns = 50'000'000;
  // Live: a camera without a frame for this long is lost (0: never).
  int64_t camera_timeout_ns = 1'000'000'000;
  // Name the lost cameras on the picture, and repeat the last picture so
  // marked when every camera is lost.
  bool show_missing = true;
};

// A camera lost or back, to be reported.
struct CameraStatusChange {
  int camera_id = -1;
  bool lost = false;  // false: it returned
  int64_t silent_ns = 0;
  bool never_seen = false;  // lost: it has sent nothing since the view started
};

// An input holding a frame this round.
struct PendingFrame {
  InputKey key = nullptr;
  int64_t running_time_ns = -1;
  WarpedPose pose;
};

// What the round is, apart from the frames.
struct RoundContext {
  bool live = false;
  int64_t now_ns = -1;       // running time now (live, with a clock)
  bool timeout = false;      // the latency ran out: produce with what there is
  int64_t last_out_ns = -1;  // running time of the last output frame
  bool have_picture = false;  // a fused picture was sent and can be sent again
  int64_t monotonic_ns = 0;  // for rate-limiting the warnings
  // Live: how long the fuse waits for a late camera's frame (its latency). A camera is never lost sooner:
  // a fuse told to wait 5 s for a slow camera must not give it up after the 1 s camera timeout.
  int64_t latency_ns = 0;
  // The session of the latest pose passed upstream to the warps, when one was: frames warped for another
  // session's pose are stale (stale_poses()).
  std::optional<uint64_t> steering_session;
};

enum class FrameVerdict {
  kFuse,        // fuse it (with kWait: keep it for the next round)
  kLeftOut,     // its view has another size: drop it
  kOlderPose,   // live, warped for an older pose than the others: drop it, await its fresh one
  kLate,        // live, not newer than the last output: drop it
};

enum class RoundAction {
  kWait,        // produce nothing now
  kFuse,        // fuse the frames marked kFuse
  kRepeatLast,  // every camera lost: send the last picture again with the banner
};

struct FuseRound {
  std::vector<CameraStatusChange> status_changes;  // to report, in this order
  std::vector<int> missing;                        // the cameras lost now
  bool all_lost = false;
  std::vector<std::string> warnings;    // left-out frames, rate-limited, to post after the status changes
  std::vector<FrameVerdict> verdicts;   // one per frame given
  std::string banner;                   // to draw on the output ("" none)
  RoundAction action = RoundAction::kWait;
};

class FuseInputs {
 public:
  explicit FuseInputs(const FuseInputsParams& params = {});
  const FuseInputsParams& params() const { return params_; }
  void set_params(const FuseInputsParams& params);

  // An input's view (its caps): camera `camera_id` at width x height. Returns
  // why it is left out ("" when accepted): every input but the left-out ones
  // must have the same size. An input left out is accepted again once its
  // size matches.
  std::string configure(InputKey key, int camera_id, int width, int height);
  // An input that exists (the element's pad), whether or not it has sent
  // anything: named camera `camera_id` (e.g. from its pad's name) until its
  // caps say which camera it is. Live, one silent from the start is lost
  // after the camera timeout, reported and named on the banner, as one that
  // stopped. Call it every round for every input; known ones are kept as they are.
  void expect(InputKey key, int camera_id);
  // The first accepted input (by key), whose view the output takes; nullptr when none.
  InputKey first_accepted() const;
  // An input gone for good (its pad released): its camera is forgotten too.
  void release(InputKey key);
  // A restart: inputs come again with their caps, cameras are unknown.
  void clear();

  // Decides one round for the inputs holding a frame (in the element's pad
  // order). Records their cameras as seen (live) and the left-out frames for
  // the warnings, so call it once per round.
  FuseRound decide(const std::vector<PendingFrame>& frames, const RoundContext& ctx);

 private:
  struct Input {
    int camera_id = 0;
    bool has_caps = false;  // else expected only: its camera_id is a guess and it has no size
    int width = 0, height = 0;
    std::string left_out;  // why; "" when accepted
    WarningLimiter warnings;
  };
  FuseInputsParams params_;
  std::map<InputKey, Input> inputs_;
  CameraLiveness liveness_;
};

// The bus text for a person about a camera lost or back: "camera 2 lost (no
// frame for 1.0 s): the view goes on without it", "camera 0 has sent no frame
// in the 1.0 s since the view started: ..." for one silent from the start, or
// with every camera lost what the lecturer sees, or "camera 2 is back after
// 3.0 s without frames".
std::string camera_status_text(const CameraStatusChange& change, const std::vector<int>& missing, bool all_lost);
// "0,2": the ids for the status message's `missing` field.
std::string camera_id_list(const std::vector<int>& ids);

// A fused frame's running time (< 0 unknown) and pose.
struct FrameStamp {
  int64_t running_time_ns = -1;
  WarpedPose pose;
};
// Of the frames fused, the one whose time (and duration) the output takes: the
// newest, as fresh as the output is; and the one whose pose it carries: the
// oldest pose, the one it fully shows (so a latency measured from it is not
// flattered). -1 when none has a time, or a pose.
struct OutputStamp {
  int time_from = -1;
  int pose_from = -1;
};
OutputStamp output_stamp(const std::vector<FrameStamp>& fused);

// Live, the aggregator waits until the running time its get_next_time gives
// (plus the latency). The simple rule (the end of the last output) lies in
// the past once inputs stop, and a wait for a past time ends at once: the
// thread would spin at full CPU. So while no input holds a frame the next
// wake-up is at least `idle_wake_ns` after `now_ns` (data ends the wait anyway).
int64_t fuse_wake_time(int64_t next_ns, int64_t now_ns, bool any_input, int64_t idle_wake_ns);

// The running time of the next output: `rt`, but never at or before the last
// output's `last_out_ns`, whatever the inputs' timing (< 0: unknown).
int64_t next_output_time(int64_t last_out_ns, int64_t rt_ns);

}  // namespace vclassroom
