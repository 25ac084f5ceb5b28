// The lecturer's virtual view as viewwarp and viewfuse set it up: its camera
// at the negotiated size, and the pose a pose trace gives each frame.
// GStreamer-free (docs/vva.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// The virtual camera's intrinsics before a pose: `src` scaled to width x
// height (when both are > 0 and differ from its size), its horizontal field
// of view set to fov_deg (when > 0), without distortion, at the rig's origin.
CameraCalib virtual_view_base(const CameraCalib& src, int width, int height, double fov_deg);

// viewwarp: the pose of a non-empty trace for the `frame`-th frame, at running
// time `running_time_s` (NaN: unknown). With a running time and a t column
// the trace's moment (every camera's frame of one instant gets the same pose,
// however far apart their threads run), else by frame number; the last pose
// is held. Its seq is the sample's index + 1, its viewer time the trace's t
// (so viewfuse's pose window compares two cameras' poses by how far apart the
// trace has them), -1 without one.
Pose trace_pose_for_frame(const std::vector<PoseSample>& trace, double running_time_s, uint64_t frame);

// viewfuse: the `n`-th pose it sends of a non-empty trace (the last one is
// held), seq the sample's index + 1; the viewer time is the caller's.
Pose trace_pose_in_turn(const std::vector<PoseSample>& trace, size_t n);

}  // namespace vclassroom
