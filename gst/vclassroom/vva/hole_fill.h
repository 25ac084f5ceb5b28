// Filling what no camera sees in a fused view (docs/vva.md, "hole filling"). GStreamer-free: cv::Mat in and
// out. A hole is a pixel whose depth is 0; it takes its colour from the side that lies behind (the
// disocclusion's background), never from the foreground object that caused it.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

enum class HoleFillMethod {
  // Since issue 35: a push-pull pyramid over the hole's background border only (docs/references.md: Gortler
  // et al. 1996, Solh and AlRegib 2012). The known pixels across a hole along its row and column that lie on
  // its far side are the only samples; coarser levels average them, and a hole takes the bilinear
  // interpolation of the next coarser level, so every hole gets a smooth surface over the background around
  // it in 2-D, at whatever width. Near the border the nearest background pixels along the rays weigh more.
  Pyramid,
  // The fill before issue 35: the nearest known pixel along the row and the column in each direction,
  // those on the far side weighted by 1/distance, then a box blur. Kept for comparison.
  Rays,
};

struct HoleFillParams {
  HoleFillMethod method = HoleFillMethod::Pyramid;
  // A sample counts as background when its depth is within this share of the farthest one it is compared
  // with (the ray ends of a hole pixel; a pyramid cell's children or a hole's coarser neighbours).
  double background_ratio = 0.12;
  // The filled pixels are then box-blurred over (2r+1)^2 (0: not at all; -1: the method's own, after the
  // pyramid 1 px next to the hole's border and 2 px deeper in, 2 px after the rays).
  int smooth_px = -1;
  // Rays only: each filled pixel within 16 px of the hole's edge gets, times this, the detail of its mirror
  // image across the edge on its nearest background side (FuseParams::fill_texture). 0: smooth.
  double texture = 0;
};

// What the pyramid fill made in the frame before, for a view whose pose has not changed since (the caller
// clears it when it does): a hole that stays put then keeps its fill where its background border changed by
// no more than its noise (issue 35's fourth round). Empty: nothing kept yet.
struct HoleFillHistory {
  cv::Mat color;           // CV_8UC3: the fill's colour where `depth` is set
  cv::Mat depth;           // CV_16UC1: the background depth each pixel was filled from; 0 where none was
  std::vector<int> spans;  // the filled runs, as y, first x, last x (to clear `depth` at the next frame)
  void clear() { color.release(), depth.release(), spans.clear(); }
};

// Fills every pixel of `color` (CV_8UC3) where `depth` (CV_16UC1) is 0. `mask` (CV_8UC1, the size of
// `color`, zero on entry) gets 255 where a colour was made. `filled_depth` (optional, a copy of `depth`)
// gets the background depth chosen for each filled pixel. A view without any known pixel stays as it is.
// `history` (optional, the pyramid only): the same view's fill of the frame before, blended in (see
// keep_steady_fill in hole_fill.cpp) and then replaced by this frame's.
// `left_to_caller` (optional, CV_8UC1 the size of `color`; the pyramid only, the rays ignore it): hole pixels
// set there are not filled (colour, mask and `filled_depth` untouched, nothing kept in `history`), for a caller
// that paints them itself (viewfuse's fade, far from anything seen). The other pixels are filled as without
// it, bit for bit, but for those within hole_fill_reach() of one left (the smoothing reads its neighbours'
// fill), which the caller must paint over too. With a history, a pixel left in one frame and filled in the next
// has no fill of the frame before to be damped against.
void fill_holes(cv::Mat& color, const cv::Mat& depth, const HoleFillParams& params, cv::Mat& mask,
                cv::Mat* filled_depth = nullptr, HoleFillHistory* history = nullptr,
                const cv::Mat* left_to_caller = nullptr);

// How far (px, along a row, a column or diagonally) a filled pixel's colour reads the fill of other hole
// pixels: the smoothing's widest radius.
int hole_fill_reach(const HoleFillParams& params);

// The two methods, as fill_holes runs them by params.method (the pyramid's smoothing averages only what
// lies behind each filled pixel, smooth_px < 0 its own widening one; the rays' blurs all around it, as before
// issue 35).
void fill_holes_by_pyramid(cv::Mat& color, const cv::Mat& depth, double background_ratio, int smooth_px,
                           cv::Mat& mask, cv::Mat* filled_depth, HoleFillHistory* history = nullptr,
                           const cv::Mat* left_to_caller = nullptr);
void fill_holes_along_rays(cv::Mat& color, const cv::Mat& depth, const HoleFillParams& params, cv::Mat& mask,
                           cv::Mat* filled_depth);

// Box-blurs (2 smooth_px + 1)^2 the pixels where `filled` is set, from the colours around them as they are
// (every filled pixel reads the unblurred image). Only the parts of the image holding filled pixels are
// touched.
void smooth_filled_pixels(cv::Mat& color, const cv::Mat& filled, int smooth_px);

}  // namespace vclassroom
