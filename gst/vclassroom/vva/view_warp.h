// V-VA step 2: warps one RGB-D camera to the lecturer's virtual view
// (docs/vva.md). GStreamer-free.
//
// The source image is a mesh: every 2x2 block of pixels gives two triangles
// whose corners are the pixel centres at their measured depth. Triangles are
// projected into the virtual camera and rasterised with a z-buffer; each
// covered virtual pixel remembers the sub-pixel source position it came from,
// and its colour is then sampled bilinearly there (forward geometry, backward
// colour). A triangle whose corners straddle a depth edge (or a learner/static
// boundary) is dropped instead of stretched, so foreground never smears over
// background and disoccluded areas stay holes for the fusion to fill.
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/sample_tiles.h>

namespace vclassroom {

// One frame of the source camera. All images have the camera's size.
struct WarpSource {
  cv::Mat color;         // CV_8UC3 RGB
  cv::Mat depth;         // CV_16UC1 mm, live depth (0 = none)
  cv::Mat label;         // CV_8UC1, 0 static, k learner k; may be empty (all static)
  // Static layer: the depth of the empty classroom for this camera (V-DA's
  // prior depth, or a stand-in). Used for label-0 pixels where non-zero; may be empty.
  cv::Mat static_depth;  // CV_16UC1 mm
  // The room behind the learners as a camera remembers it
  // (BackgroundMemory::room_behind_learners): drawn behind what the camera
  // sees now, where room_depth is non-zero. room_depth empty: no layer (room_color may be empty too).
  cv::Mat room_color{};  // CV_8UC3 RGB
  cv::Mat room_depth{};  // CV_16UC1 mm, 0 = none
};

struct WarpParams {
  // Two mesh neighbours belong to different surfaces when their depths differ
  // by more than max(edge_min_mm, edge_ratio * nearer depth).
  double edge_ratio = 0.03;
  double edge_min_mm = 15;
  // ... unless the view does not tear them apart: a triangle with a depth
  // step is kept when none of its edges grows by more than this many pixels
  // beyond its source length (slanted surfaces stay whole, edges open).
  double max_gap_px = 1.0;
  // Depth that comes in steps (quantised disparity): a pixel near a step
  // larger than the link tolerance above is averaged with its neighbours
  // along the row and then the column, as far as no jump beyond
  // max(edge_min_mm, step_ratio * depth) intervenes, so a slanted surface is
  // a ramp, not a staircase whose steps crack open in the view; larger jumps
  // are real edges and stay. 0: off. (Real edges between the two tolerances
  // are softened too: 4.5 % keeps the classroom's small edges, see docs/vva.md.)
  double step_ratio = 0.045;
  // A virtual pixel left empty, or showing something farther, between two
  // pixels of one surface (left and right, or above and below) is a crack
  // between their cells: it takes their mean.
  bool close_cracks = true;
  // Projected triangles larger than this many times their source area (0.5 px²)
  // are dropped (grazing surfaces seen edge-on).
  double max_stretch = 64;
  // The far-side pixel next to a depth edge (8-neighbourhood) takes the
  // nearer side's depth and label: its colour mixes both surfaces, and it is
  // the object's rim seen against the background, so it moves with the
  // object instead of leaving a ghost contour on the background (and depth
  // maps' edges are often a pixel inside the colour edges) - when its colour
  // shows some of the object (view_warp.cpp, kMinObjectShare) and its depth
  // is not the static layer's (a model's edges are not a sensor's). On
  // Middlebury Art it is worth 1.8 dB at offset 1 over dropping the pixel
  // (docs/vva.md).
  bool edge_to_near = true;
  // Source pixels this close (px) to a depth edge, on its far side, are not
  // warped (after edge_to_near, beyond the claimed pixel): another way to keep
  // mixed colours off the background. The holes get filled.
  int boundary_px = 0;
  // true: rasterise the two triangles of every 2x2 block (the reference,
  // about 1.7x slower); false: map every pixel's cell with the local affine
  // map of its same-surface neighbours (same coverage away from edges).
  bool mesh = false;
  // Cell warp only: a 2x2 block of pixels inside one surface (every pixel
  // linked to all its neighbours) is drawn as one cell of twice the size, a
  // quarter of the set-up; false: every pixel its own cell (the reference).
  bool coarse_cells = true;
  // Learner pixels without live depth take their learner's median depth.
  bool fill_learner_depth = true;
  // Cell warp only: the source columns whose points cannot land in the view
  // (tiles of view_cull.h) are not projected, linked or set up; the view is
  // the same pixel for pixel (false: every column, the reference).
  bool cull_outside_view = true;
  // The room view (room_view.h, docs/vva.md "How a view is made"): only the learners' pixels, the room's beside
  // them and those without a static depth are drawn, as a sparse layer over their spans; the rest of the room
  // comes from the room's meshes and lookup. Cell warp only (with `mesh` everything is drawn).
  bool learners_only = false;
};

// The source warped to the virtual view: all images have the virtual camera's size.
struct WarpedView {
  cv::Mat color;   // CV_8UC3 RGB, black where weight is 0
  cv::Mat depth;   // CV_16UC1 mm along the virtual optical axis, 0 = hole
  cv::Mat label;   // CV_8UC1
  cv::Mat weight;  // CV_8UC1, 0 = hole, 1..255 quality (viewing angle, distance, stretch)
  // WarpParams::learners_only: every sample lies in these tiles; anywhere() when they are not known.
  SampleTiles tiles;
};

// Where a sparse layer's pixels lie (the learners' of WarpParams::learners_only, the room behind them): its
// rows [row_begin, row_end) and, per pair of rows from an even one (the cell warp takes rows in pairs), the
// column spans [first, second) where either row has a pixel, spans closer than what a cell reads either side of
// them joined. It depends on the source alone: the learners' are found once per frame, by prepare().
struct SparseRows {
  int row_begin = 0, row_end = 0;
  int first_pair = 0, end_pair = 0;  // the pairs' first rows: first_pair, first_pair + 2, ... < end_pair
  std::vector<size_t> pair_first;    // per pair, its first span; one more at the end
  std::vector<std::pair<int, int>> spans;
  // Whether these are a width x height layer's (one entry a pair, spans ordered within [0, width)).
  bool fit(int width, int height) const;
};
// The SparseRows of `depth` (width x height, 0 where the layer has no pixel).
void find_sparse_rows(int width, int height, const uint16_t* depth, SparseRows* out);

// What ViewWarper::prepare() makes of a source frame: the half of the warp
// that does not depend on the virtual camera.
struct PreparedSource {
  int width = 0, height = 0;
  std::vector<uint16_t> depth;  // the layered depth (mm), steps smoothed, rims given to the near side
  std::vector<uint8_t> label;   // the labels likewise; width * height + 1 (a zero after the last)
  // Per tile of view_cull.h, the nearest and farthest depth (mm) of `depth`; empty: found when warped.
  std::vector<uint16_t> tile_nearest, tile_farthest;
  // WarpParams::learners_only: the depth of what is drawn (the learners, the room's pixels beside them and
  // those without a static depth), 0 elsewhere; empty: made when warped.
  std::vector<uint16_t> learner_depth;
  SparseRows learner_rows;  // learners_only: where learner_depth has pixels
};

// Keeps per-source precomputation (pixel rays) and scratch buffers between
// frames; one per camera (not thread-safe, cheap to create).
class ViewWarper {
 public:
  // `source` and `virt` give intrinsics and cam_to_rig; `virt` must have no
  // distortion. `out` is reallocated only when its size changes.
  void warp(const CameraCalib& source, const WarpSource& in, const CameraCalib& virt, const WarpParams& params,
            WarpedView* out);
  // warp() in two halves: prepare() does what does not depend on the virtual
  // camera (the source's layered depth and labels, its steps smoothed, its
  // rims given to the near side), so a live view can do it before it reads
  // the lecturer's pose, and one camera's frame can be prepared once for
  // several views; warp_prepared() then warps it (any warper, any number of
  // times) with the same `source`, `in` and `params`. Throws cv::Exception
  // when `prepared` is not of the source's size.
  void prepare(const CameraCalib& source, const WarpSource& in, const WarpParams& params, PreparedSource* out);
  void warp_prepared(const CameraCalib& source, const WarpSource& in, const PreparedSource& prepared,
                     const CameraCalib& virt, const WarpParams& params, WarpedView* out);
  // A learners' view of `virt` with nothing drawn, as a learners-only warp that found no learner makes it (a
  // camera that leaves its learners to cameras nearer the view: learners_left_to_nearer in room_view.h): the
  // planes of the view's size, zero (where the last tiles were, when they are the last warp's planes), and
  // tiles that mark nothing.
  void warp_nothing(const CameraCalib& virt, WarpedView* out);
  // The share of the source's pixels the last warp set up (WarpParams::cull_outside_view: those whose
  // columns can land in the view; 1 without it, and for a learners-only warp, drawn over its spans).
  double warped_share() const { return warped_share_; }

