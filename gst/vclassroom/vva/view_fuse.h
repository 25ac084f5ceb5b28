// V-VA step 3: fuses the cameras warped to the virtual view into one image
// (docs/vva.md). GStreamer-free.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/vva/hole_fill.h>
#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

struct FuseParams {
  // A camera's sample counts as the visible surface when it lies within
  // max(depth_tol_mm, depth_tol_ratio * z) of the nearest sample of the pixel
  // (z-buffer visibility); nearer samples occlude farther ones.
  double depth_tol_ratio = 0.03;
  double depth_tol_mm = 30;
  // Blending weight = (warp quality)^weight_power: > 1 favours the best camera.
  double weight_power = 2.0;
  // The room view (room_view.h): the first input is the room, seen nearly everywhere, and the others are
  // sparse (the learners and what the room's mesh does not draw): the views are blended only over the column
  // spans where one of the others has a sample, elsewhere the first is copied (the blend of one sample is that
  // sample); a learner within the tolerance of the room keeps its own colour. The first holds no sample where
  // its weight is 0 (depth, colour and label 0 there), as RoomViewRenderer makes it: the blend of short gaps
  // between the spans, taken with them, is then the copy. The first may have the output's own colour, depth
  // and label planes (share_room_planes): then it is fused in place, not copied.
  bool first_is_base = false;
  // Fill holes no camera covers from their background side (hole_fill.h), by the depth-aware pyramid or,
  // for comparison, along rows and columns (the fill before issue 35).
  bool fill_holes = true;
  HoleFillMethod fill_method = HoleFillMethod::Pyramid;
  // A hole neighbour counts as background when its depth is within this share
  // of the farthest neighbour found around the hole (0.12 rather than 0.08
  // since the warp gives objects their rims, WarpParams::edge_to_near:
  // +0.2 dB on the classroom and Middlebury Art at offset 1, docs/vva.md).
  double background_ratio = 0.12;
  // The filled pixels are then box-blurred over (2r+1)² : a fill can only
  // guess, and a smooth guess errs least (on Middlebury Art/Aloe it is worth
  // 0.5-1 dB with the rays, see docs/vva.md; 2 rather than 3 with the rims).
  // -1: the method's own (HoleFillParams::smooth_px: for the pyramid 1 px next to a hole's border and 2 px
  // deeper in, 2 for the rays).
  int fill_smooth_px = -1;
  // Texture on the smooth fill: each filled pixel within kTextureReach px of the hole's edge gets, times
  // this, the detail (deviation from its 3x3 mean) of its mirror image across the edge on its nearest
  // background side, where that pixel is known and on the background side too: a hole carries the grain of
  // the surface beside it instead of a flat smear. Off by default: PSNR does not reward a copied texture
  // (0.5 is within +-0.01 dB on Middlebury, +0.1 on Teddy), and a lecturer's encoder spends more on it
  // (about 5 ms of server CPU per view frame with four lecturers; docs/vva.md). 0: smooth.
  double fill_texture = 0;
  // What lies far from anything a camera saw cannot be guessed: beyond
  // fade_start (a share of the image width) from the nearest seen pixel the
  // fill fades over fade_length towards a neutral grey, a calm "outside the
  // view" rather than an edge pixel smeared across the frame (docs/navigation.md).
  // Narrow disocclusions stay as filled.
  bool fade_unseen = true;
  double fade_start = 0.02;
  double fade_length = 0.06;
};

struct FusedView {
  cv::Mat color;   // CV_8UC3 RGB
  cv::Mat depth;   // CV_16UC1 mm, 0 where nothing was seen (before filling)
  cv::Mat label;   // CV_8UC1
  cv::Mat filled;  // CV_8UC1, 255 where the hole filling made the colour
  double unseen_share = 0;  // share of the pixels no camera (nor the static model) provided
};

// `views` all have the same size; null or empty entries (a stopped camera) are skipped. `fill_history`
// (optional): the fill of this view's frame before, kept by a caller that fuses a sequence from one pose and
// cleared by it when the pose changes (HoleFillHistory): steady holes keep a steady fill.
void fuse_views(const std::vector<const WarpedView*>& views, const FuseParams& params, FusedView* out,
                HoleFillHistory* fill_history = nullptr);

// Points `room`'s colour, depth and label at `fused`'s, made at `size` where they are not, so that the room is
// rendered (RoomViewRenderer) into the picture fuse_views then makes of it in place (FuseParams::first_is_base).
void share_room_planes(cv::Size size, FusedView* fused, WarpedView* room);

// Fills every pixel of `color` where `depth` is 0 along rays (HoleFillMethod::Rays): from the nearest known
// pixels along the row and column (both directions), keeping only those on
// the far (background) side and weighting them by inverse distance, then
// smooths the filled pixels with a (2 smooth_px + 1)² box, then adds `texture`
// times the background's detail (FuseParams::fill_texture). `depth` gets the
// chosen background depth. `filled` (optional) marks what was filled.
void fill_holes_from_background(cv::Mat& color, cv::Mat& depth, double background_ratio, int smooth_px = 2,
                                cv::Mat* filled = nullptr, double texture = 0);

// The fill fuse_views runs with `fuse`'s fill settings.
HoleFillParams hole_fill_params(const FuseParams& fuse);

// The pose a camera's warped frame was made for (its PoseMeta), for the live
// pairing in viewfuse.
struct WarpedPose {
  bool known = false;          // the frame carries a pose
  uint64_t seq = 0;
  int64_t viewer_time_ns = -1;  // when the viewer took the pose; < 0 unknown
  RenderedPose rendered;        // the pose as rendered (after the navigation bounds), echoed with the frame
  uint64_t session = 0;         // whose pose (Pose::session): seqs are ordered within a session only
};
// Whether two frames' poses name the same rendered view (both known, the same position and orientation): a
// fused sequence keeps its HoleFillHistory while this holds from frame to frame, and clears it otherwise.
bool same_rendered_view(const WarpedPose& a, const WarpedPose& b);


// Live, one output frame should show one view: a camera's frame warped for
// an older pose than the newest among `inputs` is stale, unless the viewer
// took the two poses at most `window_ns` apart (the cameras' threads pick up
// a new pose at slightly different moments; at 30 poses a second waiting for
// exact agreement would drop frames all the time, while poses 50 ms apart
// differ by a few centimetres and degrees). Frames without a pose are stale
// when another has one. Seqs are compared within a session only: with the
// steering session known (the session of the latest pose the fuse passed
// upstream), a frame warped for another session's pose is stale; without it,
// frames of different sessions are not stale for each other. Returns one flag
// per input.
std::vector<bool> stale_poses(const std::vector<WarpedPose>& inputs, int64_t window_ns,
                              std::optional<uint64_t> steering_session = std::nullopt);

}  // namespace vclassroom
