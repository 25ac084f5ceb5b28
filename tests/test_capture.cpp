// Real cameras (issue 12): what a consumer RGB-D camera's V4L2 nodes deliver,
// turned into video/x-rgbd planes; colour and depth paired by capture time;
// depth registered into the colour camera. The algorithms alone: the V4L2
// source that uses them is built on top.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/depth_registration.h>
#include <gst/vclassroom/capture/rgbd_camera.h>
#include <gst/vclassroom/capture/frame_pairing.h>
#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/capture/v4l2_device.h>
#include <gst/vclassroom/core/jpeg.h>

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
  const std::vector<uint8_t> yuyv = rgb_to_yuyv(rgb);
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

// The registration of an undistorted colour camera runs eight pixels at a time; one with lens distortion a
// pixel at a time. With a distortion too small to move a pixel the two must give the same image: the lanes,
// the row ends (a width that is no multiple of eight) and the image border handled alike.
TEST(DepthRegistration, EightPixelsAtATimeGivesWhatOneAtATimeGives) {
  CameraCalib color;
  color.width = 203;
  color.height = 97;
  color.fx = color.fy = 180;
  color.cx = 101;
  color.cy = 48;
  CameraCalib depth = color;
  depth.width = 157;  // another size: footprints of one to two pixels
  depth.height = 75;
  depth.fx = depth.fy = 139;
  depth.cx = 78;
  depth.cy = 37;
  Eigen::Isometry3d depth_to_color = Eigen::Isometry3d::Identity();
  depth_to_color.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  depth_to_color.translation() = Eigen::Vector3d(-0.025, 0.004, 0.002);
  cv::Mat d(depth.height, depth.width, CV_16UC1);
  cv::RNG rng(7);
  rng.fill(d, cv::RNG::UNIFORM, 300, 6000);
  d(cv::Rect(0, 0, 20, 10)).setTo(0);  // no depth there
  CameraCalib distorted = color;
  distorted.distortion[0] = 1e-12;
  ASSERT_TRUE(distorted.has_distortion());
  cv::Mat vector_path, scalar_path;
  DepthRegistration(depth, color, depth_to_color).register_depth(d, &vector_path);
  DepthRegistration(depth, distorted, depth_to_color).register_depth(d, &scalar_path);
  ASSERT_EQ(vector_path.size(), scalar_path.size());
  EXPECT_GT(cv::countNonZero(vector_path), int(vector_path.total() / 2));
  // A footprint edge exactly on a pixel centre may round the other way (the distortion model's own arithmetic).
  EXPECT_LE(cv::countNonZero(vector_path != scalar_path), int(vector_path.total() / 1000));
}

// ---- rgbdsrc on the stand-in device (tests/fakev4l2, preloaded for this program by tests/meson.build)
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/synthetic/classroom.h>

namespace {

// Configures the fake nodes for the next pipeline: they are read when a node is opened.
void fake_devices(const std::string& config) { g_setenv("VCLASSROOM_FAKE_V4L2", config.c_str(), TRUE); }

bool fake_loaded() { return std::string(g_getenv("LD_PRELOAD") ? g_getenv("LD_PRELOAD") : "").find("fakev4l2") != std::string::npos; }

struct Captured {
  std::vector<cv::Mat> color, depth;
  vctest::RunResult run;
  guint64 unpaired = 0, damaged = 0;
};

Captured capture(const std::string& rig, int frames, const std::string& extra = "") {
  Captured c;
  GstElement* p = gst_parse_launch(("rgbdsrc name=src color-device=/fake/color depth-device=/fake/depth rig=" + rig +
                                    " num-buffers=" + std::to_string(frames) + " " + extra +
                                    " ! appsink name=out sync=false")
                                       .c_str(),
                                   nullptr);
  EXPECT_NE(p, nullptr);
  if (!p) return c;
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  GstElement* src = gst_bin_get_by_name(GST_BIN(p), "src");
  {
    vctest::SampleCollector got(out);
    c.run = vctest::run_pipeline(p, 60 * GST_SECOND);
    for (size_t i = 0; i < got.size(); ++i) {
      RgbdInfo info;
      EXPECT_TRUE(rgbd_info_from_caps(got.caps(i), &info, nullptr));
      RgbdFrame f;
      EXPECT_TRUE(f.map(got.buffer(i), info, GST_MAP_READ, nullptr));
      c.color.push_back(f.color().clone());
      c.depth.push_back(f.depth().clone());
    }
  }
  g_object_get(src, "frames-unpaired", &c.unpaired, "frames-damaged", &c.damaged, nullptr);
  gst_object_unref(src);
  gst_object_unref(out);
  gst_object_unref(p);
  return c;
}

// The fake marks instant n in depth pixel (0, 0) as n + 1 and in colour's top-left block as grey 20 + 37n mod 200:
// a pair of one instant has both marks agree.
bool one_instant(const cv::Mat& color, const cv::Mat& depth) {
  const long n = long(depth.at<uint16_t>(0, 0)) - 1;
  const double grey = cv::mean(color(cv::Rect(2, 2, 4, 4)))[0];
  return n >= 0 && std::abs(grey - double(20 + (37 * n) % 200)) < 12;
}

std::string fake_config(const std::string& rig, const std::string& color_format, const std::string& color_extra = "",
                        const std::string& depth_extra = "", int width = 64, int height = 48) {
  const std::string common = ",width=" + std::to_string(width) + ",height=" + std::to_string(height) + ",rig=" + rig;
  return "path=/fake/color,format=" + color_format + common + color_extra + ";path=/fake/depth,format=Z16" + common +
         depth_extra;
}

}  // namespace

