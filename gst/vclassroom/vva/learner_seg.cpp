#include <gst/vclassroom/vva/learner_seg.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <numeric>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

// Fixed point: background colour with 8 fractional bits (CV_16UC3), evidence
// with 14 (CV_16SC1). Integers keep the cue loop branch-free and let it work
// on 8-16 pixels at once; the rounding is far below the colour threshold and
// the evidence's decision level.
constexpr int kColorFrac = 8;
constexpr int kEvidenceOne = 1 << 14;

struct CueConsts {
  int decay;  // 15 fractional bits
  // (1 - decay) * cue, 14 fractional bits, for each way the cue can come out.
  int in_front, surface_changed, room, nodepth_changed, nodepth_kept, nodepth_room;
  int fg_level;   // evidence above this is a learner
  int cthr, cthr2;
  int rate;       // background learning rate, 15 fractional bits
};

// One row of the cue + working memory + background colour update.
VCLASSROOM_SIMD_CLONES
void cue_row(int W, const uint8_t* __restrict c, const uint16_t* __restrict d, const uint16_t* __restrict lo,
             const uint16_t* __restrict hi, const uint8_t* __restrict pl, uint16_t* __restrict bg,
             int16_t* __restrict ev, uint8_t* __restrict fg, const CueConsts& k) {
  const int decay = k.decay, t_front = k.in_front, t_surf = k.surface_changed, t_room = k.room;
  const int t_col = k.nodepth_changed, t_keep = k.nodepth_kept, t_gone = k.nodepth_room;
  const int fg_level = k.fg_level, cthr = k.cthr, cthr2 = k.cthr2, rate = k.rate;
  for (int x = 0; x < W; ++x) {
    const int c0 = c[3 * x], c1 = c[3 * x + 1], c2 = c[3 * x + 2];
    const int g0 = bg[3 * x], g1 = bg[3 * x + 1], g2 = bg[3 * x + 2];
    const int dc = std::abs(c0 - (g0 >> kColorFrac)) + std::abs(c1 - (g1 >> kColorFrac)) +
                   std::abs(c2 - (g2 >> kColorFrac));
    const int z = d[x], zlo = lo[x], zhi = hi[x], was_learner = pl[x];
    const bool known = (z != 0) & (zhi != 0);
    const bool front = known & (z < zlo);
    // Known depth: in front of the room, on its surface (a colour change
    // there is weak evidence), or behind it; no depth: colour change, or
    // what this pixel was a frame ago. Every select reads only values loaded
    // above, so the loop has no branch.
    int term = ((z < zhi) & (dc > cthr2)) ? t_surf : t_room;
    term = front ? t_front : term;
    int unknown_term = was_learner ? t_keep : t_gone;
    unknown_term = dc > cthr ? t_col : unknown_term;
    term = known ? term : unknown_term;
    const int e = ((ev[x] * decay + (1 << 14)) >> 15) + term;
    ev[x] = int16_t(e);
    const bool is_fg = front | (e > fg_level);
    fg[x] = is_fg ? 255 : 0;
    // Selective update: only where no learner is.
    const int r = rate & (int(is_fg) - 1);
    bg[3 * x] = uint16_t(g0 + ((((c0 << kColorFrac) - g0) * r + (1 << 14)) >> 15));
    bg[3 * x + 1] = uint16_t(g1 + ((((c1 << kColorFrac) - g1) * r + (1 << 14)) >> 15));
    bg[3 * x + 2] = uint16_t(g2 + ((((c2 << kColorFrac) - g2) * r + (1 << 14)) >> 15));
  }
}

int fixed(double v, int one) { return int(std::lround(v * one)); }