 private:
  // prepare() into src_depth_ and src_label_; warp_prepared() of the prepared depth and labels given (which
  // may be those two: the room layer is drawn from them after).
  void prepare_here(const CameraCalib& source, const WarpSource& in, const WarpParams& params);
  void warp_prepared_here(const CameraCalib& source, const WarpSource& in, const uint16_t* depth,
                          const uint8_t* label, const std::vector<uint16_t>& tile_nearest,
                          const std::vector<uint16_t>& tile_farthest, const CameraCalib& virt,
                          const WarpParams& params, WarpedView* out);
  // The steps of warp_prepared_here() (view_warp.cpp defines the structures): one layer projected and drawn
  // into the z-buffer, as triangles (mesh) or cells; the room behind the learners as a second layer; the
  // z-buffer unpacked into the view.
  struct Frame;
  struct Layer;
  struct CellPass;
  struct RayTable;
  void splat_layer(const Frame& f, const Layer& layer, const WarpParams& params);
  void splat_mesh(const Frame& f, const Layer& layer, const WarpParams& params);
  void splat_cells(const Frame& f, const Layer& layer, const WarpParams& params);
  void project_rows(const Frame& f, const Layer& layer, int r0, int r1, int c0, int c1);
  uint32_t* links_row(int width, int v);
  void link_row(const Frame& f, const Layer& layer, int v, int c0, int c1);
  void splat_sparse_pairs(const Frame& f, const Layer& layer, const CellPass& pass);
  void splat_fine_cells(const Frame& f, const Layer& layer, const CellPass& pass, int v, int u_begin, int u_end,
                        const int32_t* skip);
  void splat_block_pair(const Frame& f, const Layer& layer, const CellPass& pass, int v, int j_begin, int j_end);
  void draw_room_layer(const Frame& f, const WarpSource& in, const WarpParams& params);
  void draw_learner_layer(const Frame& f, const WarpSource& in, const uint16_t* depth, const uint8_t* label,
                          const WarpParams& params);
  void unpack_tiles(const Frame& f, const WarpParams& params, bool fresh, WarpedView* out);
  void unpack_view(const Frame& f, const WarpParams& params, WarpedView* out);
  // The cell warp's rows in pairs over every column, or only over the columns that can land in the view.
  void splat_pairs(const Frame& f, const Layer& layer, const CellPass& pass, int first_pair, int end_pair);
  void splat_pairs_in_view(const Frame& f, const Layer& layer, const CellPass& pass, int first_pair, int end_pair);
  void splat_pair_columns(const Frame& f, const Layer& layer, const CellPass& pass, int v, int c0, int c1);
  void prepare_rays(const CameraCalib& source);
  // src_depth_ with its steps smoothed (WarpParams::step_ratio).
  void smooth_stepped_depth(int width, int height, const WarpParams& params);
  // WarpParams::edge_to_near on src_depth_ and src_label_.
  void give_edges_to_near_side(int width, int height, const WarpParams& params, const cv::Mat& color,
                               const cv::Mat& static_depth);
  std::shared_ptr<const RayTable> rays_;  // the source's (prepare_rays)
  std::vector<uint16_t> tile_nearest_, tile_farthest_;  // per tile: prepare_here's depth range
  std::vector<std::pair<int, int>> view_columns_;       // per row of tiles: the columns that can land in the view
  double warped_share_ = 1.0;
  std::vector<uint16_t> src_depth_;  // chosen layer depth (mm)
  std::vector<uint16_t> learner_depth_;  // learners_only: draw_learner_layer's depth
  const uint16_t* prepared_learner_depth_ = nullptr;  // learners_only: the prepared one, for this warp
  const SparseRows* prepared_learner_rows_ = nullptr;  // and where it has pixels, when prepared
  SparseRows sparse_rows_;                              // a sparse layer's, found when warped
  // learners_only: splat_fine_cells marks the view's tiles (SampleTiles) its records may lie in; tile_cols_
  // across, one more than the view needs each way (a cell's 2x2 may reach a pixel past the view's last).
  bool track_tiles_ = false;
  int tile_cols_ = 0;
  std::vector<uint8_t> tile_marks_;
  std::vector<uint16_t> step_tmp_;   // src_depth_ smoothed along the rows
  std::vector<uint8_t> step_code_;   // what lies between neighbours (steps, edges), along rows, then columns
  std::vector<uint8_t> step_chunk_;  // per row and chunk of columns: a step across the column there
  std::vector<uint8_t> crack_code_;  // one virtual row's cracks (close_cracks)
  std::vector<uint8_t> row_empty_;   // per virtual row: nothing drawn (unpack_view)
  std::vector<uint8_t> src_label_;
  std::vector<uint8_t> edge_code_, drop_;  // depth edges, far-side pixels dropped
  cv::Mat nearest_around_;                 // edge_to_near: per source pixel, the nearest depth in its 3x3, less 1
  std::vector<uint8_t> claim_flags_;       // edge_to_near: 1 where a pixel lies behind its nearest neighbour
  struct EdgeClaim {
    int pixel;      // y * width + x
    uint8_t label;  // the near side's
  };
  std::vector<EdgeClaim> edge_claims_;     // edge_to_near: the far-side pixels that take the near side's depth
  std::vector<uint32_t> links_;            // three rows of link flags (same surface as right / below), a spare zero row
  // One source row of splat cells (view_warp.cpp, prepare_cells).
  std::vector<int32_t> cell_x0_, cell_y0_, cell_x1_, cell_y1_, cell_sides_;
  std::vector<float> cell_pos_;
  std::vector<int32_t> cell_mask_, cell_weight_;
  // The 2x2 blocks of a pair of source rows drawn as one cell (prepare_blocks).
  std::vector<int32_t> block_x0_, block_y0_, block_x1_, block_y1_, block_coarse_, block_mask_, block_weight_,
      block_z_;
  std::vector<float> block_pos_;
  std::vector<int32_t> block_fixed_;  // each candidate's source position, fixed point
  std::vector<int32_t> no_blocks_;              // all zero: a row pair without block cells
  std::vector<std::pair<int, int>> fine_runs_;  // pixels [first, second) of a row pair without block cells
  std::vector<std::pair<int, int>> own_columns_, shared_columns_;  // what a pair reads: its rows', the next pair's
};

// Convenience: one-shot warp.
WarpedView warp_view(const CameraCalib& source, const WarpSource& in, const CameraCalib& virt,
                     const WarpParams& params = WarpParams());

// The camera that sees the virtual view `virt`: same as `base` (intrinsics,
// size) with the pose's cam_to_rig; when fov_deg is finite, fx = fy set for
// that horizontal field of view at base's width (cx, cy unchanged).
CameraCalib virtual_camera(const CameraCalib& base, const Eigen::Isometry3d& cam_to_rig, double fov_deg);

}  // namespace vclassroom