TEST(RgbdSrc, NegotiatesEachColourFormatAndDeliversDepthBitExact) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  ClassroomConfig cc;
  const RenderOutput truth = render(Classroom(cc), 0.0, load_rig(rig).camera(0));
  for (const char* format : {"YUYV", "RGB3", "MJPG"}) {
    SCOPED_TRACE(format);
    fake_devices(fake_config(rig, format));
    const Captured c = capture(rig, 8);
    ASSERT_EQ(c.run.error, "");
    ASSERT_EQ(c.depth.size(), 8u);
    for (size_t i = 0; i < c.depth.size(); ++i) {
      EXPECT_TRUE(one_instant(c.color[i], c.depth[i])) << "frame " << i;
      cv::Mat d = c.depth[i].clone();
      d.at<uint16_t>(0, 0) = truth.depth.at<uint16_t>(0, 0);  // the instant's mark
      EXPECT_TRUE(vctest::same_image(d, truth.depth)) << "frame " << i << ": depth not bit-exact";
      cv::Mat col = c.color[i].clone();
      truth.color(cv::Rect(0, 0, 8, 8)).copyTo(col(cv::Rect(0, 0, 8, 8)));
      EXPECT_GT(cv::PSNR(col, truth.color), 25) << "frame " << i;  // 4:2:2 or JPEG on a tiny, detailed view
    }
  }
}

// The library's camera alone (what rgbdsrc wraps), through the fake device: pairs of one instant at the rig
// camera's size; a node that is not there is a CaptureError saying so.
TEST(RgbdCamera, GivesPairsOfOneInstantWithoutGStreamer) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  fake_devices(fake_config(rig, "YUYV"));
  RgbdCamera camera("/fake/color", "/fake/depth", load_rig(rig).camera(0), 30, 1, 10'000'000);
  int pairs = 0;
  for (int tries = 0; pairs < 3 && tries < 200; ++tries) {
    RgbdCamera::Frame f;
    RgbdCamera::Losses losses;
    if (!camera.next(100, &f, &losses)) continue;
    ++pairs;
    EXPECT_EQ(f.color.size(), cv::Size(64, 48));
    EXPECT_EQ(f.depth.type(), CV_16UC1);
    EXPECT_TRUE(one_instant(f.color, f.depth)) << "pair " << pairs;
    EXPECT_TRUE(losses.damaged.empty());
  }
  EXPECT_EQ(pairs, 3);
  try {
    RgbdCamera missing("/fake/none", "/fake/depth", load_rig(rig).camera(0), 30, 1, 10'000'000);
    ADD_FAILURE() << "a camera without its colour node opened";
  } catch (const CaptureError& e) {
    EXPECT_EQ(e.kind(), CaptureError::Kind::kNoDevice) << e.what();
  }
}

