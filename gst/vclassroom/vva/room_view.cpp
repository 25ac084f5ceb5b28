#include <gst/vclassroom/vva/room_view.h>

#include <algorithm>
#include <atomic>
#include <set>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {
// The mesh's tolerance (docs/vva.md, "How a view is made"): max(10 mm, 1 %) of the depth, tiles of 32 px at
// most.
constexpr double kMeshRatio = 0.01, kMeshMinMm = 10;
constexpr int kMeshTopLevel = 5;
// The edge quads' parts (RoomMesh::edge_begin: a surface drawn to half a pixel past its last pixel centres, as
// the camera saw it) are drawn for the camera nearest the view, when it is within this reach: there its pixels'
// outlines are the view's within a fraction of a pixel. Every camera's drew the union of their outlines, each
// a pixel off from the others' at the view, and fattened the foreground (near camera 0 at 160x90 without the
// memory, 27.7 dB against 29.8 without them); the nearest one's from 0.8 m away (Table I) cost 0.10 dB, from
// 0.5-1 m (the novel poses) 0.02 (vclassroom-eval-views --room-view, 2026-11-28).
constexpr double kEdgeReachM = 0.5;
// The gaps the meshes leave between a surface and the one behind it: without the edge quads' parts a mesh
// ends at its last pixel centres (and the nearest camera's, with them, half a pixel further), so a view off
// the camera's place shows a strip of up to a pixel or two there, where the forward warp's cells (half a
// pixel past each centre) leave none. Gaps of up to kStripPx along a row or a column are closed with the
// farther side's depth: what a camera sees there is the surface behind. The near meshes' gaps are closed
// before the far meshes fill their holes, so that those are holes a far camera can see into, not these seams.
constexpr int kStripPx = 2;

double distance(const RoomTexture& camera, const CameraCalib& view) {
  return (camera.camera.center_in_rig() - view.center_in_rig()).norm();
}

size_t closest_camera(const std::vector<RoomCamera>& cameras, const CameraCalib& view) {
  size_t closest = 0;
  for (size_t k = 1; k < cameras.size(); ++k)
    if (distance(*cameras[k].texture, view) < distance(*cameras[closest].texture, view)) closest = k;
  return closest;
}

// One row of the row pass, from the row as drawn (`in`, readable two pixels before and after the row, zero
// there): an empty pixel in a gap of one or two between depths takes the farther of the two around the gap.
// A gap's ends are pixels as drawn (gaps of up to kStripPx lie between pixels with depth), so every pixel is
// found from the drawn row alone, in vector lanes.
VCLASSROOM_SIMD_CLONES
void close_row_gaps(int n, const uint16_t* __restrict in, uint16_t* __restrict out) {
  static_assert(kStripPx == 2, "the row pass looks two pixels either way");
  for (int x = 0; x < n; ++x) {
    const uint16_t c = in[x], l1 = in[x - 1], l2 = in[x - 2], r1 = in[x + 1], r2 = in[x + 2];
    const bool empty = c == 0;
    const bool one = empty & (l1 != 0) & (r1 != 0);                  // x alone
    const bool first = empty & (l1 != 0) & (r1 == 0) & (r2 != 0);    // x and x + 1
    const bool second = empty & (l2 != 0) & (l1 == 0) & (r1 != 0);  // x - 1 and x
    const uint16_t across_one = std::max(l1, r1), across_first = std::max(l1, r2), across_second = std::max(l2, r1);
    out[x] = one ? across_one : first ? across_first : second ? across_second : c;
  }
}

// The row pass from `drawn` (the depth as drawn, in columns 2 .. 2 + width of an image zero in the two columns
// either side) into `depth`.
void close_strips_along_rows(const cv::Mat& drawn, cv::Mat& depth) {
  depth.create(drawn.rows, drawn.cols - 4, CV_16UC1);
  for (int y = 0; y < depth.rows; ++y) close_row_gaps(depth.cols, drawn.ptr<uint16_t>(y) + 2, depth.ptr<uint16_t>(y));
}

