// A view relative to a reference camera: the paper's six sliders, their unbounded form (ViewOffset), and
// the navigation bounds that keep a pose where the cameras see (docs/pose.md, docs/navigation.md).
#pragma once

#include <array>
#include <string>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// The paper's mouse interface writes a view as six sliders 0..100, where
// [50,50,50,50,50,50] is the reference camera. Mapping (docs/pose.md):
//   s[0..2]: move right / up / forward in the reference camera's own axes,
//            (s - 50) * kSliderMetres each (±1 m);
//   s[3..5]: yaw (turn right) / pitch (look up) / roll (clockwise),
//            (s - 50) * kSliderDegrees each (±90°), applied yaw, then pitch, then roll.
using Sliders = std::array<double, 6>;
inline constexpr double kSliderMetres = 0.02;
inline constexpr double kSliderDegrees = 1.8;

// A view relative to a reference camera, in that camera's own axes: the
// unbounded form of the sliders (which are this, scaled and offset by 50).
struct ViewOffset {
  double right = 0, up = 0, forward = 0;  // metres
  double yaw = 0, pitch = 0, roll = 0;    // degrees: turn right, look up, roll clockwise
};
Pose offset_to_pose(const ViewOffset& o, const CameraCalib& reference);
// The reference when no rig is known: a camera at the rig origin looking
// level along -Z (rotation diag(1, -1, -1), rig Y up).
CameraCalib rig_origin_reference();
ViewOffset pose_to_offset(const Pose& pose, const CameraCalib& reference);
ViewOffset sliders_to_offset(const Sliders& s);
Sliders offset_to_sliders(const ViewOffset& o);

// The pose nearest to `pose` inside the navigation bounds (each of the six
// offsets from the reference camera clamped to its range). Returns false and
// leaves `pose` untouched, bit for bit, when it is inside already. seq,
// session, viewer time and field of view are kept; `clamped` is set.
bool clamp_to_navigation(const NavigationBounds& bounds, const CameraCalib& reference, Pose* pose);

Pose sliders_to_pose(const Sliders& s, const CameraCalib& reference);
// Inverse of sliders_to_pose for poses within the sliders' range (|pitch| < 90°).
Sliders pose_to_sliders(const Pose& pose, const CameraCalib& reference);
// Parses "[50,50,50,50,50,50]" (brackets optional, comma or space separated); throws Error.
Sliders parse_sliders(const std::string& text);
std::string format_sliders(const Sliders& s);

}  // namespace vclassroom
