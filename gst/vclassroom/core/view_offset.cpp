#include <gst/vclassroom/core/view_offset.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// YXZ intrinsic angles of R = Ry(yaw) Rx(pitch) Rz(roll).
Eigen::Matrix3d yaw_pitch_roll(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

}  // namespace

Pose offset_to_pose(const ViewOffset& o, const CameraCalib& ref) {
  const Eigen::Matrix3d R = ref.cam_to_rig.linear();
  Pose p;
  p.position = ref.cam_to_rig.translation() + R * Eigen::Vector3d(o.right, -o.up, o.forward);
  p.orientation = Eigen::Quaterniond(R * yaw_pitch_roll(o.yaw * kDeg, o.pitch * kDeg, o.roll * kDeg)).normalized();
  return p;
}

CameraCalib rig_origin_reference() {
  CameraCalib c;
  c.width = c.height = 1;
  c.fx = c.fy = 1;
  c.cam_to_rig.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  return c;
}

ViewOffset pose_to_offset(const Pose& p, const CameraCalib& ref) {
  const Eigen::Matrix3d R = ref.cam_to_rig.linear();
  const Eigen::Vector3d move = R.transpose() * (p.position - ref.cam_to_rig.translation());
  const Eigen::Matrix3d off = R.transpose() * p.orientation.normalized().toRotationMatrix();
  ViewOffset o;
  o.right = move.x();
  o.up = -move.y();
  o.forward = move.z();
  o.pitch = std::asin(std::clamp(-off(1, 2), -1.0, 1.0)) / kDeg;
  o.yaw = std::atan2(off(0, 2), off(2, 2)) / kDeg;
  o.roll = std::atan2(off(1, 0), off(1, 1)) / kDeg;
  return o;
}

ViewOffset sliders_to_offset(const Sliders& s) {
  return {(s[0] - 50) * kSliderMetres, (s[1] - 50) * kSliderMetres, (s[2] - 50) * kSliderMetres,
          (s[3] - 50) * kSliderDegrees, (s[4] - 50) * kSliderDegrees, (s[5] - 50) * kSliderDegrees};
}

Sliders offset_to_sliders(const ViewOffset& o) {
  return {50 + o.right / kSliderMetres, 50 + o.up / kSliderMetres, 50 + o.forward / kSliderMetres,
          50 + o.yaw / kSliderDegrees,  50 + o.pitch / kSliderDegrees, 50 + o.roll / kSliderDegrees};
}

Pose sliders_to_pose(const Sliders& s, const CameraCalib& ref) {
  for (double v : s)
    if (!std::isfinite(v) || v < 0 || v > 100) throw Error("sliders: each value must be between 0 and 100");
  return offset_to_pose(sliders_to_offset(s), ref);
}

Sliders pose_to_sliders(const Pose& p, const CameraCalib& ref) { return offset_to_sliders(pose_to_offset(p, ref)); }

Sliders parse_sliders(const std::string& text) {
  std::string t = text;
  for (char& c : t)
    if (c == '[' || c == ']' || c == ',' || c == ';') c = ' ';
  std::istringstream is(t);
  Sliders s;
  std::string tok;
  size_t n = 0;
  while (is >> tok) {
    if (n == 6) throw Error("sliders '" + text + "': expected 6 values, got more");
    char* end = nullptr;
    double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0' || !std::isfinite(v))
      throw Error("sliders '" + text + "': '" + tok + "' is not a number");
    if (v < 0 || v > 100) throw Error("sliders '" + text + "': '" + tok + "' is outside 0..100");
    s[n++] = v;
  }
  if (n != 6) throw Error("sliders '" + text + "': expected 6 values like [50,50,50,50,50,50], got " + std::to_string(n));
  return s;
}

std::string format_sliders(const Sliders& s) {
  std::ostringstream os;
  os.precision(10);
  os << '[';
  for (size_t i = 0; i < s.size(); ++i) os << (i ? "," : "") << s[i];
  os << ']';
  return os.str();
}

// How far the view's horizon is rolled in the rig (Y up), radians: 0 when the view's X axis is level; the
// angle a turn about the view's own axis adds. NaN looking (nearly) straight up or down, where the horizon
// is not in the view.
static double horizon_roll(const Eigen::Quaterniond& orientation) {
  const Eigen::Matrix3d R = orientation.normalized().toRotationMatrix();
  if (std::abs(R(1, 2)) > 0.99) return std::nan("");
  return std::atan2(-R(1, 0), -R(1, 1));
}

bool clamp_to_navigation(const NavigationBounds& bounds, const CameraCalib& reference, Pose* pose) {
  const ViewOffset o = pose_to_offset(*pose, reference);
  std::array<double, 6> v{{o.right, o.up, o.forward, o.yaw, o.pitch, o.roll}};
  bool outside = false;
  for (size_t i = 0; i < v.size(); ++i) {
    // A hair of tolerance: a pose made at the boundary (e.g. by posenav's own
    // clamping) comes back from the decomposition a rounding error outside it.
    const double eps = i < 3 ? 1e-9 : 1e-7;
    if (v[i] < bounds.min[i] - eps || v[i] > bounds.max[i] + eps) outside = true;
    v[i] = std::clamp(v[i], bounds.min[i], bounds.max[i]);
  }
  if (!outside) return false;
  // Only where it looks moves: seq, session, times and field of view stay the lecturer's.
  Pose clamped = offset_to_pose(ViewOffset{v[0], v[1], v[2], v[3], v[4], v[5]}, reference);
  // The offsets' yaw turns about the reference camera's own axis, tilted when it looks down: a yaw clamped
  // alone would roll the horizon the lecturer kept level. A turn about the view's own axis (the roll offset,
  // applied last) gives back the asked horizon, as far as the roll range allows.
  const double roll_change = (horizon_roll(pose->orientation) - horizon_roll(clamped.orientation)) / kDeg;
  if (std::isfinite(roll_change) && std::abs(roll_change) > 1e-9) {
    v[5] = std::clamp(v[5] + std::remainder(roll_change, 360.0), bounds.min[5], bounds.max[5]);
    clamped = offset_to_pose(ViewOffset{v[0], v[1], v[2], v[3], v[4], v[5]}, reference);
  }
  pose->position = clamped.position;
  pose->orientation = clamped.orientation;
  pose->clamped = true;
  return true;
}

}  // namespace vclassroom
