// Image quality as DESIGN.md §5 defines it, so every figure compares with
// published ones: PSNR on 8-bit RGB (MSE over all pixels and channels, peak
// 255) and SSIM (Wang et al. 2004) on BT.601 luma, 11x11 Gaussian window with
// sigma 1.5, K1 = 0.01, K2 = 0.03, data range 255.
#pragma once

#include <opencv2/core.hpp>

namespace vclassroom {

// PSNR in dB of two CV_8UC3 images of the same size over `roi` (whole image
// when empty). +infinity when they are identical.
double psnr_rgb(const cv::Mat& a, const cv::Mat& b, const cv::Rect& roi = cv::Rect());
// PSNR in dB of two CV_8UC3 images over the pixels where the CV_8UC1 `mask` is non-zero; 99 when the mask is
// empty or the images agree there.
double psnr_rgb_masked(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask);
// Mean SSIM (0..1) of the luma of two CV_8UC3 RGB images over `roi`. The
// window statistics are computed inside the roi only (the crop is applied
// first), and the mean is over the windows' centres that lie fully inside
// ("valid" area), as in the reference MATLAB implementation.
double ssim_luma(const cv::Mat& a, const cv::Mat& b, const cv::Rect& roi = cv::Rect());
// BT.601 luma (0.299 R + 0.587 G + 0.114 B) of an RGB image as CV_64F.
cv::Mat luma_bt601(const cv::Mat& rgb);
// A picture of the error for people: |a - b| per channel, amplified x4.
cv::Mat error_image(const cv::Mat& a, const cv::Mat& b);

}  // namespace vclassroom
