#include <gst/vclassroom/capture/pixel_formats.h>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/core/limits.h>

// Depth words are read as host 16-bit values: right on little-endian hosts only.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "Z16/Y16 are little-endian: byte-swap them on this host");

namespace vclassroom {

const char* capture_format_name(CapturePixelFormat f) {
  switch (f) {
    case CapturePixelFormat::kYuyv: return "YUYV";
    case CapturePixelFormat::kRgb3: return "RGB3";
    case CapturePixelFormat::kMjpg: return "MJPG";
    case CapturePixelFormat::kZ16: return "Z16";
    case CapturePixelFormat::kY16: return "Y16";
  }
  return "?";
}

bool capture_format_is_depth(CapturePixelFormat f) {
  return f == CapturePixelFormat::kZ16 || f == CapturePixelFormat::kY16;
}

namespace {

// Bytes a packed line holds, and whether a buffer of `bytesused` holds
// `height` lines of `stride` (the last one only needs its pixels).
bool holds_lines(size_t bytesused, int width, int height, size_t pixel_bytes, size_t* stride, std::string* error) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) {
    *error = "frame size " + std::to_string(width) + "x" + std::to_string(height) + " out of range";
    return false;
  }
  const size_t line = size_t(width) * pixel_bytes;
  if (*stride == 0) *stride = line;
  if (*stride < line) {
    *error = "line stride " + std::to_string(*stride) + " is shorter than a line of " + std::to_string(line) + " bytes";
    return false;
  }
  const size_t need = *stride * size_t(height - 1) + line;
  if (bytesused < need) {
    *error = "short frame: " + std::to_string(bytesused) + " bytes, " + std::to_string(need) + " expected for " +
             std::to_string(width) + "x" + std::to_string(height);
    return false;
  }
  return true;
}

}  // namespace

bool capture_to_rgb(CapturePixelFormat f, const uint8_t* data, size_t bytesused, int width, int height, size_t stride,
                    cv::Mat* rgb, std::string* error) {
  if (!data) {
    *error = "no frame data";
    return false;
  }
  switch (f) {
    case CapturePixelFormat::kYuyv: {
      if (!holds_lines(bytesused, width, height, 2, &stride, error)) return false;
      if (width % 2) {
        *error = "YUYV needs an even width (got " + std::to_string(width) + ")";
        return false;
      }
      const cv::Mat yuyv(height, width, CV_8UC2, const_cast<uint8_t*>(data), stride);
      cv::cvtColor(yuyv, *rgb, cv::COLOR_YUV2RGB_YUYV);
      return true;
    }
    case CapturePixelFormat::kRgb3: {
      if (!holds_lines(bytesused, width, height, 3, &stride, error)) return false;
      cv::Mat(height, width, CV_8UC3, const_cast<uint8_t*>(data), stride).copyTo(*rgb);
      return true;
    }
    case CapturePixelFormat::kMjpg:
      return decode_jpeg(data, bytesused, width, height, rgb, error);
    case CapturePixelFormat::kZ16:
    case CapturePixelFormat::kY16:
      break;
  }
  *error = std::string(capture_format_name(f)) + " is not a colour format";
  return false;
}

bool capture_to_depth_mm(CapturePixelFormat f, const uint8_t* data, size_t bytesused, int width, int height,
                         size_t stride, double depth_scale, cv::Mat* depth_mm, std::string* error) {
  if (!capture_format_is_depth(f)) {
    *error = std::string(capture_format_name(f)) + " is not a depth format";
    return false;
  }
  if (!data) {
    *error = "no frame data";
    return false;
  }
  if (!(depth_scale > 0) || depth_scale > 1000) {
    *error = "depth scale " + std::to_string(depth_scale) + " out of range";
    return false;
  }
  if (!holds_lines(bytesused, width, height, 2, &stride, error)) return false;
  // V4L2's Z16 and Y16 are little-endian, and so is every host this builds
  // for (the static_assert above).
  const cv::Mat raw(height, width, CV_16UC1, const_cast<uint8_t*>(data), stride);
  if (depth_scale == 1.0)
    raw.copyTo(*depth_mm);
  else
    raw.convertTo(*depth_mm, CV_16UC1, depth_scale);  // rounds and saturates
  return true;
}

std::vector<uint8_t> rgb_to_yuyv(const cv::Mat& rgb) {
  CV_Assert(rgb.type() == CV_8UC3 && rgb.cols % 2 == 0);
  cv::Mat yuv;
  cv::cvtColor(rgb, yuv, cv::COLOR_RGB2YUV);
  std::vector<uint8_t> out(yuv.total() * 2);
  auto luma = [](int v) { return cv::saturate_cast<uint8_t>(16 + v * 219.0 / 255.0); };
  auto chroma = [](int a, int b) { return cv::saturate_cast<uint8_t>(128 + ((a + b) / 2 - 128) * 224.0 / 255.0); };
  for (int y = 0; y < yuv.rows; ++y)
    for (int x = 0; x < yuv.cols; x += 2) {
      const cv::Vec3b p = yuv.at<cv::Vec3b>(y, x), q = yuv.at<cv::Vec3b>(y, x + 1);
      uint8_t* o = &out[(size_t(y) * yuv.cols + x) * 2];
      o[0] = luma(p[0]);
      o[1] = chroma(p[1], q[1]);
      o[2] = luma(q[0]);
      o[3] = chroma(p[2], q[2]);
    }
  return out;
}

}  // namespace vclassroom
