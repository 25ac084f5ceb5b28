// A room's planes (walls, floor, ceiling, desks) found in a point cloud: V-DA's static model finds them in
// the fused cloud, the rig calibration in one camera's depth (to level the rig). GStreamer-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace vclassroom {

// A plane of the static room in the rig frame: normal . p + offset = 0 (p in
// metres, |normal| = 1, normal towards the room's inside / the cameras).
struct RoomPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  double offset = 0;
  std::string name;  // "floor", "ceiling", "wall", "desk", "plane"
  int inliers = 0;   // fused-model points it explains
};

// How planes are found: RANSAC inlier distance, at most max_planes, each explaining at least min_share of
// the points, iterations per plane, and the random seed (the result is reproducible).
struct PlaneFinding {
  double distance_m = 0.02;
  int max_planes = 12;
  double min_share = 0.01;
  int iterations = 400;
  uint64_t seed = 1;
};

// Sequential RANSAC plane finding with a least-squares refit of each plane; normals turned towards
// `viewpoint`; named "floor" (the lowest level plane), "ceiling", "desk", "wall" or "plane" (rig Y up).
std::vector<RoomPlane> find_planes(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& viewpoint,
                                   const PlaneFinding& o = {});

}  // namespace vclassroom
