// Real cameras (issue 12): what a consumer RGB-D camera's V4L2 nodes deliver,
// turned into video/x-rgbd planes; colour and depth paired by capture time;
// depth registered into the colour camera. The algorithms alone: the V4L2
// source that uses them is built on top.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/depth_registration.h>
#include <gst/vclassroom/capture/frame_pairing.h>
#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/net/rgbd_codec.h>

#include "test_util.h"

using namespace vclassroom;

TEST(CaptureFormats, ColourFormatsDecodeAndShortFramesAreRefused) {
  const int w = 64, h = 48;
  cv::Mat rgb(h, w, CV_8UC3);
  cv::randu(rgb, 0, 255);
  cv::GaussianBlur(rgb, rgb, cv::Size(5, 5), 2);  // camera-like: no pixel-sized noise for 4:2:2 to lose
  std::string err;
  cv::Mat out;
  // RGB3 with padded lines.
  const size_t stride = w * 3 + 16;
  std::vector<uint8_t> rgb3(stride * h, 0xEE);
  for (int y = 0; y < h; ++y) std::memcpy(&rgb3[y * stride], rgb.ptr(y), w * 3);
  ASSERT_TRUE(capture_to_rgb(CapturePixelFormat::kRgb3, rgb3.data(), rgb3.size(), w, h, stride, &out, &err)) << err;
  EXPECT_TRUE(vctest::same_image(out, rgb));
  // YUYV as a UVC camera sends it: back to RGB within the chroma subsampling's loss.
  cv::Mat yuv;
  cv::cvtColor(rgb, yuv, cv::COLOR_RGB2YUV);
  std::vector<uint8_t> yuyv(size_t(w) * h * 2);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; x += 2) {
      const cv::Vec3b a = yuv.at<cv::Vec3b>(y, x), b = yuv.at<cv::Vec3b>(y, x + 1);
      uint8_t* p = &yuyv[(size_t(y) * w + x) * 2];
      p[0] = a[0];
      p[1] = uint8_t((a[1] + b[1]) / 2);
      p[2] = b[0];
      p[3] = uint8_t((a[2] + b[2]) / 2);
    }
  ASSERT_TRUE(capture_to_rgb(CapturePixelFormat::kYuyv, yuyv.data(), yuyv.size(), w, h, 0, &out, &err)) << err;
  EXPECT_GT(cv::PSNR(out, rgb), 30);
  // MJPG through the project's JPEG decoder (libjpeg-turbo).
  std::vector<uint8_t> jpeg;
  encode_jpeg(rgb, 95, &jpeg);
  ASSERT_TRUE(capture_to_rgb(CapturePixelFormat::kMjpg, jpeg.data(), jpeg.size(), w, h, 0, &out, &err)) << err;
  EXPECT_GT(cv::PSNR(out, rgb), 30);
  // A driver's short buffer, a stride shorter than a line, a JPEG of another size: refused, saying why.
  EXPECT_FALSE(capture_to_rgb(CapturePixelFormat::kYuyv, yuyv.data(), yuyv.size() - 1, w, h, 0, &out, &err));
  EXPECT_NE(err.find("short frame"), std::string::npos) << err;
  EXPECT_FALSE(capture_to_rgb(CapturePixelFormat::kRgb3, rgb3.data(), rgb3.size(), w, h, w, &out, &err));
  EXPECT_FALSE(capture_to_rgb(CapturePixelFormat::kMjpg, jpeg.data(), jpeg.size(), w * 2, h, 0, &out, &err));
  EXPECT_FALSE(capture_to_rgb(CapturePixelFormat::kMjpg, jpeg.data(), jpeg.size() / 2, w, h, 0, &out, &err));
  EXPECT_FALSE(capture_to_rgb(CapturePixelFormat::kZ16, yuyv.data(), yuyv.size(), w, h, 0, &out, &err));
}

