// viewfuse's private state and the parts of the element kept in companion files: its properties
// (gstviewfuse_props.cpp), the poses it sends upstream (gstviewfuse_pose.cpp), the picture it sends with its
// messages and the latency its camera branches answer (gstviewfuse_output.cpp). Not installed.
#pragma once

#include <gst/base/gstaggregator.h>
#include <gst/video/video.h>

#include <atomic>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/camera_liveness.h>
#include <gst/vclassroom/vva/fuse_inputs.h>
#include <gst/vclassroom/vva/navigation.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/warp_start.h>

#include "gstviewfuse.h"

GST_DEBUG_CATEGORY_EXTERN(view_fuse_debug);
#define GST_CAT_DEFAULT view_fuse_debug

namespace vclassroom {
// Live and without any input, the fuse thread wakes this often to notice lost
// cameras and to keep the lecturer's picture saying so; otherwise it sleeps.
constexpr GstClockTime kIdleWake = 100 * GST_MSECOND;
// viewfuse room-view's default: on (docs/vva.md, "How a view is made": the same quality or better for 0.6 of
// the CPU per view).
constexpr bool kRoomViewByDefault = true;

struct ViewFuseState {
  std::mutex lock;  // guards the properties, pad_info, inputs, room_cameras and rounds_without_learners
  std::string trace_path;
  std::string rig_path;
  NavigationClamp bounds;  // every pose sent upstream stays inside the rig's navigation bounds
  std::optional<uint64_t> steering_session;  // the session of the latest pose sent upstream (stale_poses())
  double unseen_share = 0;  // of the last picture
  guint stats_interval = 0;  // frames between vclassroom-view-stats messages; 0: none
  FuseParams params;
  // The room drawn here (room_view.h), the viewwarps asked to warp only the learners (their warp-start query).
  std::atomic<bool> room_view{kRoomViewByDefault};
  // The cameras a far camera may leave its learners to (LearnerRounds::steady of the rounds so far), told to
  // the viewwarps in the warp-start answer; the rounds not shown because one of them had not drawn them.
  std::vector<RoomCameraPlace> room_cameras;
  guint64 rounds_without_learners = 0;
  std::map<InputKey, RgbdInfo> pad_info;  // each pad's caps, to map its frames
  // Which pads are left out, lost, stale (the decisions of each round).
  FuseInputs inputs;
  guint64 frames = 0;
  // The cameras' warps start together (warp-sync); only live, as the aggregate thread last found.
  WarpStartBarrier warp_start;
  std::atomic<bool> live{false};
  GstClockID first_camera_watch = nullptr;  // while PLAYING and no camera has sent yet (watch_for_first_camera)

  // Streaming thread only.
  std::vector<PoseSample> trace;
  size_t trace_next = 0;
  uint64_t trace_session = 0;  // the trace's poses are a session of their own, new each start
  GstVideoInfo out_info{};
  bool have_out = false;
  FusedView fused;
  RoomViewRenderer room_renderer;
  LearnerRounds learner_rounds;  // which cameras took others' learners, round by round
  WarpedView room;  // the room's view of the last round
  // The fill of the last picture, kept while the pose it was rendered for stays (same_rendered_view).
  HoleFillHistory fill_history;
  WarpedPose fill_pose;
  bool have_fused = false;  // fused holds the last picture sent
  GstClockTime last_out = GST_CLOCK_TIME_NONE;  // running time of the last output frame
};



}  // namespace vclassroom

struct _GstViewFuse {
  GstAggregator parent;
  vclassroom::ViewFuseState* st;
};

namespace vclassroom {

// GstClockTime as the library's nanoseconds (< 0: unknown) and back.
inline int64_t time_ns(GstClockTime t) { return GST_CLOCK_TIME_IS_VALID(t) ? int64_t(t) : -1; }
inline GstClockTime clock_time(int64_t ns) { return ns < 0 ? GST_CLOCK_TIME_NONE : GstClockTime(ns); }
// Running time on the element's clock now; GST_CLOCK_TIME_NONE without a clock.
GstClockTime running_time_now(GstElement* element);

// gstviewfuse_props.cpp
void view_fuse_install_properties(GObjectClass* klass);
void view_fuse_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec);
void view_fuse_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec);

// gstviewfuse_pose.cpp: a pose event (taken) to every camera branch, inside the navigation bounds; the
// trace's next pose the same way.
void forward_pose(GstViewFuse* self, GstEvent* event);
void send_trace_pose(GstViewFuse* self);

// gstviewfuse_output.cpp
void drop_buffers(const std::vector<GstAggregatorPad*>& pads, const std::vector<FrameVerdict>& verdicts,
                  FrameVerdict which);
void post_camera_status(GstViewFuse* self, const CameraStatusChange& change, const std::vector<int>& missing,
                        bool all_lost);
GstFlowReturn push_picture(GstViewFuse* self, const std::string& banner, GstClockTime rt, GstClockTime duration,
                           const WarpedPose* pose);
GstFlowReturn fuse_and_push(GstViewFuse* self, const std::vector<GstAggregatorPad*>& pads,
                            const std::vector<GstBuffer*>& bufs, const std::vector<RgbdInfo>& infos,
                            const std::vector<PendingFrame>& pending, const FuseRound& round,
                            const FuseParams& params);
GstPadProbeReturn answer_latency_of_unconnected_branch(GstPad* pad, GstPadProbeInfo* info, gpointer);
// Playing (`on`), a view that no camera has sent to after camera-timeout says so, once each time it starts
// playing: with no camera the
// fuse never runs (there is nothing to give its picture a size), so its liveness messages never come.
void watch_for_first_camera(GstViewFuse* self, bool on);

}  // namespace vclassroom