// The depth cue's bounds for a row of static depth `sd` (mm, <= 0 unknown): a
// depth is in front below `lo` and on the surface below `hi` (integer depths
// compare with a float bound exactly as with its ceiling); hi = 0 marks
// unknown. Without branches, so that it vectorises: without a prior the
// learnt depth changes every frame, and this runs on every pixel of every frame.
VCLASSROOM_SIMD_CLONES
void depth_bounds_row(int W, const float* __restrict sd, float margin, float ratio, uint16_t* __restrict lo,
                      uint16_t* __restrict hi) {
  for (int x = 0; x < W; ++x) {
    const bool known = sd[x] > 0;
    const float d = known ? sd[x] : 0.0f;
    const float thr = std::max(margin, ratio * d);
    const uint16_t l = uint16_t(std::clamp(std::ceil(d - thr), 0.0f, 65535.0f));
    const uint16_t h = uint16_t(std::clamp(std::ceil(d + thr), 1.0f, 65535.0f));
    lo[x] = known ? l : 0;
    hi[x] = known ? h : 0;
  }
}

// Without a prior: the learnt depth follows the row's room pixels (not a
// learner, depth known): it jumps to a depth behind it or where it knew none,
// else moves towards the depth seen at `rate`. Without branches, as above.
VCLASSROOM_SIMD_CLONES
void learn_depth_row(int W, const uint16_t* __restrict d, const uint8_t* __restrict fg, float margin, float ratio,
                     float rate, float* __restrict bd) {
  for (int x = 0; x < W; ++x) {
    const float b = bd[x], z = float(d[x]);
    const bool jump = (z > b + std::max(margin, ratio * b)) | (b <= 0);
    const float learnt = jump ? z : b + rate * (z - b);
    bd[x] = (fg[x] != 0) | (d[x] == 0) ? b : learnt;
  }
}

}  // namespace

LearnerSegmenter::LearnerSegmenter(const SegParams& params) : p_(params) {}

void LearnerSegmenter::set_static_depth(const cv::Mat& depth_mm) {
  CV_Assert(depth_mm.empty() || depth_mm.type() == CV_16UC1);
  prior_ = depth_mm.clone();
  depth_lo_.release();
  depth_hi_.release();
}

void LearnerSegmenter::reset() {
  bg_depth_.release();
  bg_color_.release();
  evidence_.release();
  prev_label_.release();
  active_.clear();
  lost_.clear();
  frame_ = 0;
}

int LearnerSegmenter::new_id() {
  bool used[256] = {false};
  for (const auto& t : active_) used[t.id] = true;
  for (const auto& t : lost_) used[t.id] = true;
  for (int i = 1; i < 256; ++i)
    if (!used[i]) return i;
  // All ids taken: forget the learner lost longest ago.
  auto oldest = std::min_element(lost_.begin(), lost_.end(),
                                 [](const LearnerTrack& a, const LearnerTrack& b) { return a.last_seen < b.last_seen; });
  if (oldest == lost_.end()) return 255;
  const int id = oldest->id;
  lost_.erase(oldest);
  return id;
}

void LearnerSegmenter::update_depth_bounds() {
  if (!depth_lo_.empty() && depth_lo_.size() == prior_.size() && bounds_margin_ == p_.depth_margin_mm &&
      bounds_ratio_ == p_.depth_margin_ratio)
    return;
  const float margin = float(p_.depth_margin_mm), ratio = float(p_.depth_margin_ratio);
  depth_lo_.create(prior_.size(), CV_16UC1);
  depth_hi_.create(prior_.size(), CV_16UC1);
  cv::Mat prior_mm;
  prior_.convertTo(prior_mm, CV_32F);
  for (int y = 0; y < prior_.rows; ++y)
    depth_bounds_row(prior_.cols, prior_mm.ptr<float>(y), margin, ratio, depth_lo_.ptr<uint16_t>(y),
                     depth_hi_.ptr<uint16_t>(y));
  bounds_margin_ = p_.depth_margin_mm;
  bounds_ratio_ = p_.depth_margin_ratio;
}

