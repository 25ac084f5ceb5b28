// V-DA depth completion (docs/vda.md, PAPER.md "V-DA" steps 1-2): fills the
// holes of one camera's sensor depth from the static room's prior depth, then
// by image-guided completion in the style of Ku et al. (CRV 2018) tuned for
// indoor depth in mm, then by a colorization-style solve (Levin et al., 2004).
// Also the two baselines the evaluation compares with. GStreamer-free; every
// depth image is CV_16UC1 in mm with 0 = no depth, colour is CV_8UC3 RGB.
#pragma once

#include <opencv2/core.hpp>

namespace vclassroom {

// Where live depth and the static room's prior depth "agree": within
// max(min_mm, ratio * prior) of each other.
struct PriorFillParams {
  int tolerance_min_mm = 40;
  double tolerance_ratio = 0.03;
  // Holes within this many pixels of live depth that is clearly in front of the
  // prior (a learner) keep no prior: a learner's missing hair or dark sweater
  // must not become the wall behind it.
  int learner_guard_px = 4;
  // A missing pixel takes the prior only where the live colour still looks
  // like the empty room's (largest RGB channel difference at most this); 0 = no test.
  int color_tolerance = 40;
  // Holes take only prior depth some camera measured; the rest of the prior
  // (filled offline) is left to the per-frame completion.
  bool measured_only = false;
};

// What the static model knows of the empty room in one camera.
struct StaticPrior {
  cv::Mat depth;     // CV_16UC1 mm, D_i (complete: measured, then filled offline)
  cv::Mat color;     // CV_8UC3 RGB, the empty room's colour; may be empty (no colour test)
  cv::Mat measured;  // CV_8UC1, 255 where some camera measured the depth; empty = all
  bool empty() const { return depth.empty(); }
};

// out = live where live is in front of the prior (learners, new objects) or
// behind it; the prior where live is missing (no learner near, the colour still
// that of the empty room, and the prior measured there rather than filled) or
// where live agrees with it (the prior is the less noisy measurement of the
// static room). `color` (CV_8UC3, may be empty): the live image. `label`
// (CV_8UC1, may be empty): pixels with label > 0 never take the prior.
void prior_fill(const cv::Mat& live, const cv::Mat& color, const StaticPrior& prior, const cv::Mat& label,
                const PriorFillParams& p, cv::Mat& out);

// The Ku et al.-style stage, with its changes for indoor depth in mm: depth is
// inverted (max_depth_mm - D) so dilation prefers the nearer surface, but
// measured pixels are never overwritten, and a dilation only fills a hole when
// the valid depths under its kernel agree (so nothing grows across a depth
// edge); holes that remain are filled from the four run ends around each hole
// pixel, chosen and weighted by colour similarity, interpolating 1/Z across a
// run whose two ends lie on one surface; then a 3x3 median over the filled
// pixels among neighbours of similar colour (in depth_complete after
// colorization, see there).
struct GuidedCompletionParams {
  int max_depth_mm = 65535;         // inversion constant: any 16-bit depth stays valid once inverted
  bool morphology = true;           // diamond dilation, closing, 7x7 hole fill (agreeing neighbours only)
  int agree_min_mm = 30;            // "agree": max - min <= max(agree_min_mm, agree_ratio * depth)
  double agree_ratio = 0.03;
  bool hole_fill = true;            // colour-guided fill of the remaining holes
  double color_sigma = 20.0;        // colour distance (8-bit RGB, L2) at which a run end's weight falls to 1/e
  bool median = true;               // median over filled pixels only
  int median_size = 3;              // 3 or 5
  // The median's window leaves out pixels whose colour differs from the centre's
  // by more than this (8-bit RGB, L2; 5 colour sigmas: weight e^-25 in the hole
  // fill, another surface): it keeps thin structures and edges where they are.
  // 0 = plain median.
  double median_color_distance = 100.0;
  // A hole pixel is ambiguous when the run ends that disagree with the chosen
  // surface carry more than this share of the colour weight (typically at a
  // depth edge whose colours do not tell the sides apart).
  double ambiguous_share = 0.25;
};

// `depth` with its holes filled (in place allowed). `filled` (CV_8UC1, may be
// nullptr): 255 where a value was filled. `ambiguous` (may be nullptr): 255
// where the hole fill had to choose between disagreeing surfaces (the
// colorization stage revisits these). Pixels with no valid depth in any of the
// four directions stay 0.
void guided_completion(const cv::Mat& depth, const cv::Mat& color, const GuidedCompletionParams& p, cv::Mat& out,
                       cv::Mat* filled = nullptr, cv::Mat* ambiguous = nullptr);

// Colorization-style fill (Levin et al.): the value of each unknown pixel r is
// the colour-weighted mean of its 8 neighbours, D(r) = sum_s w_rs D(s), solved
// by successive over-relaxation with the known pixels fixed, started from the
// current fill. Optionally the weights also fall with the difference of the
// starting values (depth_sigma_ratio).
struct ColorizationParams {
  int iterations = 10;  // per frame, starting from the image-guided fill; the offline model uses more
  double color_sigma = 12.0;     // RGB L2 distance, 8-bit
  double depth_sigma_ratio = 0;  // depth difference (share of depth) at which weights fall to 1/e; 0 = colour only
  double relaxation = 1.6;       // SOR factor in [1, 2)
};

// Refines `depth` in place over the pixels where `unknown` (CV_8UC1) is
// nonzero. Unknown pixels that are 0 in `depth` are first given their nearest
// valid pixel's depth (nearest_fill). Known pixels are never changed.
void colorization_fill(cv::Mat& depth, const cv::Mat& color, const cv::Mat& unknown, const ColorizationParams& p);

// Median of `depth` over its 3x3 (size 3) or 5x5 window, 0s excluded, at every
// pixel where `filled` (CV_8UC1) is nonzero and depth is not 0; all medians are
// taken from the input, then written. With `color` (CV_8UC3, may be empty) and
// max_color_distance > 0, window pixels whose colour differs from the centre's
// by more than that (RGB L2) are left out.
void filled_median(cv::Mat& depth, const cv::Mat& filled, int size = 3, const cv::Mat& color = cv::Mat(),
                   double max_color_distance = 0);

// Baseline: every hole pixel takes the depth of the nearest valid pixel
// (Euclidean distance). Empty input stays empty.
void nearest_fill(const cv::Mat& depth, cv::Mat& out);

// Baseline: a faithful re-implementation of Ku et al.'s "fast" mode
// (fill_in_fast, CRV 2018) on depth in metres: invert (max_depth - D), 5x5
// diamond dilation, 5x5 full closing, 7x7 dilation into empty pixels, optional
// extrapolation (top-of-column extension, 31x31 dilation into large holes),
// 5x5 median blur, then bilateral (d = 5, sigma colour 1.5, sigma space 2.0)
// or Gaussian blur of valid pixels, invert back. Unlike V-DA it changes
// measured pixels too, as the original does.
struct KuFastParams {
  double max_depth_m = 100.0;
  bool extrapolate = true;
  bool bilateral = true;  // false: Gaussian 5x5 on valid pixels
};
void ku_fast_fill(const cv::Mat& depth_mm, const KuFastParams& p, cv::Mat& out);

// The per-frame depthcomplete path: which stages run, and their parameters.
struct DepthCompleteOptions {
  bool use_prior = true;
  bool image_guided = true;
  bool colorization = true;
  PriorFillParams prior;
  GuidedCompletionParams guided;
  ColorizationParams colorize;
};

// Runs the enabled stages in order: prior fill, image-guided completion,
// colorization, and last the image-guided stage's median over the filled
// pixels (after colorization, whose relaxation would otherwise spread what the
// median moved). `prior` and `label` may be empty (without a prior the prior
// stage is skipped). `out` must not alias `live`.
void depth_complete(const cv::Mat& live, const cv::Mat& color, const StaticPrior& prior, const cv::Mat& label,
                    const DepthCompleteOptions& o, cv::Mat& out);

}  // namespace vclassroom
