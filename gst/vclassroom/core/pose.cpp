#include <gst/vclassroom/core/pose.h>

#include <cmath>
#include <sstream>

#include <glib.h>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

Eigen::Isometry3d Pose::cam_to_rig() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = orientation.normalized().toRotationMatrix();
  T.translation() = position;
  return T;
}

Pose Pose::from_cam_to_rig(const Eigen::Isometry3d& T) {
  Pose p;
  p.position = T.translation();
  p.orientation = Eigen::Quaterniond(T.linear()).normalized();
  return p;
}

uint64_t pose_session_id(const std::string& name) {
  // FNV-1a: stable across runs and machines, so a log's session numbers can be compared.
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ull;
  return h != 0 ? h : 1;
}

uint64_t new_pose_session_id() {
  uint64_t id = 0;
  while (id == 0) id = (static_cast<uint64_t>(g_random_int()) << 32) | g_random_int();
  return id;
}

void validate_pose(const Pose& p) {
  if (!p.position.allFinite()) throw Error("pose: position is not finite (NaN or infinity)");
  if (p.position.norm() > kMaxPoseDistance) {
    std::ostringstream os;
    os << "pose: position (" << p.position.x() << ", " << p.position.y() << ", " << p.position.z() << ") is "
       << p.position.norm() << " m from the rig origin (expected at most " << kMaxPoseDistance << " m)";
    throw Error(os.str());
  }
  const Eigen::Vector4d q = p.orientation.coeffs();
  if (!q.allFinite()) throw Error("pose: orientation quaternion is not finite (NaN or infinity)");
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) {
    std::ostringstream os;
    os << "pose: orientation quaternion has norm " << q.norm() << " (expected a unit quaternion, ±"
       << kUnitQuaternionTolerance << ")";
    throw Error(os.str());
  }
  if (p.has_fov() && !(p.fov_deg > 1.0 && p.fov_deg < 179.0)) {
    std::ostringstream os;
    os << "pose: fov " << p.fov_deg << " deg out of range (expected 1 to 179)";
    throw Error(os.str());
  }
  if (!std::isnan(p.fov_deg) && !std::isfinite(p.fov_deg)) throw Error("pose: fov is infinite");
}

RenderedPose rendered_pose_of(const Pose& pose) {
  RenderedPose r;
  r.known = true;
  r.clamped = pose.clamped;
  for (int i = 0; i < 3; ++i) r.position[i] = static_cast<float>(pose.position[i]);
  const Eigen::Quaterniond q = pose.orientation.normalized();
  r.orientation[0] = static_cast<float>(q.w());
  r.orientation[1] = static_cast<float>(q.x());
  r.orientation[2] = static_cast<float>(q.y());
  r.orientation[3] = static_cast<float>(q.z());
  return r;
}

Pose pose_of(const RenderedPose& r) {
  Pose p;
  p.position = Eigen::Vector3d(r.position[0], r.position[1], r.position[2]);
  p.orientation = Eigen::Quaterniond(r.orientation[0], r.orientation[1], r.orientation[2], r.orientation[3]).normalized();
  p.clamped = r.clamped;
  return p;
}

bool rendered_pose_is_valid(const RenderedPose& r) {
  double distance2 = 0, norm2 = 0;
  for (float v : r.position) {
    if (!std::isfinite(v)) return false;
    distance2 += double(v) * v;
  }
  for (float v : r.orientation) {
    if (!std::isfinite(v)) return false;
    norm2 += double(v) * v;
  }
  // Rounded to float, a unit quaternion's norm is within about 1e-7 of 1.
  return distance2 <= kMaxPoseDistance * kMaxPoseDistance && std::abs(std::sqrt(norm2) - 1.0) <= kUnitQuaternionTolerance;
}

}  // namespace vclassroom
