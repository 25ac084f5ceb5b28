// The lecturer's 6DoF pose (DESIGN.md §2.3, docs/pose.md): the type, its checks and its session. The
// event that carries it is pose_event.h, the paper's sliders and the navigation bounds view_offset.h, pose
// traces pose_trace.h, and its wire format net/pose_wire.h. GStreamer-free.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include <Eigen/Geometry>

namespace vclassroom {

// Positions farther than this from the rig origin are rejected as absurd.
inline constexpr double kMaxPoseDistance = 1000.0;  // metres
// Quaternions whose norm is farther than this from 1 are rejected.
inline constexpr double kUnitQuaternionTolerance = 1e-3;

// The virtual camera's pose in the rig frame: `position` is its optical
// centre, `orientation` rotates virtual-camera coordinates (OpenCV axes) into
// rig coordinates, exactly like a rig camera's cam_to_rig.
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  double fov_deg = std::numeric_limits<double>::quiet_NaN();  // optional horizontal field of view
  uint64_t seq = 0;
  // Whose stream the pose belongs to: seqs are ordered only within one
  // session (docs/network.md, "Sessions"). Named by the receiver that obeyed
  // the pose (pose_session_id()); 0: unnamed, one local source.
  uint64_t session = 0;
  int64_t viewer_time_ns = -1;  // -1: not given
  // The server moved this pose into the rig's navigation bounds (docs/navigation.md); carried by the pose
  // event to the renderers and echoed with the frame, never sent by a client.
  bool clamped = false;

  bool has_fov() const { return std::isfinite(fov_deg); }
  Eigen::Isometry3d cam_to_rig() const;
  static Pose from_cam_to_rig(const Eigen::Isometry3d& T);
};

// The pose a frame shows, as the server rendered it: after the navigation bounds moved it in, so the lecturer's
// side learns where it really is. Plain floats, as it rides in a GstMeta and on the wire (pose_stamp.h).
struct RenderedPose {
  bool known = false;    // false: the frame names only the pose's seq and viewer time
  bool clamped = false;  // the lecturer's pose was outside the navigation bounds and was moved in
  float position[3] = {0, 0, 0};         // rig metres
  float orientation[4] = {1, 0, 0, 0};  // unit quaternion w, x, y, z (virtual camera -> rig)
};
RenderedPose rendered_pose_of(const Pose& pose);
// The pose it names (seq and viewer time unset), for a known one.
Pose pose_of(const RenderedPose& rendered);
// False when the values are not a usable pose (not finite, absurd position, not a unit quaternion at float
// precision): it came from the network.
bool rendered_pose_is_valid(const RenderedPose& rendered);

// A session's number in pose events from the receiver's name for it (an RTP
// stream's SSRC and session number, a WHEP session id): a stable 64-bit hash,
// never 0.
uint64_t pose_session_id(const std::string& name);
// A fresh random session number for a local pose source that starts (never 0).
uint64_t new_pose_session_id();

// Throws Error when the pose is not usable: NaN, non-unit quaternion, absurd
// position or field of view.
void validate_pose(const Pose& pose);

}  // namespace vclassroom