// A camera whose depth lens sits 25 mm beside its colour lens, with an image and intrinsics of its own
// (depth_to_color with width/height/fx/fy/cx/cy in the rig): rgbdsrc opens the depth node at the depth
// lens's size and registers its depth into the colour image, where it matches the depth the colour camera
// would see (the fake renders each node from its own lens).
TEST(RgbdSrc, RegistersADepthLensBesideTheColourLens) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig_path = dir / "rig.yaml";
  Rig rig = vctest::make_rig(1, 128, 96);
  CameraCalib& cam = rig.cameras[0];
  Eigen::Isometry3d depth_to_color = Eigen::Isometry3d::Identity();
  depth_to_color.translation() = Eigen::Vector3d(-0.025, 0, 0);  // the colour lens is 25 mm to the depth lens's right
  cam.depth_to_color = depth_to_color;
  cam.depth_lens = CameraCalib::DepthLens{96, 72, cam.fx * 0.7, cam.fy * 0.7, 47.5, 35.5};
  save_rig(rig, rig_path);
  ASSERT_TRUE(load_rig(rig_path).cameras[0].depth_lens.has_value()) << "the rig file lost the depth lens";
  const RenderOutput truth = render(Classroom(ClassroomConfig{}), 0.0, cam);
  fake_devices("path=/fake/color,format=YUYV,width=128,height=96,rig=" + rig_path +
               ";path=/fake/depth,format=Z16,width=96,height=72,rig=" + rig_path);
  const Captured c = capture(rig_path, 4);
  ASSERT_EQ(c.run.error, "");
  ASSERT_EQ(c.depth.size(), 4u);
  const cv::Mat& got = c.depth[3];
  ASSERT_EQ(got.size(), truth.depth.size());
  int both = 0, close = 0, seen = 0, covered = 0;
  for (int y = 0; y < got.rows; ++y)
    for (int x = 0; x < got.cols; ++x) {
      const int t = truth.depth.at<uint16_t>(y, x), g = got.at<uint16_t>(y, x);
      if (t > 0) {
        ++seen;
        if (g > 0) ++covered;
      }
      if (t > 0 && g > 0) {
        ++both;
        if (std::abs(t - g) <= std::max(20, t / 50)) ++close;  // 2 %: the coarser lens's depth steps
      }
    }
  // What the depth lens could not see from 25 mm aside, and the edges, may differ; the rest matches.
  EXPECT_GT(double(covered) / seen, 0.9) << covered << " of " << seen;
  EXPECT_GT(double(close) / both, 0.95) << close << " of " << both;
  std::printf("registered: %d of %d pixels with depth, %d of %d within 2 %%\n", covered, seen, close, both);
  // Unregistered (the rig without depth_to_color), the same nodes give depth from the wrong place: refused at
  // the size check, as the depth node has no mode at the colour size.
  rig.cameras[0].depth_to_color.reset();
  rig.cameras[0].depth_lens.reset();
  save_rig(rig, rig_path);
  const Captured plain = capture(rig_path, 2);
  EXPECT_NE(plain.run.error.find("offers no Z16 or Y16 at 128x96"), std::string::npos) << plain.run.error;
}

TEST(RgbdSrc, PairsRightUnderJitterAndDroppedFrames) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  fake_devices(fake_config(rig, "YUYV", ",jitter_ms=5,drop=0.1,seed=3", ",jitter_ms=5,drop=0.1,seed=4"));
  const Captured c = capture(rig, 40);
  ASSERT_EQ(c.run.error, "");
  ASSERT_EQ(c.depth.size(), 40u);
  for (size_t i = 0; i < c.depth.size(); ++i) EXPECT_TRUE(one_instant(c.color[i], c.depth[i])) << "frame " << i;
  EXPECT_GT(c.unpaired, 0u);  // the instants one node skipped left the other's frame alone: counted, dropped
}

