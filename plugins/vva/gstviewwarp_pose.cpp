// viewwarp's pose: the reference view before the first pose event, the events that steer it, the pose
// trace that overrides them (docs/vva.md, docs/network.md "Sessions").
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <cmath>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/virtual_view.h>
#include <gst/vclassroom/vva/warp_start.h>

#include "gstviewwarp_state.h"

namespace vclassroom {

bool view_warp_load(ViewWarpState* st, ViewWarpLoadError* error) {
  std::string prior_path, rig_path, trace_path, empty_room_path;
  int ref;
  {
    const auto g = st->lock();
    prior_path = st->prior_path;
    empty_room_path = st->empty_room_path;
    rig_path = st->rig_path;
    trace_path = st->trace_path;
    ref = st->reference_id;
  }
  const auto fail = [&](GstResourceError code, std::string message, const char* property) {
    *error = {code, std::move(message), property};
    return false;
  };
  // Until the first pose event: the rig's reference camera. Without a rig there is no calibration but the
  // stream's own, so the caps' camera is the view (view_warp_reference_from_caps()); a built-in rig would
  // show a real classroom the synthetic one's camera.
  if (rig_path.empty()) {
    const auto g = st->lock();
    st->pose = Pose();
    st->have_pose = false;
    st->reference_from_caps = true;
  } else {
    try {
      const Rig rig = load_rig(rig_path);
      const CameraCalib* c = rig.find(ref);
      if (!c)
        return fail(GST_RESOURCE_ERROR_SETTINGS,
                    "reference-camera " + std::to_string(ref) + " is not in the rig " + rig_path, "reference-camera");
      const auto g = st->lock();
      st->pose = Pose::from_cam_to_rig(c->cam_to_rig);
      st->have_pose = false;
      st->reference_from_caps = false;
    } catch (const Error& e) {
      return fail(GST_RESOURCE_ERROR_OPEN_READ, e.what(), "rig");
    }
  }
  st->trace.clear();
  st->frames = 0;
  if (!trace_path.empty()) {
    try {
      st->trace = load_pose_trace(trace_path);
    } catch (const Error& e) {
      return fail(GST_RESOURCE_ERROR_OPEN_READ, e.what(), "pose-trace");
    }
    if (st->trace.empty())
      return fail(GST_RESOURCE_ERROR_OPEN_READ, "pose trace " + trace_path + " has no poses", "pose-trace");
  }
  st->prior.release();
  st->empty_room.release();
  try {
    if (!prior_path.empty()) st->prior = load_static_depth(prior_path);
    if (!empty_room_path.empty()) st->empty_room = load_empty_room(empty_room_path);
  } catch (const Error& e) {
    return fail(GST_RESOURCE_ERROR_OPEN_READ, e.what(), "prior-depth and empty-room");
  }
  return true;
}

void view_warp_reference_from_caps(ViewWarpState* st, const CameraCalib& camera) {
  const auto g = st->lock();
  // A renegotiation that brings another calibration before any pose moves the view with it.
  if (st->reference_from_caps && !st->have_pose) st->pose = Pose::from_cam_to_rig(camera.cam_to_rig);
}

void view_warp_take_pose(ViewWarpState* st, const Pose& pose) {
  const auto g = st->lock();
  ++st->poses_received;
  // The receiver upstream of the fuse chose the session; a pose of another session than the one shown is
  // the new steering one (docs/network.md, "Sessions"), and within a session the latest seq wins.
  const Pose& shown = st->pose;
  if (!st->have_pose || pose.session != shown.session || pose.seq >= shown.seq) {
    st->pose = pose;
    st->have_pose = true;
  }
}

Pose view_warp_frame_pose(ViewWarpState* st, GstClockTime running_time) {
  Pose pose;
  {
    const auto g = st->lock();
    pose = st->pose;
  }
  if (!st->trace.empty()) {
    // The frame's own moment of the trace (trace_pose_for_frame()).
    pose = trace_pose_for_frame(st->trace, GST_CLOCK_TIME_IS_VALID(running_time) ? double(running_time) / GST_SECOND
                                                                                 : NAN,
                                st->frames);
  }
  ++st->frames;
  return pose;
}

Pose view_warp_ask_pose(GstBaseTransform* trans, ViewWarpState* st, GstBuffer* inbuf, bool* room_view,
                        std::vector<RoomCameraPlace>* room_cameras) {
  const GstClockTime running_time = trans->segment.format == GST_FORMAT_TIME && GST_BUFFER_PTS_IS_VALID(inbuf)
                                       ? gst_segment_to_running_time(&trans->segment, GST_FORMAT_TIME, GST_BUFFER_PTS(inbuf))
                                       : GST_CLOCK_TIME_NONE;
  // Live, viewfuse holds this until the view's other cameras have a frame to warp too (its warp-sync), so
  // that all read the same newest pose below.
  GstQuery* warp_start = gst_query_new_custom(
      GST_QUERY_CUSTOM, gst_structure_new(kWarpStartQueryName, "running-time", G_TYPE_UINT64, running_time, nullptr));
  gboolean fuse_draws_room = FALSE;
  room_cameras->clear();
  if (gst_pad_peer_query(GST_BASE_TRANSFORM_SRC_PAD(trans), warp_start)) {
    gst_structure_get_boolean(gst_query_get_structure(warp_start), "room-view", &fuse_draws_room);
    *room_cameras = warp_start_room_cameras(gst_query_get_structure(warp_start));
  }
  gst_query_unref(warp_start);
  *room_view = fuse_draws_room;
  return view_warp_frame_pose(st, running_time);
}

}  // namespace vclassroom
