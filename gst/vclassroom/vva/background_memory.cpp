#include <gst/vclassroom/vva/background_memory.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

void BackgroundMemory::seed(const cv::Mat& empty_room) {
  if (empty_room.type() != CV_8UC3 || empty_room.empty())
    throw Error("background memory: the empty room must be an RGB image");
  empty_room.convertTo(mean_, CV_32FC3);
  count_ = cv::Mat(empty_room.size(), CV_8UC1, cv::Scalar(std::clamp(params_.frames, 1, 255)));
}

void BackgroundMemory::update(const cv::Mat& color, const cv::Mat& label, cv::Mat* out) {
  if (color.type() != CV_8UC3 || (!label.empty() && (label.type() != CV_8UC1 || label.size() != color.size())))
    throw Error("background memory: expected an RGB image and a label plane of its size");
  if (mean_.size() != color.size()) {
    mean_ = cv::Mat::zeros(color.size(), CV_32FC3);
    count_ = cv::Mat::zeros(color.size(), CV_8UC1);
  }
  out->create(color.size(), CV_8UC3);
  const int frames = std::max(1, params_.frames);
  const float change = float(params_.change);
  for (int y = 0; y < color.rows; ++y) {
    const cv::Vec3b* c = color.ptr<cv::Vec3b>(y);
    const uint8_t* l = label.empty() ? nullptr : label.ptr<uint8_t>(y);
    cv::Vec3f* m = mean_.ptr<cv::Vec3f>(y);
    uint8_t* n = count_.ptr<uint8_t>(y);
    cv::Vec3b* o = out->ptr<cv::Vec3b>(y);
    for (int x = 0; x < color.cols; ++x) {
      if (l && l[x] != 0) {  // a learner: shown as seen; the room behind stays remembered
        o[x] = c[x];
        continue;
      }
      const cv::Vec3f now(c[x][0], c[x][1], c[x][2]);
      const cv::Vec3f d = now - m[x];
      if (n[x] == 0 || std::abs(d[0]) > change || std::abs(d[1]) > change || std::abs(d[2]) > change) {
        m[x] = now;  // something new here: start again
        n[x] = 1;
      } else {
        n[x] = uint8_t(std::min<int>(n[x] + 1, frames));
        m[x] += d * (1.0f / n[x]);
      }
      o[x] = cv::Vec3b(cv::saturate_cast<uint8_t>(m[x][0]), cv::saturate_cast<uint8_t>(m[x][1]),
                       cv::saturate_cast<uint8_t>(m[x][2]));
    }
  }
}

void BackgroundMemory::room_behind_learners(const cv::Mat& label, const cv::Mat& static_depth, cv::Mat* color,
                                            cv::Mat* depth) const {
  if (label.type() != CV_8UC1 || static_depth.type() != CV_16UC1 || label.size() != static_depth.size())
    throw Error("background memory: the room layer needs a label plane and a 16-bit static depth of one size");
  if (mean_.size() != label.size()) {  // nothing remembered at this size
    *depth = cv::Mat::zeros(label.size(), CV_16UC1);
    *color = cv::Mat::zeros(label.size(), CV_8UC3);
    return;
  }
  cv::Mat hidden = label != 0;
  const int margin = params_.room_margin;
  if (margin > 0)
    cv::dilate(hidden, hidden, cv::getStructuringElement(cv::MORPH_RECT, {2 * margin + 1, 2 * margin + 1}));
  depth->create(label.size(), CV_16UC1);
  depth->setTo(0);
  static_depth.copyTo(*depth, hidden & (count_ >= stable_count()));
  mean_.convertTo(*color, CV_8UC3);
}

void BackgroundMemory::apply(WarpSource* src) {
  update(src->color, src->label, &shown_);
  src->color = shown_;
  if (src->static_depth.empty() || src->label.empty()) return;
  room_behind_learners(src->label, src->static_depth, &room_color_, &room_depth_);
  src->room_color = room_color_;
  src->room_depth = room_depth_;
}

}  // namespace vclassroom