TEST(RgbdSrc, EachFailureHasAClearMessage) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  fake_devices("");
  Captured c = capture(rig, 3);
  EXPECT_NE(c.run.error.find("/fake/color: no such device"), std::string::npos) << c.run.error;
  fake_devices(fake_config(rig, "YUYV", ",busy=1"));
  c = capture(rig, 3);
  EXPECT_NE(c.run.error.find("another program is using it"), std::string::npos) << c.run.error;
  fake_devices(fake_config(rig, "YUYV", "", "", 32, 24));
  c = capture(rig, 3);
  EXPECT_NE(c.run.error.find("offers no YUYV or RGB3 or MJPG at 64x48"), std::string::npos) << c.run.error;
  EXPECT_NE(c.run.error.find("it offers YUYV 32x24@30"), std::string::npos) << c.run.error;
  // A short frame is dropped with a warning, a frame the driver fails with EIO too, and the stream goes on.
  fake_devices(fake_config(rig, "YUYV", ",short_at=2", ",eio_at=4"));
  c = capture(rig, 8);
  EXPECT_EQ(c.run.error, "");
  EXPECT_EQ(c.depth.size(), 8u);
  EXPECT_EQ(c.damaged, 1u);
  ASSERT_EQ(c.run.warnings.size(), 2u);
  EXPECT_NE(c.run.warnings[0].find("a damaged frame dropped from /fake/color"), std::string::npos) << c.run.warnings[0];
  EXPECT_NE(c.run.warnings[1].find("/fake/depth: cannot take a frame"), std::string::npos) << c.run.warnings[1];
  // A node that goes away while streaming stops the source with an error saying so.
  fake_devices(fake_config(rig, "YUYV", "", ",enodev_at=0"));
  c = capture(rig, 1000);
  EXPECT_NE(c.run.error.find("/fake/depth"), std::string::npos) << c.run.error;
  EXPECT_NE(c.run.error.find("went away"), std::string::npos) << c.run.error;
}

// reconnect=true: a camera unplugged while streaming is a warning, and when it is back the frames go on.
TEST(RgbdSrc, UnplugThenReconnectResumes) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  fake_devices(fake_config(rig, "YUYV", "", ",enodev_at=3,vanish_once=1"));
  const Captured c = capture(rig, 10, "reconnect=true");
  EXPECT_EQ(c.run.error, "");
  EXPECT_EQ(c.depth.size(), 10u);
  ASSERT_GE(c.run.warnings.size(), 2u);
  EXPECT_NE(c.run.warnings[0].find("went away; waiting for it to return"), std::string::npos) << c.run.warnings[0];
  EXPECT_NE(c.run.warnings[1].find("returned"), std::string::npos) << c.run.warnings[1];
  for (size_t i = 0; i < c.depth.size(); ++i) EXPECT_TRUE(one_instant(c.color[i], c.depth[i])) << "frame " << i;
}

// The device provider lists a camera whose depth and colour nodes share a bus, and its element (an rgbdsrc
// for both nodes, no rig yet: a nominal calibration with a warning) streams.
TEST(RgbdDeviceProvider, ListsACameraWhoseElementStreams) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
  fake_devices("path=/dev/video60,format=MJPG,width=64,height=48;path=/dev/video61,format=Z16,width=64,height=48");
  GstDeviceProvider* provider = gst_device_provider_factory_get_by_name("rgbddeviceprovider");
  ASSERT_NE(provider, nullptr);
  GList* devices = gst_device_provider_get_devices(provider);
  ASSERT_EQ(g_list_length(devices), 1u);
  GstDevice* device = GST_DEVICE(devices->data);
  gchar* name = gst_device_get_display_name(device);
  EXPECT_STREQ(name, "Fake RGB-D depth (RGB-D)");
  g_free(name);
  GstElement* src = gst_device_create_element(device, "camera");
  ASSERT_NE(src, nullptr);
  gchar *color = nullptr, *depth = nullptr;
  g_object_get(src, "color-device", &color, "depth-device", &depth, nullptr);
  EXPECT_STREQ(color, "/dev/video60");
  EXPECT_STREQ(depth, "/dev/video61");
  g_free(color);
  g_free(depth);
  g_object_set(src, "num-buffers", 3, nullptr);
  GstElement* pipe = gst_pipeline_new(nullptr);
  GstElement* sink = gst_element_factory_make("appsink", "out");
  g_object_set(sink, "sync", FALSE, nullptr);
  gst_bin_add_many(GST_BIN(pipe), src, sink, nullptr);
  ASSERT_TRUE(gst_element_link(src, sink));
  size_t frames = 0;
  {
    vctest::SampleCollector got(sink);
    const vctest::RunResult r = vctest::run_pipeline(pipe);
    EXPECT_EQ(r.error, "");
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("no rig: camera 0 gets a nominal calibration (64x48"), std::string::npos)
        << r.warnings[0];
    frames = got.size();
  }
  EXPECT_EQ(frames, 3u);
  gst_object_unref(pipe);
  g_list_free_full(devices, gst_object_unref);
  gst_object_unref(provider);
}

