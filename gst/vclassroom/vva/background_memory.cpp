#include <gst/vclassroom/vva/background_memory.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

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
      if (l && l[x] != 0) {  // a learner: shown as seen, and nothing of the room remembered here
        n[x] = 0;
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

}  // namespace vclassroom