TEST(CaptureFormats, DepthIsBitExactInMillimetresAndScaled) {
  const int w = 40, h = 30;
  cv::Mat raw(h, w, CV_16UC1);
  cv::randu(raw, 0, 65535);
  raw(cv::Rect(0, 0, 5, 5)).setTo(0);  // no measurement
  std::string err;
  cv::Mat mm;
  ASSERT_TRUE(capture_to_depth_mm(CapturePixelFormat::kZ16, raw.data, raw.total() * 2, w, h, 0, 1.0, &mm, &err)) << err;
  EXPECT_TRUE(vctest::same_image(mm, raw));
  // A camera counting in 1/4 mm (depth_scale 0.25): rounded, 0 stays 0.
  ASSERT_TRUE(capture_to_depth_mm(CapturePixelFormat::kY16, raw.data, raw.total() * 2, w, h, 0, 0.25, &mm, &err)) << err;
  EXPECT_EQ(mm.at<uint16_t>(0, 0), 0);
  EXPECT_EQ(mm.at<uint16_t>(10, 10), uint16_t(std::lround(raw.at<uint16_t>(10, 10) * 0.25)));
  EXPECT_FALSE(capture_to_depth_mm(CapturePixelFormat::kZ16, raw.data, raw.total() * 2 - 2, w, h, 0, 1.0, &mm, &err));
  EXPECT_FALSE(capture_to_depth_mm(CapturePixelFormat::kYuyv, raw.data, raw.total() * 2, w, h, 0, 1.0, &mm, &err));
  EXPECT_FALSE(capture_to_depth_mm(CapturePixelFormat::kZ16, raw.data, raw.total() * 2, w, h, 0, 0.0, &mm, &err));
}

// 30 fps colour and depth, each with up to 5 ms of jitter and 10 % of its
// frames dropped by the driver: every pair is of one instant, nothing is
// paired twice, and every frame without a partner is counted.
TEST(FramePairing, PairsRightUnderJitterAndDroppedFrames) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> jitter(-5'000'000, 5'000'000);
  std::bernoulli_distribution drop(0.1);
  const int64_t period = 33'333'333;
  FramePairer pairer(12'000'000);  // under half the frame interval
  std::vector<std::pair<uint64_t, uint64_t>> pairs;
  std::deque<uint64_t> dropped_c, dropped_d;
  size_t sent_c = 0, sent_d = 0, both = 0;
  for (uint64_t n = 0; n < 600; ++n) {
    const bool c = !drop(rng), d = !drop(rng);
    // Ids carry the instant: frame n is id n on both streams.
    if (c) pairer.push_color(n, int64_t(n) * period + jitter(rng)), ++sent_c;
    if (d) pairer.push_depth(n, int64_t(n) * period + jitter(rng)), ++sent_d;
    if (c && d) ++both;
    while (auto p = pairer.pop(&dropped_c, &dropped_d)) pairs.push_back({p->color_id, p->depth_id});
  }
  for (const auto& [c, d] : pairs) EXPECT_EQ(c, d) << "colour frame " << c << " paired with depth frame " << d;
  // Every instant both streams delivered was paired (the last may still wait for its partner's successor).
  EXPECT_GE(pairs.size() + 1, both);
  EXPECT_EQ(dropped_c.size(), pairer.unpaired_color());
  EXPECT_EQ(dropped_d.size(), pairer.unpaired_depth());
  EXPECT_GT(pairer.unpaired_color(), 0u);
  // Nothing is lost silently: each frame was paired, counted as unpaired, or is still waiting.
  std::deque<uint64_t> waiting_c, waiting_d;
  pairer.clear(&waiting_c, &waiting_d);
  EXPECT_EQ(pairs.size() + dropped_c.size() + waiting_c.size(), sent_c);
  EXPECT_EQ(pairs.size() + dropped_d.size() + waiting_d.size(), sent_d);
}

