// The room's depth at a view by rasterising meshes of the room (room_mesh.h) into it, so that the backward
// lookup (room_lookup.h) has a depth per view pixel without splatting every camera pixel. GStreamer-free.
//
// Depth only: per view pixel the nearest triangle's depth, 1/z interpolated linearly in screen space
// (perspective-correct for a pinhole view). Vertices are snapped to 1/16 px and the edge functions are exact
// integers, sampled at the pixel centres (integer coordinates, as CameraCalib::project gives them). A pixel
// centre exactly on an edge is inside: triangles that share an edge (the same two vertices) leave no crack (the
// centres on it drawn by both, at one depth), and a mesh seen from its own camera, whose pixel centres are its
// vertices, is drawn to its border, a surface's last pixels before a depth edge included. A triangle with a
// vertex at or in front of the near plane is dropped (not clipped). Triangles whose screen box is under 1024 px
// on each side run the vectorised row loop (32-bit edge functions); larger ones a scalar 64-bit loop. The
// triangles' set-up runs in batches, in vector lanes across triangles.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/room_mesh.h>
#include <gst/vclassroom/vva/sample_tiles.h>

namespace vclassroom {

struct RoomRasterStats {
  long triangles = 0;    // given
  long near = 0;         // dropped: a vertex at or in front of the near plane (or projected absurdly far)
  long empty = 0;        // no pixel centre in its box on screen (or degenerate)
  long drawn = 0;        // reached the pixel loop
  long large = 0;        // of which through the 64-bit loop
  long box_pixels = 0;   // pixels of the boxes scanned
  long skipped = 0;      // draw_where_empty: no empty tile under its box
};

class RoomRaster {
 public:
  // Starts a view: a pinhole camera (distortion ignored), its cam_to_rig the pose; nothing drawn.
  void begin(const CameraCalib& view, double near_m = 0.05);
  // As begin(), but nothing drawn only in `tiles` (elsewhere the buffer keeps an earlier view's values): for a
  // caller that reads the depth there alone (depth_in_tiles), as draw_where_empty's does.
  void begin_in_tiles(const CameraCalib& view, const SampleTiles& tiles, double near_m = 0.05);
  // Draws a mesh whose vertices are in the rig frame, nearest wins. `coverage` (tests; CV_8UC1 of the view's
  // size): + 1 at every pixel a triangle covers, whatever its depth.
  void draw(const RoomMesh& mesh, cv::Mat* coverage = nullptr);
  // The leaves' triangles alone, not the edge quads' parts (RoomMesh::edge_begin).
  void draw_leaves(const RoomMesh& mesh);
  // As draw_leaves, but only the triangles whose box on screen touches a tile that `empty_tiles` marks: per
  // tile of kTilePx x kTilePx pixels of the view (rows of tiles, left to right), 1 where another drawing of it
  // left a pixel empty. The triangles drawn are drawn whole; the caller takes from this raster only what the
  // other left empty.
  void draw_where_empty(const RoomMesh& mesh, const std::vector<uint8_t>& empty_tiles);
  // Those tiles of a view's depth (CV_16UC1): 1 where a pixel is 0.
  static void empty_tiles(const cv::Mat& depth, std::vector<uint8_t>* out);
  // The view's depth so far, CV_16UC1 mm (0: nothing drawn there).
  void depth(cv::Mat* out) const;
  // depth() in `tiles` only; `out`'s other pixels keep their values (0 where it is made).
  void depth_in_tiles(cv::Mat* out, const SampleTiles& tiles) const;
  // 1/z in 1/m, CV_32FC1 (0: nothing drawn).
  const cv::Mat& inverse_depth() const { return inv_; }
  RoomRasterStats stats;
  // The row loop works in whole groups of this many pixels; the buffer's rows have as many of slack.
  static constexpr int kSlack = 8;
  static constexpr int kTilePx = SampleTiles::kPx;

 private:
  void set_view(const CameraCalib& view, double near_m);
  void draw_masked(const RoomMesh& mesh, bool edges, cv::Mat* coverage, const std::vector<uint8_t>& empty_tiles);
  int width_ = 0, height_ = 0;
  float m_[12] = {};  // rig -> view, row-major 3x4
  float fx_ = 0, fy_ = 0, cx_ = 0, cy_ = 0, near_ = 0;
  cv::Mat buf_, inv_;  // inv_: buf_ without the slack
  std::vector<int32_t> sx_, sy_;  // vertices on screen, 1/16 px
  std::vector<float> w_;          // 1/z, 0: dropped
};

}  // namespace vclassroom