// An image of the view's size with two zero columns either side (close_strips_along_rows), and its inside.
cv::Mat padded_for_rows(int width, int height, cv::Mat* padded) {
  if (padded->cols != width + 4 || padded->rows != height || padded->type() != CV_16UC1) {
    padded->create(height, width + 4, CV_16UC1);
    padded->setTo(0);
  }
  return padded->colRange(2, width + 2);
}

// One row of the column pass, the row above already closed: an empty pixel below a depth takes the farther of
// the two around it; with the pixel below empty too and the one below that not, both take the farther of those.
VCLASSROOM_SIMD_CLONES
void close_column_gaps(int n, const uint16_t* __restrict above, uint16_t* __restrict here, uint16_t* __restrict below,
                       const uint16_t* __restrict two_below) {
  for (int x = 0; x < n; ++x) {
    const uint16_t a = above[x], h = here[x], b = below[x], c = two_below ? two_below[x] : uint16_t(0);
    const bool gap = h == 0 && a != 0, one = gap && b != 0, two = gap && b == 0 && c != 0;
    const uint16_t across_one = std::max(a, b), across_two = std::max(a, c);
    here[x] = one ? across_one : two ? across_two : h;
    below[x] = two ? across_two : b;
  }
}

// The column pass, row by row from the top; with `within`, over its spans alone (the rows' gaps lie there).
void close_strips_along_columns(cv::Mat& depth, const SampleTiles* within = nullptr) {
  static_assert(kStripPx == 2, "the column pass looks two rows ahead");
  auto close = [&](int y, int x0, int x1) {
    if (y < 1 || y + 1 >= depth.rows) return;
    close_column_gaps(x1 - x0, depth.ptr<uint16_t>(y - 1) + x0, depth.ptr<uint16_t>(y) + x0,
                      depth.ptr<uint16_t>(y + 1) + x0, y + 2 < depth.rows ? depth.ptr<uint16_t>(y + 2) + x0 : nullptr);
  };
  if (within) {
    for_each_tile_span(*within, depth.rows, close);
    return;
  }
  for (int y = 1; y + 1 < depth.rows; ++y) close(y, 0, depth.cols);
}

// The near meshes' depth, and the far ones' where it is empty.
VCLASSROOM_SIMD_CLONES
void take_where_empty(int n, const uint16_t* __restrict near, const uint16_t* __restrict far,
                      uint16_t* __restrict out) {
  for (int x = 0; x < n; ++x) out[x] = near[x] ? near[x] : far[x];
}

// The depth where the lookup found a colour (`seen` 255), 0 elsewhere.
VCLASSROOM_SIMD_CLONES
void keep_where_seen(int n, const uint8_t* __restrict seen, uint16_t* __restrict depth) {
  for (int x = 0; x < n; ++x) depth[x] = seen[x] ? depth[x] : uint16_t(0);
}

}  // namespace

RoomLookupParams room_lookup_params(const FuseParams& fuse) {
  RoomLookupParams lookup;
  lookup.depth_tol_mm = fuse.depth_tol_mm;
  lookup.depth_tol_ratio = fuse.depth_tol_ratio;
  return lookup;
}

bool room_view_fits(const CameraCalib& camera) {
  // A 2x2 to sample, and pixel indices that float arithmetic (the AVX2 lookup's) gives exactly.
  return !camera.has_distortion() && camera.width >= 2 && camera.height >= 2 &&
         int64_t(camera.width) * camera.height < (int64_t(1) << 24);
}

namespace {
std::atomic<uint64_t> next_shape_id{1};
}  // namespace

RoomShape::RoomShape(const CameraCalib& camera, const cv::Mat& static_depth)
    : camera_(camera), depth_(static_depth), id_(next_shape_id++) {
  if (depth_.type() != CV_16UC1 || depth_.cols != camera.width || depth_.rows != camera.height)
    throw Error("the room's static depth is not a 16-bit image of camera " + std::to_string(camera.id) + "'s size");
}

const RoomMesh& RoomShape::mesh() const {
  std::call_once(made_,
                 [this] { room_mesh(depth_, kMeshRatio, kMeshMinMm, kMeshTopLevel, nullptr, &camera_, &mesh_); });
  return mesh_;
}

