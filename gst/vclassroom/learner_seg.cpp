#include "learner_seg.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

LearnerSegmenter::LearnerSegmenter(const SegParams& params) : p_(params) {}

void LearnerSegmenter::set_static_depth(const cv::Mat& depth_mm) {
  CV_Assert(depth_mm.empty() || depth_mm.type() == CV_16UC1);
  prior_ = depth_mm.clone();
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

void LearnerSegmenter::segment(const cv::Mat& color, const cv::Mat& depth, cv::Mat* label) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && color.size() == depth.size());
  const int W = color.cols, H = color.rows;
  const bool first = bg_color_.empty() || bg_color_.size() != color.size();
  if (first) {
    reset();
    color.convertTo(bg_color_, CV_32FC3);
    depth.convertTo(bg_depth_, CV_32F);
    evidence_ = cv::Mat::zeros(H, W, CV_32F);
    prev_label_ = cv::Mat::zeros(H, W, CV_8UC1);
  }
  const bool has_prior = !prior_.empty() && prior_.size() == color.size();
  fg_.create(H, W, CV_8UC1);
  const float decay = float(p_.memory_decay), margin = float(p_.depth_margin_mm), ratio = float(p_.depth_margin_ratio);
  const int cthr = p_.color_threshold;
  const float rate = float(p_.background_rate);
  for (int y = 0; y < H; ++y) {
    const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    const uint16_t* d = depth.ptr<uint16_t>(y);
    const uint16_t* pr = has_prior ? prior_.ptr<uint16_t>(y) : nullptr;
    float* bd = bg_depth_.ptr<float>(y);
    cv::Vec3f* bc = bg_color_.ptr<cv::Vec3f>(y);
    float* ev = evidence_.ptr<float>(y);
    const uint8_t* pl = prev_label_.ptr<uint8_t>(y);
    uint8_t* f = fg_.ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x) {
      const float sd = pr ? float(pr[x]) : bd[x];
      const int dc = std::abs(int(c[x][0]) - int(bc[x][0])) + std::abs(int(c[x][1]) - int(bc[x][1])) +
                     std::abs(int(c[x][2]) - int(bc[x][2]));
      float cue;
      if (d[x] && sd > 0) {
        const float thr = std::max(margin, ratio * sd);
        if (d[x] < sd - thr) cue = 1.0f;                   // in front of the room
        else if (d[x] < sd + thr) cue = dc > 2 * cthr ? 0.3f : -1.0f;  // on the room's surface
        else cue = -1.0f;                                  // behind what we took for the room: room
      } else {
        // No depth: colour change, or what this pixel was a frame ago.
        cue = dc > cthr ? 0.7f : (pl[x] ? 0.4f : -0.5f);
      }
      ev[x] = decay * ev[x] + (1.0f - decay) * cue;
      const bool is_fg = cue >= 1.0f || ev[x] > 0.25f;
      f[x] = is_fg ? 255 : 0;
      if (!is_fg) {
        // Selective update: only where no learner is.
        for (int ch = 0; ch < 3; ++ch) bc[x][ch] += rate * (float(c[x][ch]) - bc[x][ch]);
        if (!pr && d[x]) {
          if (d[x] > bd[x] + std::max(margin, ratio * bd[x]) || bd[x] <= 0) bd[x] = d[x];
          else bd[x] += rate * (float(d[x]) - bd[x]);
        }
      }
    }
  }
  // Rectangular kernels: separable, several times cheaper than ellipses at this size.
  cv::morphologyEx(fg_, fg_, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::morphologyEx(fg_, fg_, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7)));
  const int n = cv::connectedComponentsWithStats(fg_, cc_labels_, cc_stats_, cc_centroids_, 8, CV_32S);
  const int min_area = std::max(20, int(p_.min_area_ratio * W * H));

  // Overlap of each blob with last frame's learners.
  std::vector<int> overlap(size_t(n) * 256, 0);
  for (int y = 0; y < H; ++y) {
    const int* l = cc_labels_.ptr<int>(y);
    const uint8_t* pl = prev_label_.ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x)
      if (l[x] && pl[x]) ++overlap[size_t(l[x]) * 256 + pl[x]];
  }
  std::vector<int> blob_id(n, 0);
  std::vector<LearnerTrack> next;
  auto find_active = [&](int id) -> const LearnerTrack* {
    for (const auto& t : active_)
      if (t.id == id) return &t;
    return nullptr;
  };
  // Blob descriptors.
  struct Desc {
    cv::Vec3f color{0, 0, 0};
    float depth = 0;
    int area = 0;
    cv::Point2f centroid;
  };
  std::vector<Desc> desc(n);
  {
    std::vector<cv::Vec3d> sum(n, cv::Vec3d(0, 0, 0));
    std::vector<double> dsum(n, 0);
    std::vector<int> dcount(n, 0);
    for (int y = 0; y < H; ++y) {
      const int* l = cc_labels_.ptr<int>(y);
      const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
      const uint16_t* d = depth.ptr<uint16_t>(y);
      for (int x = 0; x < W; ++x)
        if (l[x]) {
          sum[l[x]] += cv::Vec3d(c[x][0], c[x][1], c[x][2]);
          if (d[x]) {
            dsum[l[x]] += d[x];
            ++dcount[l[x]];
          }
        }
    }
    for (int i = 1; i < n; ++i) {
      desc[i].area = cc_stats_.at<int>(i, cv::CC_STAT_AREA);
      desc[i].color = cv::Vec3f(sum[i] / std::max(1, desc[i].area));
      desc[i].depth = dcount[i] ? float(dsum[i] / dcount[i]) : 0.f;
      desc[i].centroid = cv::Point2f(float(cc_centroids_.at<double>(i, 0)), float(cc_centroids_.at<double>(i, 1)));
    }
  }
  // 1. Fast state: a blob keeps the id it overlaps most (split blobs share it).
  for (int i = 1; i < n; ++i) {
    if (desc[i].area < min_area) continue;
    int best = 0, best_count = 0;
    for (int id = 1; id < 256; ++id)
      if (overlap[size_t(i) * 256 + id] > best_count) best = id, best_count = overlap[size_t(i) * 256 + id];
    if (best && best_count >= std::min(desc[i].area, find_active(best) ? find_active(best)->area : 1) / 5)
      blob_id[i] = best;
  }
  // 2. Long-term memory: unmatched blobs that look like a remembered learner.
  for (int i = 1; i < n; ++i) {
    if (desc[i].area < min_area || blob_id[i]) continue;
    double best_cost = 1e9;
    int best = -1;
    for (size_t j = 0; j < lost_.size(); ++j) {
      const LearnerTrack& t = lost_[j];
      const double dcol = cv::norm(t.mean_color - desc[i].color);
      const double dpos = cv::norm(t.centroid - desc[i].centroid) / std::max(W, H);
      const double ddep = (t.depth_mm > 0 && desc[i].depth > 0) ? std::abs(t.depth_mm - desc[i].depth) / 1000.0 : 0.3;
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
  // Track states: merge the blobs of each id.
  std::map<int, LearnerTrack> by_id;
  for (int i = 1; i < n; ++i) {
    if (!blob_id[i]) continue;
    LearnerTrack& t = by_id[blob_id[i]];
    const LearnerTrack* old = find_active(blob_id[i]);
    const double a0 = t.area, a1 = desc[i].area;
    if (t.area == 0) {
      t.id = blob_id[i];
      t.first_seen = old ? old->first_seen : frame_;
      t.mean_color = desc[i].color;
      t.depth_mm = desc[i].depth;
      t.centroid = desc[i].centroid;
    } else {
      t.mean_color = (t.mean_color * a0 + desc[i].color * a1) / (a0 + a1);
      t.centroid = (t.centroid * a0 + desc[i].centroid * a1) / (a0 + a1);
      if (desc[i].depth > 0) t.depth_mm = t.depth_mm > 0 ? std::min(t.depth_mm, desc[i].depth) : desc[i].depth;
    }
    t.area += desc[i].area;
    t.last_seen = frame_;
  }
  for (auto& [id, t] : by_id) {
    // Slow descriptor: the long-term memory should not follow every frame.
    if (const LearnerTrack* old = find_active(id); old && old->area > 0)
      t.mean_color = 0.9f * old->mean_color + 0.1f * t.mean_color;
    next.push_back(t);
  }
  for (const auto& t : active_)
    if (t.area > 0 && !by_id.count(t.id)) lost_.push_back(t);
  lost_.erase(std::remove_if(lost_.begin(), lost_.end(),
                             [&](const LearnerTrack& t) { return frame_ - t.last_seen > p_.keep_lost_frames; }),
              lost_.end());
  active_ = std::move(next);

  label->create(H, W, CV_8UC1);
  for (int y = 0; y < H; ++y) {
    const int* l = cc_labels_.ptr<int>(y);
    uint8_t* o = label->ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x) o[x] = uint8_t(blob_id[l[x]]);
  }
  label->copyTo(prev_label_);
  ++frame_;
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
