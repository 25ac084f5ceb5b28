// Camera calibration and the rig file (DESIGN.md §2.2, docs/rig-format.md).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

// One pinhole camera of the rig. Camera frames follow OpenCV (x right,
// y down, z forward); the rig frame is metric with Y up (DESIGN.md §2.2).
struct CameraCalib {
  int id = 0;
  std::string name;
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // OpenCV order: k1, k2, p1, p2, k3.
  std::array<double, 5> distortion{{0, 0, 0, 0, 0}};
  // Millimetres per raw unit of this sensor's depth images (1 for mm,
  // 0.2 for TUM-style 1/5000 m). The `video/x-rgbd` stream is always mm.
  double depth_scale = 1.0;
  // Maps camera coordinates to rig coordinates: p_rig = cam_to_rig * p_cam.
  Eigen::Isometry3d cam_to_rig = Eigen::Isometry3d::Identity();
  // Where the sensor's depth lens differs from its colour lens: maps depth
  // camera coordinates to colour camera coordinates. Sources register depth
  // to colour with it, so streams never carry it.
  std::optional<Eigen::Isometry3d> depth_to_color;
  // The depth lens's own image and pinhole intrinsics, where they differ
  // from the colour lens's (with depth_to_color only; absent: the same).
  struct DepthLens {
    int width = 0, height = 0;
    double fx = 0, fy = 0, cx = 0, cy = 0;
  };
  std::optional<DepthLens> depth_lens;

  bool has_distortion() const;
  Eigen::Matrix3d K() const;
  Eigen::Vector3d center_in_rig() const { return cam_to_rig.translation(); }

  // Pixel (u, v) with depth z (metres, along the optical axis) to a point in
  // this camera's frame. Undistorts when the camera has distortion.
  Eigen::Vector3d unproject(double u, double v, double z) const;
  // A point in this camera's frame to its pixel; nullopt behind the camera.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const;
  // Undistorted, normalised image coordinates of a pixel (z = 1 plane).
  Eigen::Vector2d normalized(double u, double v) const;
};

// Where a lecturer's view may go: a box of positions and a cone of view
// directions, as offsets from the reference camera in its own axes (the
// unbounded form of the paper's sliders, ViewOffset in pose.h), inside which
// the cameras show at least `coverage` of the view (docs/navigation.md).
struct NavigationBounds {
  int reference_camera = 0;
  double coverage = 0.9;  // the share of the view seen that the bounds were derived for
  // right, up, forward (metres), yaw, pitch, roll (degrees): the lowest and highest allowed.
  std::array<double, 6> min{{0, 0, 0, 0, 0, 0}};
  std::array<double, 6> max{{0, 0, 0, 0, 0, 0}};
};

struct Rig {
  std::string name;
  std::vector<CameraCalib> cameras;
  std::optional<NavigationBounds> navigation;  // the optional `navigation` section

  static constexpr int kMaxCameras = 8;

  // The camera whose `id` is `id`; throws Error if there is none.
  const CameraCalib& camera(int id) const;
  const CameraCalib* find(int id) const;
  // Maps points of camera `from` to camera `to`: p_to = T * p_from.
  Eigen::Isometry3d transform(int from, int to) const;
};

// The same camera (pose, field of view) at another image size, e.g. 480x270
// for previews or a small working size.
CameraCalib scale_camera(const CameraCalib& cam, int width, int height);
// The depth sensor of a camera with a separate depth lens as a camera of its
// own: the depth lens's intrinsics (the colour lens's when the rig gives none),
// no distortion, posed at cam_to_rig * depth_to_color. The camera itself when
// its depth is aligned with its colour.
CameraCalib depth_sensor_of(const CameraCalib& camera);

// Reads and validates a rig file (at most 1 MiB). Throws Error naming file,
// line, camera, field and what was expected (docs/rig-format.md).
Rig load_rig(const std::string& path);
// The same from text in memory; `file` names it in messages.
Rig parse_rig_text(const std::string& text, const std::string& file);
// The YAML that save_rig writes.
std::string rig_to_text(const Rig& rig);
// The plausible focal lengths (fx and fy, pixels) as multiples of the image's
// larger side: a fisheye is about 0.15 of it, a long telephoto tens of it.
inline constexpr double kMinFocalPerSide = 0.05;
inline constexpr double kMaxFocalPerSide = 100.0;
// Checks one camera's fields (sizes, finite positive focal lengths, a proper
// rotation...); `where` prefixes messages (e.g. "rig.yaml: camera 1").
void validate_camera(const CameraCalib& cam, const std::string& where);
// Checks the whole rig (1..8 cameras, unique ids, each camera valid). A rig's
// cameras (as every rig file's) must also have plausible intrinsics: fx and
// fy within kMinFocalPerSide..kMaxFocalPerSide times max(width, height), and
// the principal point on the image (-0.5 .. width - 0.5, -0.5 .. height - 0.5).
void validate_rig(const Rig& rig, const std::string& where);
// Throws Error when the navigation bounds (if any) name no camera of the rig,
// are not finite, exceed ±1000 m / ±180°, or leave out the reference view.
void validate_navigation(const Rig& rig);
// Writes a rig file that load_rig reads back exactly (doubles in full precision).
void save_rig(const Rig& rig, const std::string& path);

// Rotation helpers shared by rig files, caps and poses.
bool is_rotation(const Eigen::Matrix3d& r, double tol = 1e-4);

}  // namespace vclassroom
