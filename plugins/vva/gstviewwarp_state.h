// viewwarp's private state, shared by the element (gstviewwarp.cpp: negotiation and the warp) and its
// properties (gstviewwarp_props.cpp), so that neither file mixes the two. Not installed.
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/rgbd_filter.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

struct ViewWarpState {
  explicit ViewWarpState(GstRgbdFilter* element) : element(element) {}
  // The base class's lock guards the properties and the pose (the pose comes from the src pad's events).
  std::unique_lock<std::mutex> lock() const { return rgbd_filter_lock(element); }
  GstRgbdFilter* const element;

  int width = 0, height = 0;
  double fov = 0;
  std::string prior_path;
  int boundary_px = 0;
  bool edge_to_near = true;
  int memory_frames = 0;  // background-memory; 0: off
  std::string empty_room_path;
  std::string rig_path;
  int reference_id = 0;
  std::string trace_path;
  // Latest pose (a new session's first, then the highest seq within it). Until one arrives: the rig's
  // reference camera, or without a rig the source camera its caps describe (reference_from_caps).
  Pose pose;
  bool have_pose = false;
  bool reference_from_caps = false;  // no rig at start: each negotiation's camera is the view until a pose
  guint64 poses_received = 0;

  // Streaming thread only (the negotiated caps are the base class's: rgbd_filter_in_info, _out_info).
  cv::Mat prior;
  bool use_prior = false;  // the prior fits the negotiated camera size
  std::vector<PoseSample> trace;  // pose-trace, loaded at start
  uint64_t frames = 0;
  ViewWarper warper;
  WarpedView warped;
  FramePreparer preparer;   // the memory and the warp's first half, for frames viewprep did not prepare
  cv::Mat empty_room;       // empty-room, RGB: the memory's seed
  bool told_unprepared = false;  // the warning that a prepared frame's settings differ from ours
  // The viewfuse downstream drew the room at the last frame (its warp-start answer): this frame's room is
  // packed before the pose is read.
  bool room_view_last = false;
};

// The element's properties: installed on its class, read and written under ViewWarpState::lock().
void view_warp_install_properties(GObjectClass* klass);
void view_warp_set_property(ViewWarpState* st, GObject* object, guint prop_id, const GValue* value,
                            GParamSpec* pspec);
void view_warp_get_property(ViewWarpState* st, GObject* object, guint prop_id, GValue* value, GParamSpec* pspec);

}  // namespace vclassroom

namespace vclassroom {

// Why start() could not begin a stream: the message, the property that named the file, the error's code.
struct ViewWarpLoadError {
  GstResourceError code = GST_RESOURCE_ERROR_OPEN_READ;
  std::string message;
  std::string property;
};

// gstviewwarp_pose.cpp: what the view is before and between pose events.
// A new stream's reference pose (the rig's reference camera, or without a rig the caps' camera from the next
// negotiation), its pose trace, prior depth and empty room; false with *error when one cannot be loaded.
bool view_warp_load(ViewWarpState* st, ViewWarpLoadError* error);
// At negotiation: without a rig and before any pose, the camera the caps describe is the view.
void view_warp_reference_from_caps(ViewWarpState* st, const CameraCalib& camera);
// A pose event's pose, kept when it steers (a new session's first, then the highest seq within one).
void view_warp_take_pose(ViewWarpState* st, const Pose& pose);
// The pose the next frame shows: the trace's for its running time (or frame number), else the latest.
Pose view_warp_frame_pose(ViewWarpState* st, GstClockTime running_time);
// The pose frame `inbuf` shows, asked for at the last moment, after the pose-independent work, so that this
// work is not part of the pose's latency: first the warp-start query to the viewfuse downstream (live, it
// holds it until the view's other cameras have a frame too). `room_view`: whether that viewfuse draws the room
// itself (its room-view), so that this element warps only the learners; `room_cameras`: the cameras a far one
// may leave its learners to (none without an answer).
Pose view_warp_ask_pose(GstBaseTransform* trans, ViewWarpState* st, GstBuffer* inbuf, bool* room_view,
                        std::vector<RoomCameraPlace>* room_cameras);

}  // namespace vclassroom
