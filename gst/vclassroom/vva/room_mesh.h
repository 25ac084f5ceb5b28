// Experiment (issue 31, wip/room-lookup): a quadtree mesh of a camera's static depth (V-DA's prior, which
// does not change): a tile (its grid of pixel centres, border included, so neighbours meet) is two triangles
// when its depth lies on one plane (1/z linear in u and v, as a plane seen by a pinhole camera) within a
// tolerance; otherwise it splits, down to single pixel quads (two triangles, as the warp's mesh; a quad across
// a depth edge, beyond max(15 mm, 3 %), is dropped). GStreamer-free.
#pragma once

#include <opencv2/core.hpp>

namespace vclassroom {

struct RoomMeshCount {
  long tiles[8] = {0};  // leaves by level (size 1 << level px)
  long dropped = 0;     // pixel quads across an edge or without depth
  long triangles() const {
    long t = 0;
    for (long n : tiles) t += 2 * n;
    return t;
  }
};

// The quadtree of `depth` (CV_16UC1 mm) with tiles of at most 1 << top px, planar within
// max(min_mm, ratio * z). `planar` (optional): the depth as the mesh gives it at each pixel centre (a tile's
// plane inside it; the depth itself in single pixel quads).
RoomMeshCount room_mesh(const cv::Mat& depth, double ratio, double min_mm, int top, cv::Mat* planar = nullptr);

}  // namespace vclassroom
