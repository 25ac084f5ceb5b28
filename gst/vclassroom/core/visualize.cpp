#include <gst/vclassroom/core/visualize.h>

#include <array>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

namespace {

// The turbo map sampled once: 256 RGB entries, index 0 = near (red end).
const std::array<cv::Vec3b, 256>& turbo_rgb() {
  static const std::array<cv::Vec3b, 256> lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(255 - i);
    cv::Mat bgr;
    cv::applyColorMap(ramp, bgr, cv::COLORMAP_TURBO);
    std::array<cv::Vec3b, 256> out;
    for (int i = 0; i < 256; ++i) {
      const cv::Vec3b c = bgr.at<cv::Vec3b>(0, i);
      out[i] = cv::Vec3b(c[2], c[1], c[0]);
    }
    return out;
  }();
  return lut;
}

}  // namespace

void colorize_depth(const cv::Mat& depth, cv::Mat& out, double min_mm, double max_mm) {
  CV_Assert(depth.type() == CV_16UC1);
  out.create(depth.size(), CV_8UC3);
  const auto& lut = turbo_rgb();
  const double span = std::max(1.0, max_mm - min_mm);
  // One table lookup per pixel: 64K entries cost less than a division each.
  static thread_local std::array<cv::Vec3b, 65536> table;
  static thread_local double table_min = -1, table_max = -1;
  if (table_min != min_mm || table_max != max_mm) {
    table[0] = cv::Vec3b(0, 0, 0);
    for (int v = 1; v < 65536; ++v) {
      const double t = std::clamp((v - min_mm) / span, 0.0, 1.0);
      table[v] = lut[static_cast<int>(t * 255.0 + 0.5)];
    }
    table_min = min_mm;
    table_max = max_mm;
  }
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* d = depth.ptr<uint16_t>(y);
    cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < depth.cols; ++x) o[x] = table[d[x]];
  }
}

}  // namespace vclassroom
