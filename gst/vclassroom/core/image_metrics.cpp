#include <gst/vclassroom/core/image_metrics.h>

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

namespace {
cv::Rect whole_or(const cv::Mat& m, const cv::Rect& roi) {
  return roi.area() > 0 ? (roi & cv::Rect(0, 0, m.cols, m.rows)) : cv::Rect(0, 0, m.cols, m.rows);
}
}  // namespace

double psnr_rgb_masked(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  CV_Assert(a.type() == CV_8UC3 && b.type() == CV_8UC3 && a.size() == b.size() && mask.type() == CV_8UC1 &&
            mask.size() == a.size());
  const double values = 3.0 * cv::countNonZero(mask), se = cv::norm(a, b, cv::NORM_L2SQR, mask);
  return values == 0 || se == 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 * values / se);
}

double psnr_rgb(const cv::Mat& a, const cv::Mat& b, const cv::Rect& roi) {
  CV_Assert(a.type() == CV_8UC3 && b.type() == CV_8UC3 && a.size() == b.size());
  const cv::Rect r = whole_or(a, roi);
  double sse = 0;
  for (int y = r.y; y < r.y + r.height; ++y) {
    const uint8_t* pa = a.ptr<uint8_t>(y) + 3 * r.x;
    const uint8_t* pb = b.ptr<uint8_t>(y) + 3 * r.x;
    int64_t row = 0;
    for (int i = 0; i < 3 * r.width; ++i) {
      const int d = int(pa[i]) - int(pb[i]);
      row += d * d;
    }
    sse += double(row);
  }
  const double mse = sse / (3.0 * r.area());
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

cv::Mat luma_bt601(const cv::Mat& rgb) {
  CV_Assert(rgb.type() == CV_8UC3);
  cv::Mat out(rgb.size(), CV_64F);
  for (int y = 0; y < rgb.rows; ++y) {
    const cv::Vec3b* p = rgb.ptr<cv::Vec3b>(y);
    double* o = out.ptr<double>(y);
    for (int x = 0; x < rgb.cols; ++x) o[x] = 0.299 * p[x][0] + 0.587 * p[x][1] + 0.114 * p[x][2];
  }
  return out;
}

double ssim_luma(const cv::Mat& a, const cv::Mat& b, const cv::Rect& roi) {
  CV_Assert(a.type() == CV_8UC3 && b.type() == CV_8UC3 && a.size() == b.size());
  const cv::Rect r = whole_or(a, roi);
  const cv::Mat x = luma_bt601(a(r)), y = luma_bt601(b(r));
  const double c1 = std::pow(0.01 * 255, 2), c2 = std::pow(0.03 * 255, 2);
  const cv::Mat g = cv::getGaussianKernel(11, 1.5, CV_64F);
  auto filt = [&](const cv::Mat& m) {
    cv::Mat o;
    // Valid windows only: filter, then keep centres at least 5 px inside.
    cv::sepFilter2D(m, o, CV_64F, g, g, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
    return o;
  };
  const cv::Mat mx = filt(x), my = filt(y);
  const cv::Mat sxx = filt(x.mul(x)) - mx.mul(mx);
  const cv::Mat syy = filt(y.mul(y)) - my.mul(my);
  const cv::Mat sxy = filt(x.mul(y)) - mx.mul(my);
  const cv::Mat num = (2 * mx.mul(my) + c1).mul(2 * sxy + c2);
  const cv::Mat den = (mx.mul(mx) + my.mul(my) + c1).mul(sxx + syy + c2);
  cv::Mat map;
  cv::divide(num, den, map);
  if (map.rows > 10 && map.cols > 10) map = map(cv::Rect(5, 5, map.cols - 10, map.rows - 10));
  return cv::mean(map)[0];
}

cv::Mat error_image(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  d.convertTo(d, CV_8UC3, 4.0);
  return d;
}

}  // namespace vclassroom
