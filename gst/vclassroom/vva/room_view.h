// The room's part of a lecturer's view (docs/vva.md, "How a view is made"): most of a classroom does not move
// and V-DA models it, so a view need not splat every camera pixel again. Each camera's static depth becomes
// a mesh once (room_mesh.h); per camera frame its room (the seen static pixels, the background memory's room
// behind the learners) is packed once for the lookup (room_lookup.h); per view the meshes are
// rasterised at the pose (room_raster.h) and every view pixel's colour is looked up backward in every camera
// that sees that point. The learners (and the room's pixels its mesh does not draw) are then warped forward
// (WarpParams::learners_only) and fused on top (FuseParams::first_is_base). GStreamer-free.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/room_lookup.h>
#include <gst/vclassroom/vva/room_mesh.h>
#include <gst/vclassroom/vva/room_raster.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

// Whether a camera's room (or a view) can be drawn this way: the lookup and the rasteriser are pinhole only,
// for images of 2 x 2 pixels to 16 M pixels.
bool room_view_fits(const CameraCalib& camera);

// A camera's static depth as a mesh in the rig frame, made at the first mesh() (any thread; once). The
// mesh's tolerance is max(10 mm, 1 %) of the depth, 32 px tiles at most (in the prototype, 0.25 % gained
// 0.06 dB on Table I for about twice the triangles: docs/vva.md).
class RoomShape {
 public:
  // `static_depth`: CV_16UC1 mm of the camera's size (kept, not copied: it does not change).
  RoomShape(const CameraCalib& camera, const cv::Mat& static_depth);
  const RoomMesh& mesh() const;
  const CameraCalib& camera() const { return camera_; }
  const cv::Mat& static_depth() const { return depth_; }
  // mesh() without the triangles one of `near` sees (room_mesh_unseen_by): what this camera adds to a view the
  // near cameras' meshes draw, made the first time these cameras ask (any thread) and kept for a few sets.
  std::shared_ptr<const RoomMesh> unseen_by(const std::vector<const RoomShape*>& near) const;

 private:
  CameraCalib camera_;
  cv::Mat depth_;
  mutable std::once_flag made_;
  mutable RoomMesh mesh_;
  const uint64_t id_;  // unique to this shape (a later one at the same address is another)
  mutable std::mutex unseen_lock_;
  mutable std::map<std::vector<uint64_t>, std::shared_ptr<const RoomMesh>> unseen_;  // by the near shapes' ids
};

// One camera as a view's room reads it: its shape (the mesh) and this frame's packed room.
struct RoomCamera {
  const RoomShape* shape = nullptr;
  const RoomTexture* texture = nullptr;
};

// The lookup's parameters for a view fused with `fuse`: its depth tolerance, so that the room's cameras agree
// with a point as the fuse's samples agree with each other; the place's sigma the default.
RoomLookupParams room_lookup_params(const FuseParams& fuse);

// Whether a camera's learners go forward from cameras nearer the view instead (docs/vva.md, "How a view is
// made", step 3): the camera at `camera` (its centre in the rig frame) is far from the view at `view` among the
// view's cameras at `cameras` (itself among them or not) by the room's threshold (room_camera_is_far) on the
// place weight with sigma 0.2 m (RoomLookupParams' default), with or without the background memory: the room's
// lookup weighs the place only with the memory, whose averaged colour needs no other camera to average its
// noise, but a far camera's learners, a pixel off at the view, blur the near camera's and flicker with its
// noise either way (vclassroom-eval-views --room-view, 2026-11-28: near camera 0 from all three cameras
// 29.317 dB against 26.782, at the sources' own places 45.061 against 35.125, Table I and the novel poses the
// same to three decimals; vclassroom-measure-flicker 0.5313 / 1.3912 with memory 8 / 0 against 0.7126 /
// 1.5640).
bool learners_left_to_nearer(const Eigen::Vector3d& camera, const std::vector<Eigen::Vector3d>& cameras,
                             const Eigen::Vector3d& view);

// A camera of a view's room as a fuse tells its warps: its id and centre (rig frame, metres).
struct RoomCameraPlace {
  int id = 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};

// The cameras among `cameras` (as a fuse names them: LearnerRounds::steady) that `camera` leaves its learners
// to at `view`: when it is far from the view among them (learners_left_to_nearer), the ids of those that are
// not, itself left out; none when it draws its learners itself.
std::vector<int> cameras_taking_learners(const CameraCalib& camera, const std::vector<RoomCameraPlace>& cameras,
                                         const CameraCalib& view);

// One frame of a fused round, for LearnerRounds: its camera, whether it carries the camera's room (its warp drew
// only the learners), and the cameras it left its learners to (none: it drew them, or was warped whole).
struct RoundFrame {
  RoomCameraPlace camera;
  bool room = false;
  std::vector<int> learners_left_to;
};

// Which cameras a fuse tells its warps they may leave their learners to, from the rounds it fused, and
// whether a round has every learner drawn (docs/vva.md, "How a view is made", step 3). A camera is told
// only once its room has been in each of the last kSteadyRounds rounds: a camera that skips rounds (a
// slower one, one that drops frames) would lose the others' learners with every round it misses. Not
// thread-safe (the fuse's thread takes the rounds; the caller copies steady() under its own lock).
class LearnerRounds {
 public:
  static constexpr int kSteadyRounds = 3;
  // Takes a round: true when every camera a frame left its learners to drew its own in the round (a frame
  // of it without learners_left_to). Where cameras share an id, true only when no frame left its learners,
  // and that id is not named (steady) until it is one camera's again for kSteadyRounds rounds.
  bool take(const std::vector<RoundFrame>& round);
  // The cameras whose room was in each of the last kSteadyRounds rounds.
  const std::vector<RoomCameraPlace>& steady() const { return steady_; }
  void clear();

 private:
  std::map<int, int> streak_;  // rounds in a row with the camera's room in them
  std::vector<RoomCameraPlace> steady_;
};

// Renders the room at a view; keeps its buffers between views.
class RoomViewRenderer {
 public:
  // `out` gets the view's size: depth (0 where no mesh lies or no camera sees the surface), the colour
  // blended from every camera that sees it (black elsewhere), label 0, weight 255 where seen. `view` is
  // pinhole (room_view_fits). `lookup`: the depth tolerance (viewfuse's) and the place's sigma, used where
  // every camera's colour is steady (RoomTexture::steady; else the angles alone).
  void render(const std::vector<RoomCamera>& cameras, const CameraCalib& view, const RoomLookupParams& lookup,
              WarpedView* out);

 private:
  RoomRaster raster_, far_raster_;  // the near cameras' meshes, the far ones' (drawn where the near leave holes)
  std::vector<uint8_t> empty_tiles_;  // the near ones' tiles with a hole (RoomRaster::draw_where_empty)
  SampleTiles hole_tiles_;            // the same as spans, where the far raster is cleared and read
  cv::Mat far_depth_;
  std::vector<const RoomTexture*> textures_;
  std::vector<const RoomShape*> near_;  // the cameras whose meshes are drawn whole
  cv::Mat drawn_;  // the depth as drawn, with two zero columns either side (for closing the gaps along rows)
};

}  // namespace vclassroom
