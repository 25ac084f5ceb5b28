// V-VA step 1: learner masks with ids that stay the same over time
// (docs/vva.md). GStreamer-free.
//
// Per pixel, two cues against a model of the empty classroom: depth clearly
// in front of the static depth, and colour change against a background colour
// model (used where depth is missing). Memory in the spirit of XMem (Cheng &
// Schwing, ECCV 2022), without a network:
//  - fast state: the previous frame's labels, which keep pixels whose cues are
//    unknown (depth holes on dark hair) in their learner;
//  - working memory: a per-pixel evidence that decays over a few frames, so a
//    learner whose clothes match the wall and whose depth drops out for a
//    moment is not lost, and the background colour model is only updated
//    where no learner is (a learner who sits still is never absorbed);
//  - long-term memory: a compact descriptor per learner (mean colour, depth,
//    position, size) kept for a while after it disappears, so a learner who
//    was occluded or left and comes back gets the id it had.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

struct SegParams {
  // Depth cue: a pixel is in front of the empty room when nearer than the
  // static depth by more than max(depth_margin_mm, depth_margin_ratio * static).
  double depth_margin_mm = 60;
  double depth_margin_ratio = 0.03;
  // Colour cue: sum of |RGB - background| above this (0..765).
  int color_threshold = 60;
  // Working memory: evidence = decay * evidence + (1 - decay) * cue.
  double memory_decay = 0.5;
  // Blobs smaller than this share of the image are noise.
  double min_area_ratio = 0.0015;
  // Background colour model learning rate where no learner is.
  double background_rate = 0.05;
  // Long-term memory: frames a lost learner's descriptor is kept.
  int keep_lost_frames = 300;
};

struct LearnerTrack {
  int id = 0;                // label value, 1..255
  cv::Vec3f mean_color;      // RGB
  float depth_mm = 0;        // median depth
  cv::Point2f centroid;      // px
  int area = 0;              // px
  int64_t last_seen = -1;    // frame index
  int64_t first_seen = -1;
};

class LearnerSegmenter {
 public:
  explicit LearnerSegmenter(const SegParams& params = SegParams());
  // The empty classroom's depth for this camera (V-DA's prior depth, mm,
  // 0 = unknown). Without it the static depth is learnt online: the farthest
  // stable depth seen at each pixel (learners who never move stay background).
  void set_static_depth(const cv::Mat& depth_mm);
  // Takes effect from the next frame; the memory is kept.
  void set_params(const SegParams& params) { p_ = params; }
  // One frame: colour CV_8UC3 RGB, depth CV_16UC1 mm. Writes CV_8UC1 labels
  // (0 static, k learner k). Frames must keep their size.
  void segment(const cv::Mat& color, const cv::Mat& depth, cv::Mat* label);
  // Learners seen in the last frame, and those remembered after they left.
  const std::vector<LearnerTrack>& active() const { return active_; }
  const std::vector<LearnerTrack>& remembered() const { return lost_; }
  void reset();

 private:
  // A horizontal stretch of foreground pixels [x0, x1] in row y: the
  // connected components, their descriptors and the label image are all
  // built from these, so only foreground pixels cost anything.
  struct Run {
    int y, x0, x1;
  };
  struct Blob {
    int64_t area = 0, sum_x = 0, sum_y = 0;
    int64_t color[3] = {0, 0, 0}, depth_sum = 0, depth_count = 0;
    uint32_t order_key = 0;
    int slot = -1;  // row in overlap_ when big enough to be a learner
  };
  // A blob's look: its mean colour and depth, area and centre (what a learner is recognised by).
  struct BlobLook {
    cv::Vec3f color{0, 0, 0};
    float depth = 0;
    int area = 0;
    cv::Point2f centroid;
  };
  int new_id();
  void update_depth_bounds();
  // The steps of segment(): each pixel's cues into the foreground mask fg_, cleaned; the blobs' colour,
  // depth and overlap with the last frame's learners; which learner each blob is; the learners' tracks;
  // the labels.
  void classify_pixels(const cv::Mat& color, const cv::Mat& depth);
  void find_blobs();
  std::vector<BlobLook> describe_blobs(const cv::Mat& color, const cv::Mat& depth, int min_area);
  std::vector<int> identify_blobs(const std::vector<BlobLook>& looks, int min_area, int width, int height);
  void update_tracks(const std::vector<BlobLook>& looks, const std::vector<int>& blob_id);
  const LearnerTrack* find_active(int id) const;
  SegParams p_;
  cv::Mat prior_;       // CV_16UC1 given static depth
  cv::Mat bg_depth_;    // CV_32F learnt static depth (mm)
  cv::Mat bg_color_;    // CV_16UC3 RGB, 8 fractional bits
  cv::Mat evidence_;    // CV_16SC1 working memory, 14 fractional bits
  cv::Mat prev_label_;  // CV_8UC1 fast state
  cv::Mat fg_;
  // The depth cue's bounds from the given static depth: "in front" below
  // depth_lo_, "on the room's surface" below depth_hi_ (0 there: unknown).
  // The prior does not move, so they are computed once per prior and params.
  cv::Mat depth_lo_, depth_hi_;
  double bounds_margin_ = -1, bounds_ratio_ = -1;
  std::vector<Run> runs_;
  std::vector<int> run_parent_, run_blob_, row_first_run_;
  std::vector<Blob> blobs_;
  std::vector<int> overlap_;
  std::vector<LearnerTrack> active_, lost_;
  int64_t frame_ = 0;
};

// Foreground IoU of two label images (any non-zero label is a learner), and
// the mean IoU of each ground-truth learner with the predicted id that
// overlaps it most. For evaluations.
struct SegScore {
  double fg_iou = 0;
  double mean_learner_iou = 0;
};
SegScore score_segmentation(const cv::Mat& predicted, const cv::Mat& truth);

}  // namespace vclassroom