std::shared_ptr<const RoomMesh> RoomShape::unseen_by(const std::vector<const RoomShape*>& near) const {
  std::vector<uint64_t> key;
  for (const RoomShape* s : near) key.push_back(s->id_);
  std::sort(key.begin(), key.end());
  std::lock_guard<std::mutex> g(unseen_lock_);
  // A rig of many cameras has many sets of near ones: the parts are kept for a few (each holds a copy of the
  // mesh's vertices), made again when a set comes back after the others pushed them out.
  constexpr size_t kKeptParts = 8;
  if (unseen_.size() >= kKeptParts && !unseen_.count(key)) unseen_.clear();
  std::shared_ptr<const RoomMesh>& kept = unseen_[key];
  if (!kept) {
    std::vector<std::pair<CameraCalib, cv::Mat>> seers;
    for (const RoomShape* s : near) seers.emplace_back(s->camera(), s->static_depth());
    kept = std::make_shared<const RoomMesh>(room_mesh_unseen_by(mesh(), seers));
  }
  return kept;
}

bool learners_left_to_nearer(const Eigen::Vector3d& camera, const std::vector<Eigen::Vector3d>& cameras,
                             const Eigen::Vector3d& view) {
  const double sigma = RoomLookupParams().place_sigma_m;
  const float own = room_place_weight(camera, view, sigma);
  float nearest = own;
  for (const Eigen::Vector3d& c : cameras) nearest = std::max(nearest, room_place_weight(c, view, sigma));
  return room_camera_is_far(own, nearest);
}

std::vector<int> cameras_taking_learners(const CameraCalib& camera, const std::vector<RoomCameraPlace>& cameras,
                                         const CameraCalib& view) {
  std::vector<Eigen::Vector3d> centres;
  for (const RoomCameraPlace& c : cameras) centres.push_back(c.centre);
  std::vector<int> near;
  if (!learners_left_to_nearer(camera.center_in_rig(), centres, view.center_in_rig())) return near;
  for (const RoomCameraPlace& c : cameras)
    if (c.id != camera.id && !learners_left_to_nearer(c.centre, centres, view.center_in_rig())) near.push_back(c.id);
  return near;
}

bool LearnerRounds::take(const std::vector<RoundFrame>& round) {
  std::set<int> ids, repeated, drew;
  bool left = false;
  for (const RoundFrame& f : round) {
    if (!ids.insert(f.camera.id).second) repeated.insert(f.camera.id);
    left = left || !f.learners_left_to.empty();
    if (f.learners_left_to.empty()) drew.insert(f.camera.id);
  }
  bool complete = repeated.empty() || !left;
  for (const RoundFrame& f : round)
    for (int id : f.learners_left_to) complete = complete && drew.count(id) > 0;
  // A repeated id is never named: a warp could not tell which of the cameras takes its learners.
  std::map<int, int> streak;
  steady_.clear();
  for (const RoundFrame& f : round) {
    if (!f.room || streak.count(f.camera.id) || repeated.count(f.camera.id)) continue;
    const auto before = streak_.find(f.camera.id);
    const int n = std::min(kSteadyRounds, (before == streak_.end() ? 0 : before->second) + 1);
    streak[f.camera.id] = n;
    if (n >= kSteadyRounds) steady_.push_back(f.camera);
  }
  streak_.swap(streak);
  return complete;
}

void LearnerRounds::clear() {
  streak_.clear();
  steady_.clear();
}