// A school calibrates live: vclassroom-calibrate reads three rgbdsrc cameras, here fake ones showing the board
// carried through the room, and finds the classroom's rig. The sources are given the maker's intrinsics (a rig
// file; --intrinsics stream), so that a loaded machine that makes the fake cameras drop frames, and with them
// views, cannot make the result depend on the board's intrinsics (those are tested in test_calibration).
TEST(RgbdSrc, CalibrateFindsTheRigLiveFromThreeCameras) {
  if (!fake_loaded()) GTEST_SKIP() << "the fake V4L2 device is not preloaded (run through meson test)";
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "the fake cameras render every instant of the board's walk anew, which AddressSanitizer slows to "
                  "minutes; the release suite runs this, the sanitizer build runs the tool in "
                  "Tools.CalibrateFindsTheSyntheticRigAndEndsWithItsError";
#endif
  vctest::TempDir dir;
  std::string config;
  std::vector<std::string> argv = {std::string(g_getenv("VCLASSROOM_TOOLS_DIR")) + "/vclassroom-calibrate"};
  for (int c = 0; c < 3; ++c) {
    const std::string color = "/dev/video" + std::to_string(70 + 2 * c), depth = "/dev/video" + std::to_string(71 + 2 * c);
    const std::string common = ",width=960,height=540,fps=5,learners=0,board=1,camera=" + std::to_string(c);
    config += "path=" + color + ",format=YUYV" + common + ";path=" + depth + ",format=Z16" + common + ";";
    argv.push_back("--source");
    argv.push_back("rgbdsrc color-device=" + color + " depth-device=" + depth + " rig=" + (dir / "true-rig.yaml") +
                   " camera-id=" + std::to_string(c));
  }
  fake_devices(config);
  save_rig(default_classroom_rig(), dir / "true-rig.yaml");
  argv.insert(argv.end(),
              {"--intrinsics", "stream", "--views", "8", "--out", dir / "cal", "--true-rig", dir / "true-rig.yaml"});
  const vctest::Exit e = vctest::run_tool(argv);
  ASSERT_EQ(e.status, 0) << e.out << e.err;
  EXPECT_NE(e.out.find("view 8: per camera"), std::string::npos) << e.out;
  vctest::expect_rig_error_within_targets(e.out);
}

// On a machine with an RGB-D camera plugged in, its depth node streams through the same code; elsewhere
// this says why it skips.
TEST(RealCamera, ADepthNodeStreamsWhereOneIsPluggedIn) {
  std::string found;
  for (int i = 0; i < 64 && found.empty(); ++i) {
    const std::string path = "/dev/video" + std::to_string(i);
    if (!g_file_test(path.c_str(), G_FILE_TEST_EXISTS)) continue;
    try {
      V4l2Device dev(path);
      for (const CaptureMode& m : dev.modes())
        if (capture_format_is_depth(m.format)) found = path;
    } catch (const CaptureError&) {
    }
  }
  if (found.empty()) GTEST_SKIP() << "no V4L2 node here offers Z16 or Y16 depth (no RGB-D camera plugged in)";
  V4l2Device dev(found);
  CaptureMode mode{};
  for (const CaptureMode& m : dev.modes())
    if (capture_format_is_depth(m.format)) mode = m;
  dev.set_mode(mode);
  dev.start();
  int frames = 0;
  for (int tries = 0; tries < 100 && frames < 5; ++tries) {
    CapturedFrame f;
    if (!dev.next_frame(1000, &f)) continue;
    cv::Mat mm;
    std::string err;
    EXPECT_TRUE(capture_to_depth_mm(mode.format, f.data, f.bytesused, mode.width, mode.height, f.stride, 1.0, &mm, &err))
        << err;
    EXPECT_GT(f.timestamp_ns, 0);
    dev.release(f);
    ++frames;
  }
  EXPECT_EQ(frames, 5) << found << " (" << describe_modes({mode}) << ") delivered " << frames << " frames";
}
