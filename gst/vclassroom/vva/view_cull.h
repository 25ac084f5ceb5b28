// Which parts of a source camera can land in a lecturer's view (docs/vva.md,
// "Only what can land in the view"). A lecturer who turns or walks sees part
// of what a camera sees; the warp's per-pixel work - projection, links, cell
// set-up - is then spent only on the source columns whose points can reach
// the view. The source is cut into tiles of kTileSize pixels; for each tile,
// what does not depend on the pose is kept (the box its pixels' rays span,
// from the camera's intrinsics; its nearest and farthest depth, from the
// frame), and per view each tile's 3-D extent (a frustum piece: its rays
// between its two depths) is projected into the view. GStreamer-free.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

constexpr int kTileSize = 16;  // source pixels per tile side (the last column and row of tiles may be narrower)

struct TileGrid {
  int cols = 0, rows = 0;  // tiles across and down: ceil(width / kTileSize), ceil(height / kTileSize)
};
TileGrid tile_grid(int width, int height);

// Per tile, the smallest and largest ray_x and ray_y (the normalised rays, x / z and y / z) over its pixels
// and the pixels around it (one more on every side, clamped to the image): four floats a tile, row by row.
// Depends on the camera's intrinsics only.
void tile_ray_boxes(int width, int height, const float* ray_x, const float* ray_y, std::vector<float>* boxes);

// Per tile, the nearest and farthest non-zero depth (mm) of `depth` (width x height) over the tile and the
// pixels around it (one more on every side, as the ray boxes: a cell at the tile's edge is shaped by its
// neighbour across it); both 0 where there is none.
void tile_depth_ranges(int width, int height, const uint16_t* depth, std::vector<uint16_t>* nearest,
                       std::vector<uint16_t>* farthest);

// The view a warp draws into: the source camera's frame -> the view's (row-major rotation, translation,
// metres), the view's intrinsics and size.
struct ViewFrustum {
  float r[9], t[3];
  float fx, fy, cx, cy;
  int width, height;
};
// The view `view` (no distortion) as the source camera `source` sees it (both with their cam_to_rig).
ViewFrustum frustum_between(const CameraCalib& source, const CameraCalib& view);

// For each row of tiles, the source columns [first, second) from its first to its last tile whose points
// can land within `margin_px` of the view (empty, first == second, when none can). Conservative: a tile
// reaching behind the view's lens (nearer than near_m) counts as landing. `boxes`, `nearest` and
// `farthest` as above, for the same grid.
void columns_in_view(int width, int height, const std::vector<float>& boxes, const std::vector<uint16_t>& nearest,
                     const std::vector<uint16_t>& farthest, const ViewFrustum& view, float near_m, float margin_px,
                     std::vector<std::pair<int, int>>* columns);

}  // namespace vclassroom