// 8-connected components of fg_ by runs: union-find over the runs of
// consecutive rows. Blobs are numbered in the order cv::connectedComponents
// gives them (by the first 2x2 block, in raster order, holding one of their
// pixels), so ids come out as they did when that function made them.
void LearnerSegmenter::find_blobs() {
  const int W = fg_.cols, H = fg_.rows;
  runs_.clear();
  row_first_run_.assign(size_t(H) + 1, 0);
  for (int y = 0; y < H; ++y) {
    row_first_run_[y] = int(runs_.size());
    const uint8_t* f = fg_.ptr<uint8_t>(y);
    int x = 0;
    while (x < W) {
      // Most of a row is background: skip it 8 pixels at a time.
      if (x + 8 <= W) {
        uint64_t v;
        std::memcpy(&v, f + x, 8);
        if (!v) {
          x += 8;
          continue;
        }
      }
      if (!f[x]) {
        ++x;
        continue;
      }
      const int x0 = x;
      while (x < W && f[x]) ++x;
      runs_.push_back(Run{y, x0, x - 1});
    }
  }
  row_first_run_[H] = int(runs_.size());
  const int nr = int(runs_.size());
  run_parent_.resize(size_t(nr));
  std::iota(run_parent_.begin(), run_parent_.end(), 0);
  auto find = [&](int i) {
    while (run_parent_[i] != i) i = run_parent_[i] = run_parent_[run_parent_[i]];
    return i;
  };
  for (int y = 1; y < H; ++y) {
    int j = row_first_run_[y - 1];
    const int prev_end = row_first_run_[y];
    for (int r = row_first_run_[y]; r < row_first_run_[y + 1]; ++r) {
      const Run& cur = runs_[r];
      while (j < prev_end && runs_[j].x1 + 1 < cur.x0) ++j;
      for (int k = j; k < prev_end && runs_[k].x0 <= cur.x1 + 1; ++k) {
        const int a = find(k), b = find(r);
        if (a != b) run_parent_[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  // Roots come first in run order, so one pass names every run's blob.
  run_blob_.resize(size_t(nr));
  blobs_.assign(1, Blob());
  for (int r = 0; r < nr; ++r) {
    const int root = find(r);
    if (root == r) {
      run_blob_[r] = int(blobs_.size());
      blobs_.emplace_back();
      blobs_.back().order_key = UINT32_MAX;
    } else {
      run_blob_[r] = run_blob_[root];
    }
    Blob& b = blobs_[run_blob_[r]];
    const Run& run = runs_[r];
    const int64_t len = run.x1 - run.x0 + 1;
    b.area += len;
    b.sum_x += (int64_t(run.x0) + run.x1) * len / 2;
    b.sum_y += int64_t(run.y) * len;
    b.order_key = std::min(b.order_key, uint32_t(run.y >> 1) << 16 | uint32_t(run.x0 >> 1));
  }
  std::vector<int>& order = row_first_run_;  // reused as scratch
  order.resize(blobs_.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin() + 1, order.end(),
            [&](int a, int b) { return blobs_[a].order_key < blobs_[b].order_key; });
  std::vector<int>& rank = run_parent_;  // the union-find is done with
  rank.assign(blobs_.size(), 0);
  std::vector<Blob> sorted(blobs_.size());
  for (size_t i = 1; i < order.size(); ++i) {
    rank[order[i]] = int(i);
    sorted[i] = blobs_[order[i]];
  }
  for (int& b : run_blob_) b = rank[b];
  blobs_.swap(sorted);
}

void LearnerSegmenter::segment(const cv::Mat& color, const cv::Mat& depth, cv::Mat* label) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && color.size() == depth.size());
  const int W = color.cols, H = color.rows;
  classify_pixels(color, depth);
  find_blobs();
  const int min_area = std::max(20, int(p_.min_area_ratio * W * H));
  const std::vector<BlobLook> looks = describe_blobs(color, depth, min_area);
  const std::vector<int> blob_id = identify_blobs(looks, min_area, W, H);
  update_tracks(looks, blob_id);
  // The labels become the next frame's fast state.
  prev_label_ = cv::Scalar::all(0);  // by memset (setTo copies a pattern)
  for (size_t r = 0; r < runs_.size(); ++r) {
    const int id = blob_id[run_blob_[r]];
    if (id) std::memset(prev_label_.ptr<uint8_t>(runs_[r].y) + runs_[r].x0, id, size_t(runs_[r].x1 - runs_[r].x0 + 1));
  }
  prev_label_.copyTo(*label);
  ++frame_;
}

// Each pixel's colour and depth cues, remembered over frames (evidence_), give the foreground mask fg_; the
// learnt background follows the room where no prior depth is given.
void LearnerSegmenter::classify_pixels(const cv::Mat& color, const cv::Mat& depth) {
  const int W = color.cols, H = color.rows;
  const bool first = bg_color_.empty() || bg_color_.size() != color.size();
  if (first) {
    reset();
    color.convertTo(bg_color_, CV_16UC3, 1 << kColorFrac);
    depth.convertTo(bg_depth_, CV_32F);
    evidence_ = cv::Mat::zeros(H, W, CV_16SC1);
    prev_label_ = cv::Mat::zeros(H, W, CV_8UC1);
  }
  const bool has_prior = !prior_.empty() && prior_.size() == color.size();
  if (has_prior) update_depth_bounds();
  fg_.create(H, W, CV_8UC1);
  const float decay = float(p_.memory_decay), margin = float(p_.depth_margin_mm), ratio = float(p_.depth_margin_ratio);
  const float rate = float(p_.background_rate);
  CueConsts k;
  k.decay = fixed(decay, 1 << 15);
  auto term = [&](double cue) { return fixed((1.0 - decay) * cue, kEvidenceOne); };
  k.in_front = term(1.0);
  k.surface_changed = term(0.3);
  k.room = term(-1.0);
  k.nodepth_changed = term(0.7);
  k.nodepth_kept = term(0.4);
  k.nodepth_room = term(-0.5);
  k.fg_level = kEvidenceOne / 4;
  k.cthr = p_.color_threshold;
  k.cthr2 = 2 * p_.color_threshold;
  k.rate = std::clamp(fixed(rate, 1 << 15), 0, 1 << 15);
  // Without a prior the bounds follow the learnt depth, one row at a time.
  std::vector<uint16_t> row_lo(has_prior ? 0 : W), row_hi(has_prior ? 0 : W);
  for (int y = 0; y < H; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    float* bd = bg_depth_.ptr<float>(y);
    const uint16_t *lo, *hi;
    if (has_prior) {
      lo = depth_lo_.ptr<uint16_t>(y);
      hi = depth_hi_.ptr<uint16_t>(y);
    } else {
      depth_bounds_row(W, bd, margin, ratio, row_lo.data(), row_hi.data());
      lo = row_lo.data();
      hi = row_hi.data();
    }
    uint8_t* f = fg_.ptr<uint8_t>(y);
    cue_row(W, color.ptr<uint8_t>(y), d, lo, hi, prev_label_.ptr<uint8_t>(y), bg_color_.ptr<uint16_t>(y),
            evidence_.ptr<int16_t>(y), f, k);
    if (!has_prior) learn_depth_row(W, d, f, margin, ratio, rate, bd);
  }
  // Rectangular kernels: separable, several times cheaper than ellipses at this size.
  cv::morphologyEx(fg_, fg_, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::morphologyEx(fg_, fg_, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7)));
}

// Colour, depth and overlap with last frame's learners, for the blobs big enough to be learners (the rest
// only ever become label 0).
std::vector<LearnerSegmenter::BlobLook> LearnerSegmenter::describe_blobs(const cv::Mat& color, const cv::Mat& depth,
                                                                         int min_area) {
  const int n = int(blobs_.size());
  int big = 0;
  for (int i = 1; i < n; ++i)
    if (blobs_[i].area >= min_area) blobs_[i].slot = big++;
  overlap_.assign(size_t(big) * 256, 0);
  for (size_t r = 0; r < runs_.size(); ++r) {
    Blob& b = blobs_[run_blob_[r]];
    if (b.slot < 0) continue;
    const Run& run = runs_[r];
    const uint8_t* c = color.ptr<uint8_t>(run.y);
    const uint16_t* d = depth.ptr<uint16_t>(run.y);
    const uint8_t* pl = prev_label_.ptr<uint8_t>(run.y);
    int* ov = &overlap_[size_t(b.slot) * 256];
    int64_t s0 = 0, s1 = 0, s2 = 0, ds = 0, dn = 0;
    for (int x = run.x0; x <= run.x1; ++x) {
      s0 += c[3 * x];
      s1 += c[3 * x + 1];
      s2 += c[3 * x + 2];
      ds += d[x];
      dn += d[x] != 0;
      ++ov[pl[x]];
    }
    b.color[0] += s0;
    b.color[1] += s1;
    b.color[2] += s2;
    b.depth_sum += ds;
    b.depth_count += dn;
  }
  std::vector<BlobLook> looks(n);
  for (int i = 1; i < n; ++i) {
    const Blob& b = blobs_[i];
    looks[i].area = int(b.area);
    looks[i].color = cv::Vec3f(cv::Vec3d(double(b.color[0]), double(b.color[1]), double(b.color[2])) / int(b.area));
    looks[i].depth = b.depth_count ? float(double(b.depth_sum) / double(b.depth_count)) : 0.f;
    looks[i].centroid = cv::Point2f(float(double(b.sum_x) / double(b.area)), float(double(b.sum_y) / double(b.area)));
  }
  return looks;
}

const LearnerTrack* LearnerSegmenter::find_active(int id) const {
  for (const auto& t : active_)
    if (t.id == id) return &t;
  return nullptr;
}

// Which learner each blob is (0: none): the one it overlaps most in the last frame (the fast state), else a
// lost learner it looks like (the long-term memory), else a new one.
std::vector<int> LearnerSegmenter::identify_blobs(const std::vector<BlobLook>& looks, int min_area, int W, int H) {
  const int n = int(looks.size());
  std::vector<int> blob_id(n, 0);
  // 1. Fast state: a blob keeps the id it overlaps most (split blobs share it).
  for (int i = 1; i < n; ++i) {
    if (blobs_[i].slot < 0) continue;
    const int* ov = &overlap_[size_t(blobs_[i].slot) * 256];
    int best = 0, best_count = 0;
    for (int id = 1; id < 256; ++id)
      if (ov[id] > best_count) best = id, best_count = ov[id];
    if (best && best_count >= std::min(looks[i].area, find_active(best) ? find_active(best)->area : 1) / 5)
      blob_id[i] = best;
  }
  // 2. Long-term memory: unmatched blobs that look like a remembered learner.
  for (int i = 1; i < n; ++i) {
    if (looks[i].area < min_area || blob_id[i]) continue;
    double best_cost = 1e9;
    int best = -1;
    for (size_t j = 0; j < lost_.size(); ++j) {
      const LearnerTrack& t = lost_[j];
      const double dcol = cv::norm(t.mean_color - looks[i].color);
      const double dpos = cv::norm(t.centroid - looks[i].centroid) / std::max(W, H);
      const double ddep =
          (t.depth_mm > 0 && looks[i].depth > 0) ? std::abs(t.depth_mm - looks[i].depth) / 1000.0 : 0.3;
      const double cost = dcol / 40.0 + dpos / 0.15 + ddep / 0.5;
      if (dcol < 45 && cost < best_cost) best_cost = cost, best = int(j);
    }
    if (best >= 0 && best_cost < 2.5) {
      blob_id[i] = lost_[best].id;
      lost_.erase(lost_.begin() + best);
    } else {
      blob_id[i] = new_id();
      LearnerTrack t;
      t.id = blob_id[i];
      t.first_seen = frame_;
      active_.push_back(t);  // reserve the id while matching
    }
  }
  return blob_id;
}

// The learners' tracks from this frame's blobs: the blobs of each id merged, the long-term descriptor moved
// slowly, learners not seen any more remembered as lost for keep_lost_frames.
void LearnerSegmenter::update_tracks(const std::vector<BlobLook>& looks, const std::vector<int>& blob_id) {
  const int n = int(looks.size());
  LearnerTrack by_id[256];
  for (int i = 1; i < n; ++i) {
    if (!blob_id[i]) continue;
    LearnerTrack& t = by_id[blob_id[i]];
    const LearnerTrack* old = find_active(blob_id[i]);
    const double a0 = t.area, a1 = looks[i].area;
    if (t.area == 0) {
      t.id = blob_id[i];
      t.first_seen = old ? old->first_seen : frame_;
      t.mean_color = looks[i].color;
      t.depth_mm = looks[i].depth;
      t.centroid = looks[i].centroid;
    } else {
      t.mean_color = (t.mean_color * a0 + looks[i].color * a1) / (a0 + a1);
      t.centroid = (t.centroid * a0 + looks[i].centroid * a1) / (a0 + a1);
      if (looks[i].depth > 0) t.depth_mm = t.depth_mm > 0 ? std::min(t.depth_mm, looks[i].depth) : looks[i].depth;
    }
    t.area += looks[i].area;
    t.last_seen = frame_;
  }
  std::vector<LearnerTrack> next;
  for (int id = 1; id < 256; ++id) {
    LearnerTrack& t = by_id[id];
    if (!t.area) continue;
    // Slow descriptor: the long-term memory should not follow every frame.
    if (const LearnerTrack* old = find_active(id); old && old->area > 0)
      t.mean_color = 0.9f * old->mean_color + 0.1f * t.mean_color;
    next.push_back(t);
  }
  for (const auto& t : active_)
    if (t.area > 0 && !by_id[t.id].area) lost_.push_back(t);
  lost_.erase(std::remove_if(lost_.begin(), lost_.end(),
                             [&](const LearnerTrack& t) { return frame_ - t.last_seen > p_.keep_lost_frames; }),
              lost_.end());
  active_ = std::move(next);
}

SegScore score_segmentation(const cv::Mat& pred, const cv::Mat& truth) {
  CV_Assert(pred.type() == CV_8UC1 && truth.type() == CV_8UC1 && pred.size() == truth.size());
  int64_t inter = 0, uni = 0;
  std::vector<std::vector<int64_t>> joint(256, std::vector<int64_t>(256, 0));
  std::vector<int64_t> pa(256, 0), ta(256, 0);
  for (int y = 0; y < pred.rows; ++y) {
    const uint8_t* p = pred.ptr<uint8_t>(y);
    const uint8_t* t = truth.ptr<uint8_t>(y);
    for (int x = 0; x < pred.cols; ++x) {
      inter += p[x] && t[x];
      uni += p[x] || t[x];
      ++joint[t[x]][p[x]];
      ++pa[p[x]];
      ++ta[t[x]];
    }
  }
  SegScore s;
  s.fg_iou = uni ? double(inter) / uni : 1.0;
  double sum = 0;
  int count = 0;
  for (int g = 1; g < 256; ++g) {
    if (!ta[g]) continue;
    int best = 0;
    int64_t best_count = 0;
    for (int q = 1; q < 256; ++q)
      if (joint[g][q] > best_count) best = q, best_count = joint[g][q];
    const double iou = best ? double(joint[g][best]) / double(ta[g] + pa[best] - joint[g][best]) : 0.0;
    sum += iou;
    ++count;
  }
  s.mean_learner_iou = count ? sum / count : 1.0;
  return s;
}

}  // namespace vclassroom
