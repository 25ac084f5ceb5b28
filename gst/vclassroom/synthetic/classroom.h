// The synthetic classroom (docs/synthetic-classroom.md): a procedurally built
// multimedia classroom with moving learners, an exact ground-truth renderer for
// any camera, and a consumer RGB-D sensor model. GStreamer-free.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// Room size of the paper's multimedia classroom (metres).
inline constexpr double kClassroomWidth = 6.0;   // along rig X
inline constexpr double kClassroomDepth = 5.0;   // along rig Z
inline constexpr double kClassroomHeight = 2.4;  // floor to ceiling
// Four rows of three double desks: the most learners that can have a seat.
inline constexpr int kClassroomMaxLearners = 24;

struct ClassroomConfig {
  // Everything random (textures, chalk writing, who sits where, clothing,
  // what each learner does when) follows from the seed.
  uint64_t seed = 1;
  // 0 = the empty room; at most kClassroomMaxLearners.
  int learners = 3;
  // Height of the rig origin (the centre camera) above the floor: the floor is
  // the plane Y = -camera_height of the rig frame (DESIGN.md §2.2).
  double camera_height = 2.0;
};

// What a learner is doing at an instant (for logs, docs and tests).
struct LearnerState {
  int id = 0;                  // 1-based, as in the label plane
  std::string action;          // "sit", "write", "look-around", "raise-hand", "stand-up", "walk-to-board"
  Eigen::Vector3d position;    // rig frame, on the floor under the pelvis
  double heading = 0;          // radians about +Y; 0 = facing the board (+Z)
};

// The immutable scene: static geometry with precomputed textures and the
// learners' behaviour. Cheap to copy (copies share the scene) and safe to
// render from several threads at once.
class Classroom {
 public:
  explicit Classroom(const ClassroomConfig& config = {});

  const ClassroomConfig& config() const;
  int learner_count() const;
  // Y of the floor and ceiling, Z of the front (blackboard) and back walls,
  // X of the left and right walls, in the rig frame.
  double floor_y() const;
  double ceiling_y() const;
  double front_z() const;
  double back_z() const;
  double left_x() const;
  double right_x() const;
  // Learner k (1-based) at scene time t (seconds); a pure function of (seed, k, t).
  LearnerState learner(int k, double t) const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Impl> impl_;
};

// Per visible surface of a rendered frame, what a depth sensor needs to know.
struct SurfaceInfo {
  Eigen::Vector3f normal_cam = Eigen::Vector3f::Zero();  // unit, camera frame, towards the camera
  float ir_albedo = 0;  // 0..1 near-infrared reflectivity
  float gloss = 0;      // 0..1 share of specular (dropout-prone) reflection
  uint8_t label = 0;    // 0 static, k learner k
};

// One rendered view. All images have the camera's size.
struct RenderOutput {
  cv::Mat color;    // CV_8UC3, RGB
  cv::Mat depth;    // CV_16UC1, mm along the optical axis, rounded; 0 = nothing (or beyond 65.535 m)
  cv::Mat label;    // CV_8UC1, 0 = static scene, k = learner k (1-based)
  cv::Mat surface;  // CV_16UC1, index into `surfaces`; 0 = nothing
  std::vector<SurfaceInfo> surfaces;  // [0] is the empty entry
};

// Z-buffered rasterizer of the scene's planar convex polygons with
// perspective-correct texturing. Pixel (u, v) shows the surface hit by the ray
// through the pixel centre (u, v) under CameraCalib's pinhole model
// (x = fx X/Z + cx); lens distortion is ignored (documented). Keeps its
// scratch buffers between calls, so reuse one per thread for speed.
class ClassroomRenderer {
 public:
  ClassroomRenderer();
  ~ClassroomRenderer();
  ClassroomRenderer(const ClassroomRenderer&) = delete;
  ClassroomRenderer& operator=(const ClassroomRenderer&) = delete;

  // Reuses out's images when they have the right size and type.
  void render(const Classroom& scene, double t, const CameraCalib& cam, RenderOutput* out);

 private:
  struct Scratch;
  std::unique_ptr<Scratch> s_;
};

// One-shot convenience wrapper of ClassroomRenderer.
RenderOutput render(const Classroom& scene, double t, const CameraCalib& cam);

// A consumer time-of-flight / structured-light camera (Azure Kinect-like).
// The measured ranges of the defaults are in docs/synthetic-classroom.md.
struct SensorParams {
  // Depth noise: sigma(z) = sigma_mm_per_m2 * z^2 (z in metres), in mm.
  double sigma_mm_per_m2 = 1.0;
  // Returned signal ~ ir_albedo * cos(incidence) / z^2; below signal_min the
  // pixel is always missing, above signal_ok never (for that reason).
  double signal_min = 0.004;
  double signal_ok = 0.012;
  // Incidence angles (degrees) between which grazing pixels drop out.
  double grazing_start_deg = 72;
  double grazing_full_deg = 84;
  // Glossy surfaces drop out in blobs covering up to this share of them.
  double gloss_dropout = 0.7;
  // Depth field of view, in normalised image coordinates (x/z, y/z): pixels
  // outside the ellipse (x/ax)^2 + (y/ay)^2 = 1 have no depth (unit: tan).
  double fov_ax = 1.02;
  double fov_ay = 0.7;
  // A pixel is a depth edge when a 4-neighbour is nearer by more than this
  // share of its depth (and at least edge_min_mm). Edge pixels become flying
  // pixels (depth between the two surfaces) or drop out.
  double edge_ratio = 0.04;
  double edge_min_mm = 30;
  double flying_prob = 0.5;
  double edge_drop_prob = 0.3;
  // Colour noise: Gaussian-like, sigma in 8-bit levels.
  double color_sigma = 2.0;
};

// Depth noise sigma (mm) the model uses at depth z (metres).
double sensor_depth_sigma_mm(const SensorParams& p, double z_m);
// Pixels of a clean depth image that the model may turn into flying pixels or
// holes because they sit on a depth discontinuity (CV_8UC1, 255 = edge).
cv::Mat sensor_edge_mask(const cv::Mat& clean_depth, const SensorParams& p);
// Applies the model to a clean render: `depth` gets the measured depth
// (CV_16UC1 mm, 0 = missing), `color` the noisy colour. Deterministic in
// (seed, frame); never invents depth where clean depth is 0.
void apply_sensor_model(const RenderOutput& clean, const CameraCalib& cam, const SensorParams& p, uint64_t seed,
                        uint64_t frame, cv::Mat* depth, cv::Mat* color);

// The default rig: three 960x540 cameras in a horizontal row at the front of
// the room, 0.8 m apart, looking at the class 20 degrees downward, with Azure
// Kinect colour-like intrinsics (90 x 59 degrees: fx = fy = 480, cx = 479.5,
// cy = 269.5). Id 0 is the centre camera at the rig origin, id 1 the left one
// (X = -0.8 m) and id 2 the right one (X = +0.8 m), left and right as seen
// from the cameras.
Rig default_classroom_rig();
// A camera with the default rig's intrinsics at `position` looking at
// `target` with the rig's Y up (e.g. a lecturer's or a novel view).
CameraCalib look_at_camera(const Eigen::Vector3d& position, const Eigen::Vector3d& target, int width = 960,
                           int height = 540, double hfov_deg = 90.0);

}  // namespace vclassroom