// A depth sensor 25 mm left of the colour sensor, at half the colour
// resolution, looks at a wall at 2 m with a box face at 1.5 m in front. Once
// registered, the wall is at 2 m and the face at 1.5 m in the colour image,
// the face's edges where the rig says (a registered edge can only be as sharp
// as a depth pixel: within half a depth pixel, here one colour pixel, plus
// the colour pixel's own half), and no hole opens inside either surface.
TEST(DepthRegistration, PutsAKnownPlaneWhereTheRigSays) {
  CameraCalib color;
  color.width = 320;
  color.height = 240;
  color.fx = color.fy = 300;
  color.cx = 159.5;
  color.cy = 119.5;
  CameraCalib depth = scale_camera(color, 160, 120);
  Eigen::Isometry3d depth_to_color = Eigen::Isometry3d::Identity();
  depth_to_color.translation() = Eigen::Vector3d(-0.025, 0, 0);  // the colour lens is 25 mm to the depth lens's right
  // The box face: X in [-0.2, 0.3], Y in [-0.15, 0.1] (colour camera frame) at Z = 1.5; the wall at Z = 2.
  const double fx0 = -0.2, fx1 = 0.3, fy0 = -0.15, fy1 = 0.1;
  cv::Mat d(depth.height, depth.width, CV_16UC1);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) {
      // The ray of depth pixel (x, y), in the colour frame, hits the face or the wall.
      const Eigen::Vector3d ray = depth.unproject(x, y, 1.0);
      const Eigen::Vector3d at_face = ray * 1.5 + depth_to_color.translation();
      const bool face = at_face.x() >= fx0 && at_face.x() <= fx1 && at_face.y() >= fy0 && at_face.y() <= fy1;
      d.at<uint16_t>(y, x) = face ? 1500 : 2000;
    }
  DepthRegistration reg(depth, color, depth_to_color);
  cv::Mat out;
  reg.register_depth(d, &out);
  ASSERT_EQ(out.size(), cv::Size(color.width, color.height));
  // Where the rig puts the face's left and right edges on the middle row, in colour pixels.
  const double left = color.fx * fx0 / 1.5 + color.cx, right = color.fx * fx1 / 1.5 + color.cx;
  const int row = int(color.cy + color.fy * (fy0 + fy1) / 2 / 1.5);
  int first = -1, last = -1;
  for (int x = 0; x < color.width; ++x)
    if (out.at<uint16_t>(row, x) == 1500) {
      if (first < 0) first = x;
      last = x;
    }
  ASSERT_GE(first, 0) << "the face is not in the registered depth";
  const double tolerance = 0.5 * color.fx / depth.fx + 0.5;
  EXPECT_LE(std::abs((first - 0.5) - left), tolerance) << "left edge at " << first << ", rig says " << left;
  EXPECT_LE(std::abs((last + 0.5) - right), tolerance) << "right edge at " << last << ", rig says " << right;
  // No hole inside the face, and the wall is at 2 m where the depth sensor saw it.
  const cv::Rect inside(int(std::ceil(left)) + 1, int(color.cy + color.fy * fy0 / 1.5) + 2,
                        int(right - left) - 3, int(color.fy * (fy1 - fy0) / 1.5) - 4);
  EXPECT_EQ(cv::countNonZero(out(inside) != 1500), 0);
  EXPECT_EQ(out.at<uint16_t>(10, 300), 2000);
  // Beside the face on the side the depth lens cannot see behind it, the wall stays unknown (0), never
  // filled with the face's depth: the z-buffer and the footprint leave occlusion holes alone.
  EXPECT_EQ(out.at<uint16_t>(row, first - 1) == 0 || out.at<uint16_t>(row, first - 1) == 2000, true);
  // A depth image of another size is refused.
  EXPECT_THROW(reg.register_depth(cv::Mat(10, 10, CV_16UC1, cv::Scalar(1)), &out), Error);
}
