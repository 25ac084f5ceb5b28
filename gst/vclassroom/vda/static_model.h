// The static classroom model of V-DA (PAPER.md "V-DA" step 1, docs/vda.md):
// from a short capture of the empty room by every camera, refine the rig's
// extrinsics by ICP, fuse the cameras' point clouds, find the room's planes
// and project the model into each camera as its prior depth D_i. Also the
// model folder that the depthcomplete and planerefine elements read.
// GStreamer-free.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <gst/vclassroom/vda/depth_completion.h>
#include <gst/vclassroom/vda/plane_refine.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// A few frames of one camera looking at the empty room.
struct CameraCapture {
  int camera_id = 0;
  std::vector<cv::Mat> depth;  // CV_16UC1 mm, 0 = missing
  cv::Mat color;               // CV_8UC3 RGB (one frame), guides the offline hole fill
};

struct StaticModelOptions {
  bool refine_extrinsics = true;
  int icp_iterations = 40;
  int icp_stride = 4;              // use every n-th pixel of each camera's depth
  double icp_max_distance_m = 0.10;
  double voxel_m = 0.01;           // fused cloud resolution
  double plane_distance_m = 0.02;  // RANSAC inlier distance
  int max_planes = 12;
  double min_plane_share = 0.01;   // a plane explains at least this share of the fused points
  int ransac_iterations = 400;
  uint64_t seed = 1;
  // Fill each camera's unmeasured pixels from the other cameras' points (the fused cloud projected in).
  bool fill_from_other_cameras = true;
  // Snap prior pixels to the planes (part of V-DA's planar refinement; off for
  // its "without planes" ablation), with this tolerance.
  bool snap_planes = true;
  PlaneTolerance plane_tolerance{20, 0.01};
  // Nothing is seen beyond the room: a prior pixel no camera measured is
  // kept in front of the room's bounding planes (walls, floor, ceiling: the
  // planes with at most boundary_outlier_share of the points behind them).
  // Where nothing overhead was measured (and a floor was: the rig is Y up), a
  // level ceiling is assumed where the walls end at the top, and the
  // unmeasured pixels that look at it take it.
  // The completion alone had filled the unmeasured ceiling and window 3 %
  // and more too far (docs/vda.md).
  bool close_room = true;
  double boundary_outlier_share = 0.005;
  // With close_room: whether each unmeasured pixel lies on the room's bound or
  // in front of it is propagated by colour from the measured pixels, as its
  // depth is, and those on it take the bound's depth (a wall's unmeasured strip
  // follows the wall's slant instead of a neighbour's depth stretched flat).
  bool unmeasured_side_by_colour = true;
  // ... from at most this share of the bound's depth in front of it: the
  // mullion's strip stood up to 6 % in front of its wall; a fifth keeps every
  // pull the synthetic room gains from (a tenth lost 0.05 dB of Table I's room
  // view) and leaves what stands farther out, a chair seat or a desk's shelf
  // that looks like the floor, where the completion put it.
  double unmeasured_max_pull = 0.2;
  // Offline completion of each prior: image-guided fill, then colorization.
  GuidedCompletionParams guided;
  ColorizationParams colorize{1000, 12.0, 0.0, 1.8};
};

// How much ICP moved one camera's extrinsics, and how well it fits.
struct ExtrinsicsChange {
  int camera_id = 0;
  double translation_mm = 0;
  double rotation_deg = 0;
  int pairs = 0;              // point pairs in the last iteration
  double rms_before_mm = 0;   // point-to-plane residual against the reference camera
  double rms_after_mm = 0;
};

struct StaticModel {
  Rig rig;                                // with refined extrinsics
  std::vector<Eigen::Vector3f> points;    // fused cloud, rig frame, metres
  std::vector<cv::Vec3b> colors;          // RGB per point
  std::vector<RoomPlane> planes;          // rig frame
  std::map<int, cv::Mat> prior_depth;     // camera id -> D_i (CV_16UC1 mm, camera size)
  std::map<int, cv::Mat> prior_color;     // camera id -> the empty room's colour (CV_8UC3 RGB); may be absent
  std::map<int, cv::Mat> prior_measured;  // camera id -> 255 where D_i was measured, 0 where filled; may be absent
  std::vector<ExtrinsicsChange> refinement;  // one per camera but the reference

  // D_i of camera `id`; throws Error when the model has none.
  const cv::Mat& prior(int id) const;
  // The empty room's colour seen by camera `id`; an empty Mat when unknown.
  cv::Mat color(int id) const;
  // Everything depthcomplete needs of camera `id`; throws Error when the model has no prior for it.
  StaticPrior prior_for(int id) const;
};

// Per-pixel median of the valid measurements of several depth frames (robust
// to flying pixels); pixels measured in fewer than `min_share` of the frames stay 0.
cv::Mat median_depth(const std::vector<cv::Mat>& frames, double min_share = 0.5);

// Refines the extrinsics of every camera but the rig's first against the
// first (point-to-plane ICP with projective association). Returns the changes
// and updates `rig`.
std::vector<ExtrinsicsChange> refine_extrinsics(Rig& rig, const std::map<int, cv::Mat>& depth,
                                                const StaticModelOptions& o);

// Projects a cloud into a camera with a z-buffer (each point a small square
// sized by the voxel size); 0 where nothing lands.
cv::Mat splat_depth(const std::vector<Eigen::Vector3f>& points, const CameraCalib& cam, double voxel_m);

// The whole model. Throws Error on captures that do not match the rig.
StaticModel build_static_model(const Rig& rig, const std::vector<CameraCapture>& captures,
                               const StaticModelOptions& o = {});

// Re-aligns the rig frame to the paper's convention: Y up from the floor plane
// (origin height kept: the floor becomes Y = -height of the first camera),
// X along the widest vertical plane facing the cameras (the blackboard wall).
// Moves rig, planes and points; priors are per camera and unchanged.
// Returns false (changing nothing) when the model has no floor plane.
bool align_model_to_room(StaticModel& m);

// Model folder: rig.yaml (refined rig), planes.csv, prior-depth/cam<ID>.png,
// prior-color/cam<ID>.png, prior-measured/cam<ID>.png, fused.ply, refinement.csv. Throws Error naming the file.
void save_static_model(const StaticModel& m, const std::string& folder);
// Reads rig.yaml, planes.csv, every camera's prior depth and (when present)
// colour; the cloud is not needed per frame and not read. Throws Error naming the folder and file.
StaticModel load_static_model(const std::string& folder);
// Why a camera stream (its camera-id and size) cannot use the model read from
// `folder`: no such camera, or the camera at another size; "" when it can.
// The stream comes from the network, so this is the stream's fault, not the
// model's: the elements drop its frames with a warning rather than stop.
std::string model_stream_mismatch(const StaticModel& m, const std::string& folder, int camera_id, int width,
                                  int height);

// Writes a binary little-endian PLY (x y z float, red green blue uchar).
void write_ply(const std::string& path, const std::vector<Eigen::Vector3f>& points,
               const std::vector<cv::Vec3b>& colors);

}  // namespace vclassroom