void RoomViewRenderer::render(const std::vector<RoomCamera>& cameras, const CameraCalib& view,
                              const RoomLookupParams& params, WarpedView* out) {
  textures_.clear();
  for (const RoomCamera& c : cameras) textures_.push_back(c.texture);
  // The view's place sharpens the blend near a camera where the cameras' colour is the background memory's;
  // without it the cameras' sensor noise wants averaging, by the angles alone (docs/vva.md, flicker).
  RoomLookupParams lookup = params;
  const bool steady =
      std::all_of(textures_.begin(), textures_.end(), [](const RoomTexture* t) { return t->steady; });
  if (!steady) lookup.place_sigma_m = 0;
  std::vector<float> place;
  for (const RoomCamera& c : cameras)
    place.push_back(room_place_weight(c.texture->camera, view, lookup.place_sigma_m));
  const float nearest = place.empty() ? 0.0f : *std::max_element(place.begin(), place.end());
  // A far camera's mesh only where the near ones leave a hole: near a camera its own mesh holds what the view
  // sees, and a far mesh's depth (a pixel off from this viewpoint) would stand in front of it in places (near
  // camera 0 from all three cameras: 26.4 dB against 25.9 with every mesh in one z-buffer, vclassroom-eval-views
  // --room-view). Only its triangles over the near ones' holes are drawn (RoomRaster::draw_where_empty), and of
  // those only the ones no near camera sees (RoomShape::unseen_by): the holes lie on what the near cameras do not
  // see. That leaves out half to three quarters of a far mesh's leaves, for the same figures to three decimals
  // (vclassroom-eval-views --room-view, 2026-11-28).
  raster_.begin(view);
  const size_t closest = closest_camera(cameras, view);
  std::vector<size_t> far;
  near_.clear();
  for (size_t k = 0; k < cameras.size(); ++k) {
    if (room_camera_is_far(place[k], nearest)) {
      far.push_back(k);
      continue;
    }
    near_.push_back(cameras[k].shape);
    if (k == closest && distance(*cameras[k].texture, view) < kEdgeReachM) raster_.draw(cameras[k].shape->mesh());
    else raster_.draw_leaves(cameras[k].shape->mesh());
  }
  cv::Mat drawn = padded_for_rows(view.width, view.height, &drawn_);
  raster_.depth(&drawn);
  CV_Assert(drawn.data == drawn_.ptr<uint8_t>() + 2 * sizeof(uint16_t));  // drawn in place, not into a copy
  close_strips_along_rows(drawn_, out->depth);
  close_strips_along_columns(out->depth);
  if (!far.empty()) {
    RoomRaster::empty_tiles(out->depth, &empty_tiles_);
    // Read only where the near ones left a pixel empty: cleared and converted in those tiles only.
    constexpr int kTile = RoomRaster::kTilePx;  // empty_tiles' layout: rows of tiles, left to right
    hole_tiles_.set_marked(empty_tiles_.data(), size_t((view.width + kTile - 1) / kTile), view.width, view.height);
    far_raster_.begin_in_tiles(view, hole_tiles_);
    for (size_t k : far) far_raster_.draw_where_empty(*cameras[k].shape->unseen_by(near_), empty_tiles_);
    far_raster_.depth_in_tiles(&far_depth_, hole_tiles_);
    // Every pixel the near meshes left empty lies in a hole tile: only there does the far depth go in and are
    // the gaps closed again, each span's row from the depth as merged kStripPx around it (what the row pass
    // reads). Elsewhere the near depth, closed already, has no gap and stays as it is.
    for_each_tile_span(hole_tiles_, view.height, [&](int y, int x0, int x1) {
      const int a = std::max(0, x0 - kStripPx), b = std::min(view.width, x1 + kStripPx);
      take_where_empty(b - a, out->depth.ptr<uint16_t>(y) + a, far_depth_.ptr<uint16_t>(y) + a,
                       drawn.ptr<uint16_t>(y) + a);
      close_row_gaps(x1 - x0, drawn.ptr<uint16_t>(y) + x0, out->depth.ptr<uint16_t>(y) + x0);
    });
    close_strips_along_columns(out->depth, &hole_tiles_);
  }
  room_lookup(textures_, view, out->depth, lookup, &out->color, &out->weight);  // black where not seen
  for (int y = 0; y < out->depth.rows; ++y)  // what no camera sees there is a hole
    keep_where_seen(out->depth.cols, out->weight.ptr<uint8_t>(y), out->depth.ptr<uint16_t>(y));
  out->label.create(out->depth.size(), CV_8UC1);
  out->label = cv::Scalar::all(0);
  out->tiles = SampleTiles();
}

}  // namespace vclassroom
