// A camera's memory of the static room's colour (issue 15): per pixel, the
// mean of the last few colours seen where no learner is (label 0). A change
// larger than the camera's noise (a chair moved, a learner gone, the light)
// starts the mean again at that pixel, so the memory follows the room without
// ghosts; through it the static room no longer flickers with the camera's
// noise. Where a learner stands the memory keeps what it saw there before (or
// the empty room it was seeded with): the room behind the learner, which the
// view shows where the learner moves out of the way (room_behind_learners).
// GStreamer-free; viewwarp's background-memory property uses it.
#pragma once

#include <algorithm>

#include <opencv2/core.hpp>

#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

struct BackgroundMemoryParams {
  int frames = 8;   // the mean's length: the noise falls by about sqrt(frames)
  int change = 24;  // grey levels on any channel that count as a change, not noise
  // The room layer reaches this far around the learners (px): the warp drops
  // the room pixels right beside a learner (WarpParams::boundary_px), and the
  // layer must join the room around it without a seam.
  int room_margin = 2;
};

class BackgroundMemory {
 public:
  explicit BackgroundMemory(BackgroundMemoryParams params = BackgroundMemoryParams()) : params_(params) {}

  // Starts the memory from a picture of the empty room (RGB CV_8UC3), e.g.
  // V-DA's model (prior-color/cam<ID>.png): every pixel is known from the
  // start, as a full mean; a live colour within the noise refines it, a
  // change replaces it. Throws Error on a wrong type.
  void seed(const cv::Mat& empty_room);

  // Takes this frame (RGB CV_8UC3; label CV_8UC1, 0 static, or empty: all static) into the memory and writes
  // to *out the frame with every static pixel replaced by its remembered colour (the others as they are).
  // A seed of another size is dropped. Throws Error on a wrong type or size; the memory starts again when
  // the size changes. With `remembered`, the remembered room (room_behind_learners' colour) is written there
  // (reused when its size fits) instead of into the memory's own image.
  void update(const cv::Mat& color, const cv::Mat& label, cv::Mat* out, cv::Mat* remembered = nullptr);

  // The room behind this frame's learners, as a layer for the warp
  // (WarpSource::room_*): *depth is `static_depth` where a learner (label
  // != 0), or a pixel within room_margin of one, hides a room pixel the
  // memory knows steadily (the same colour for half its frames, so a
  // learner's edge the segmentation missed for a frame is not taken for the
  // room); 0 elsewhere. *color is the remembered room (the image update()
  // wrote it into: the memory's own is valid until the next update()). Call
  // after update() with the same label plane.
  void room_behind_learners(const cv::Mat& label, const cv::Mat& static_depth, cv::Mat* color,
                            cv::Mat* depth) const;

  // What viewwarp's background-memory does to each frame: update() with the
  // source's colour and labels, its static room shown as remembered, and -
  // where it has a static depth and labels - the room behind its learners
  // as the warp's room layer. The images stay with the memory until the
  // next frame.
  void apply(WarpSource* src) { apply(src, &shown_, &room_color_, &room_depth_); }
  // The same with the images written into the caller's own (reused when their size fits): a caller that keeps
  // them beyond the next frame (viewprep's prepared frames) copies nothing.
  void apply(WarpSource* src, cv::Mat* shown, cv::Mat* room_color, cv::Mat* room_depth);

  // Frames of one colour after which a remembered pixel counts as the room.
  int stable_count() const { return std::clamp((params_.frames + 1) / 2, 1, 255); }

  void reset() {
    mean_.release();
    count_.release();
    remembered_.release();
    own_remembered_.release();
  }

 private:
  BackgroundMemoryParams params_;
  cv::Mat mean_;        // CV_16UC3, 1/256 grey levels
  cv::Mat count_;       // CV_8UC1: frames in the mean, 0 = nothing remembered
  cv::Mat remembered_;      // CV_8UC3: the mean, rounded (the last update()'s image: own_remembered_ or the caller's)
  cv::Mat own_remembered_;  // where update() writes it when the caller gives no image
  cv::Mat shown_, room_color_, room_depth_;  // apply()'s images of this frame
};

}  // namespace vclassroom
