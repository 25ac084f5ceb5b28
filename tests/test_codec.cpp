// rgbdenc/rgbddec and their codec: depth and labels bit-exact, colour close,
// damaged frames detected and dropped, calibration kept across RTP.
#include <gtest/gtest.h>

#include <gst/app/gstappsrc.h>
#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/net/pose_stamp.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/net/rgbd_codec.h>
#include <opencv2/imgproc.hpp>

#include "test_util.h"

using namespace vclassroom;

namespace {

double psnr(const cv::Mat& a, const cv::Mat& b) { return cv::PSNR(a, b, 255.0); }

cv::Mat sensor_depth(const Classroom& room, const CameraCalib& cam, double t, uint64_t frame) {
  RenderOutput clean = render(room, t, cam);
  cv::Mat depth, color;
  apply_sensor_model(clean, cam, SensorParams(), 1, frame, &depth, &color);
  return depth;
}

cv::Mat random_depth(int rows, int cols, unsigned seed, double hole_share) {
  cv::Mat d(rows, cols, CV_16UC1);
  cv::RNG rng(seed);
  rng.fill(d, cv::RNG::UNIFORM, 1, 65536);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      if (rng.uniform(0.0, 1.0) < hole_share) d.at<uint16_t>(y, x) = 0;
  return d;
}

cv::Mat depth_round_trip(const cv::Mat& d) {
  std::vector<uint8_t> bytes;
  encode_depth_lossless(d, &bytes);
  cv::Mat back;
  EXPECT_TRUE(decode_depth_lossless(bytes.data(), bytes.size(), d.cols, d.rows, &back));
  return back;
}

}  // namespace

TEST(DepthCodec, LosslessOnEveryKindOfImage) {
  const std::vector<cv::Mat> images = {
      random_depth(37, 53, 1, 0.0),  random_depth(37, 53, 2, 0.3), random_depth(1, 1, 3, 0.0),
      random_depth(64, 1, 4, 0.5),   cv::Mat::zeros(20, 30, CV_16UC1), cv::Mat(20, 30, CV_16UC1, cv::Scalar(65535)),
      cv::Mat(20, 30, CV_16UC1, cv::Scalar(1)),
  };
  for (size_t i = 0; i < images.size(); ++i)
    EXPECT_TRUE(vctest::same_image(depth_round_trip(images[i]), images[i])) << "image " << i;
  // A view into a larger image (rows with a stride) codes the view only.
  cv::Mat big = random_depth(40, 60, 9, 0.2);
  cv::Mat roi = big(cv::Rect(5, 7, 31, 17));
  EXPECT_TRUE(vctest::same_image(depth_round_trip(roi), roi.clone()));
}

TEST(DepthCodec, SensorDepthOfTheClassroomIsLosslessAndSmall) {
  Classroom room;
  const CameraCalib cam = default_classroom_rig().camera(0);
  cv::Mat d = sensor_depth(room, cam, 2.0, 60);
  std::vector<uint8_t> bytes;
  encode_depth_lossless(d, &bytes);
  cv::Mat back;
  ASSERT_TRUE(decode_depth_lossless(bytes.data(), bytes.size(), d.cols, d.rows, &back));
  EXPECT_TRUE(vctest::same_image(back, d));
  // Raw is 2 bytes a pixel; a useful depth codec must at least halve it on real-looking depth.
  EXPECT_LT(bytes.size(), d.total());
}

TEST(DepthCodec, DamagedDataIsRejectedNotMisread) {
  cv::Mat d = random_depth(24, 32, 5, 0.2);
  std::vector<uint8_t> bytes;
  encode_depth_lossless(d, &bytes);
  cv::Mat back;
  for (size_t cut = 0; cut < bytes.size(); cut += 7)
    EXPECT_FALSE(decode_depth_lossless(bytes.data(), cut, d.cols, d.rows, &back)) << "cut at " << cut;
  EXPECT_FALSE(decode_depth_lossless(bytes.data(), bytes.size(), d.cols + 1, d.rows, &back));
}

TEST(DepthCodec, WireFormatIsPinned) {
  // 2x2 depth {5, 0; 0, 0}: a run of 0 zeros and 1 valid pixel (residual 5,
  // zigzag 10 = nibbles 0xA 0x1), then 3 zeros and no valid pixel. Nibbles
  // 0 1 A 1 3 0, low nibble first. A faster coder must still read and write this.
  cv::Mat d = cv::Mat::zeros(2, 2, CV_16UC1);
  d.at<uint16_t>(0, 0) = 5;
  const std::vector<uint8_t> wire = {0x10, 0x1A, 0x03};
  std::vector<uint8_t> bytes;
  encode_depth_lossless(d, &bytes);
  EXPECT_EQ(bytes, wire);
  cv::Mat back;
  ASSERT_TRUE(decode_depth_lossless(wire.data(), wire.size(), 2, 2, &back));
  EXPECT_TRUE(vctest::same_image(back, d));
}

TEST(DepthCodec, LongRunsAndTrailingBytesDecodeAlike) {
  // A 1000x1000 empty image is one run of 10^6 zeros: a 7-nibble value. It
  // decodes the same with bytes after it (read by the 64-bit fast path) and
  // without (the nibble-by-nibble path at the end of the data).
  const cv::Mat empty = cv::Mat::zeros(1000, 1000, CV_16UC1);
  std::vector<uint8_t> bytes;
  encode_depth_lossless(empty, &bytes);
  ASSERT_LT(bytes.size(), 8u);
  cv::Mat back;
  ASSERT_TRUE(decode_depth_lossless(bytes.data(), bytes.size(), 1000, 1000, &back));
  EXPECT_TRUE(vctest::same_image(back, empty));
  std::vector<uint8_t> padded = bytes;
  padded.resize(bytes.size() + 16, 0);
  ASSERT_TRUE(decode_depth_lossless(padded.data(), padded.size(), 1000, 1000, &back));
  EXPECT_TRUE(vctest::same_image(back, empty));
  // The same length of run far from the end of the data: a full last row follows it.
  cv::Mat framed = empty.clone();
  framed.at<uint16_t>(0, 0) = 1234;
  for (int x = 0; x < 1000; ++x) framed.at<uint16_t>(999, x) = uint16_t(1000 + 37 * x);
  EXPECT_TRUE(vctest::same_image(depth_round_trip(framed), framed));
}

TEST(DepthCodec, ValuesLongerThan32BitsAreRejected) {
  // Every nibble says "more": no value ever ends, near the end of the data or far from it.
  const std::vector<uint8_t> endless(64, 0xFF);
  cv::Mat back;
  for (size_t size : {size_t(3), size_t(7), size_t(64)})
    EXPECT_FALSE(decode_depth_lossless(endless.data(), size, 4, 4, &back)) << size << " bytes";
}

namespace {

// The depth coder's wire form of a list of values, written here by hand
// (3 value bits and a "more" bit per nibble, low nibble first).
std::vector<uint8_t> nibble_values(const std::vector<uint32_t>& values) {
  std::vector<uint8_t> nibbles;
  for (uint32_t v : values) {
    for (; v >= 8; v >>= 3) nibbles.push_back(static_cast<uint8_t>((v & 7) | 8));
    nibbles.push_back(static_cast<uint8_t>(v));
  }
  std::vector<uint8_t> bytes((nibbles.size() + 1) / 2, 0);
  for (size_t i = 0; i < nibbles.size(); ++i) bytes[i / 2] |= static_cast<uint8_t>(nibbles[i] << (4 * (i & 1)));
  return bytes;
}

}  // namespace

TEST(DepthCodec, HugeResidualsAreRejectedWithoutOverflow) {
  // Issue 14: a residual near 2^32 added to a prediction of 65535 overflowed
  // a signed int (undefined behaviour, reported by UBSan and the fuzzer; the
  // corpus keeps the input as rgbd_frame/depth-residual-overflow).
  // Run: 0 zeros, 2 valid pixels; 65535 (zigzag 131070), then 0xFFFFFFFE (unzigzag 2^31 - 1).
  cv::Mat back;
  for (uint32_t residual : {0xFFFFFFFEu, 0xFFFFFFFFu, 0xFFFFFFFDu}) {
    std::vector<uint8_t> wire = nibble_values({0, 2, 131070, residual});
    EXPECT_FALSE(decode_depth_lossless(wire.data(), wire.size(), 2, 1, &back)) << residual;
    wire.resize(wire.size() + 16, 0);  // the same through the 64-bit fast path
    EXPECT_FALSE(decode_depth_lossless(wire.data(), wire.size(), 2, 1, &back)) << residual;
  }
  // The largest residual that still gives a valid pixel decodes: 65535 then 1.
  const std::vector<uint8_t> wire = nibble_values({0, 2, 131070, 131067});
  ASSERT_TRUE(decode_depth_lossless(wire.data(), wire.size(), 2, 1, &back));
  EXPECT_EQ(back.at<uint16_t>(0, 1), 1);
}

TEST(DepthCodec, ImpossibleSizesAreRejected) {
  const std::vector<uint8_t> wire = nibble_values({0, 1, 10});
  cv::Mat back;
  for (auto [w, h] : std::vector<std::pair<int, int>>{{0, 1}, {1, 0}, {-1, 1}, {16385, 1}, {1, -7}})
    EXPECT_FALSE(decode_depth_lossless(wire.data(), wire.size(), w, h, &back)) << w << "x" << h;
}

TEST(ColorCodec, JpegDeclaringAHugeSizeIsRejectedBeforeDecoding) {
  // A 16x16 JPEG whose header is edited to declare 60000x60000: refused from
  // the header, naming the declared size, before libjpeg allocates for it.
  cv::Mat rgb(16, 16, CV_8UC3, cv::Scalar(10, 200, 30));
  std::vector<uint8_t> jpeg;
  encode_jpeg(rgb, 90, &jpeg);
  size_t sof = 0;
  for (size_t i = 0; i + 9 < jpeg.size(); ++i)
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {
      sof = i;
      break;
    }
  ASSERT_NE(sof, 0u) << "no baseline SOF marker";
  std::vector<uint8_t> huge = jpeg;
  // Height and width 60000 (libjpeg itself refuses more than 65500 in its header).
  for (size_t k = sof + 5; k < sof + 9; k += 2) huge[k] = 0xEA, huge[k + 1] = 0x60;
  cv::Mat back;
  std::string err;
  EXPECT_FALSE(decode_jpeg(huge.data(), huge.size(), 16, 16, &back, &err));
  EXPECT_NE(err.find("60000x60000"), std::string::npos) << "[" << err << "]";
  EXPECT_TRUE(back.empty());
  // Through the frame container too: a JPEG section declaring another size.
  RgbdCodedFrame f{rgb, cv::Mat(16, 16, CV_16UC1, cv::Scalar(1000)), {}};
  std::vector<uint8_t> frame;
  encode_rgbd_frame(f, 90, &frame);
  const size_t at = 16 + 12 + sof;  // header, colour section header, then the JPEG
  for (size_t k = at + 5; k < at + 9; k += 2) frame[k] = 0xEA, frame[k + 1] = 0x60;
  const uint32_t crc = crc32(frame.data() + 28, jpeg.size());  // keep the section's checksum right
  for (int i = 0; i < 4; ++i) frame[24 + i] = static_cast<uint8_t>(crc >> (8 * i));
  RgbdCodedFrame out;
  EXPECT_FALSE(decode_rgbd_frame(frame.data(), frame.size(), 16, 16, &out, &err));
  EXPECT_NE(err.find("60000x60000"), std::string::npos) << err;
  // And an intact one still decodes.
  EXPECT_TRUE(decode_jpeg(jpeg.data(), jpeg.size(), 16, 16, &back, &err)) << err;
}

TEST(PoseStamp, WireFormatIsPinnedAndReadAtAnyAlignment) {
  // The pose header extension's 16 bytes, big-endian, read and written at
  // every offset of a buffer (packet data has no alignment: issue 14's UBSan
  // report of misaligned 64-bit loads through GST_READ_UINT64_BE).
  const PoseStamp stamp{0x0102030405060708ull, -1, {}};
  const uint8_t pinned[16] = {1, 2, 3, 4, 5, 6, 7, 8, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
  uint8_t buf[32];
  for (size_t at = 0; at < 8; ++at) {
    EXPECT_EQ(pose_stamp_to_wire(stamp, buf + at, 16), 16u);
    EXPECT_EQ(std::memcmp(buf + at, pinned, 16), 0) << "offset " << at;
    PoseStamp back;
    ASSERT_TRUE(pose_stamp_from_wire(buf + at, 16, &back));
    EXPECT_EQ(back.seq, stamp.seq);
    EXPECT_EQ(back.viewer_time_ns, -1);
  }
  PoseStamp back;
  EXPECT_FALSE(pose_stamp_from_wire(buf, 15, &back));
  EXPECT_FALSE(pose_stamp_from_wire(buf, 17, &back));
  EXPECT_FALSE(pose_stamp_from_wire(nullptr, 16, &back));
  EXPECT_EQ(pose_stamp_to_wire(stamp, buf, 15), 0u);
}

// The long form carries the pose the server rendered (after its navigation bounds) and whether it clamped it.
TEST(PoseStamp, LongFormCarriesTheRenderedPoseAndTheClampedFlag) {
  Pose pose;
  pose.position = Eigen::Vector3d(0.5, -1.25, 3);
  pose.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  pose.clamped = true;
  const PoseStamp stamp{42, 7000000, rendered_pose_of(pose)};
  uint8_t buf[kPoseStampWithPoseSize + 8];
  for (size_t at = 0; at < 8; ++at) {
    ASSERT_EQ(pose_stamp_to_wire(stamp, buf + at, kPoseStampWithPoseSize), kPoseStampWithPoseSize);
    EXPECT_EQ(buf[at + 16], 3) << "flags: pose follows, clamped";
    PoseStamp back;
    ASSERT_TRUE(pose_stamp_from_wire(buf + at, kPoseStampWithPoseSize, &back)) << "offset " << at;
    EXPECT_EQ(back.seq, 42u);
    EXPECT_EQ(back.viewer_time_ns, 7000000);
    EXPECT_TRUE(back.rendered.known);
    EXPECT_TRUE(back.rendered.clamped);
    EXPECT_FLOAT_EQ(back.rendered.position[1], -1.25f);
    EXPECT_FLOAT_EQ(back.rendered.orientation[0], float(std::cos(0.15)));
    EXPECT_FLOAT_EQ(back.rendered.orientation[2], float(std::sin(0.15)));
  }
  // No room for the pose: the short form, which any reader takes.
  EXPECT_EQ(pose_stamp_to_wire(stamp, buf, 47), kPoseStampSize);
  // What the network may send instead is refused: unknown flags, the pose flag missing, reserved bytes set,
  // a position 2 km away, a quaternion that is not a unit one, a NaN.
  PoseStamp back;
  auto refused = [&](size_t byte, uint8_t value) {
    pose_stamp_to_wire(stamp, buf, kPoseStampWithPoseSize);
    buf[byte] = value;
    return !pose_stamp_from_wire(buf, kPoseStampWithPoseSize, &back);
  };
  EXPECT_TRUE(refused(16, 7));
  EXPECT_TRUE(refused(16, 2));
  EXPECT_TRUE(refused(18, 1));
  EXPECT_TRUE(refused(20, 0x45));  // x = 0x45000000 = 2048 m
  EXPECT_TRUE(refused(32, 0x40));  // w = 0x407D.... (about 4): not a unit quaternion
  EXPECT_TRUE(refused(24, 0x7F));  // y = 0x7FA00000: a NaN
  EXPECT_FALSE(refused(16, 1)) << "the same pose, not clamped, is fine";
  EXPECT_FALSE(back.rendered.clamped);
  EXPECT_FALSE(pose_stamp_from_wire(buf, 47, &back));
  EXPECT_FALSE(pose_stamp_from_wire(buf, 49, &back));
}

TEST(Checksum, Crc32MatchesTheStandardAndTheBytewiseDefinition) {
  const char* check = "123456789";
  EXPECT_EQ(crc32(reinterpret_cast<const uint8_t*>(check), 9), 0xCBF43926u);
  EXPECT_EQ(crc32(nullptr, 0), 0u);
  std::vector<uint8_t> data(64);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 131 + 7);
  auto bytewise = [](const uint8_t* p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
      c ^= p[i];
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    }
    return c ^ 0xFFFFFFFFu;
  };
  for (size_t offset = 0; offset < 8; ++offset)
    for (size_t n = 0; offset + n <= 40; ++n)
      EXPECT_EQ(crc32(data.data() + offset, n), bytewise(data.data() + offset, n)) << offset << "+" << n;
}

TEST(LabelCodec, RoundTrip) {
  cv::Mat l = cv::Mat::zeros(30, 40, CV_8UC1);
  cv::rectangle(l, cv::Rect(3, 4, 10, 20), cv::Scalar(1), cv::FILLED);
  cv::circle(l, cv::Point(30, 15), 6, cv::Scalar(3), cv::FILLED);
  l.at<uint8_t>(29, 39) = 255;
  std::vector<uint8_t> bytes;
  encode_labels(l, &bytes);
  cv::Mat back;
  ASSERT_TRUE(decode_labels(bytes.data(), bytes.size(), 40, 30, &back));
  EXPECT_TRUE(vctest::same_image(back, l));
  EXPECT_FALSE(decode_labels(bytes.data(), bytes.size() / 2, 40, 30, &back));
}

TEST(RgbdFrameCodec, RoundTripAndEveryDamageIsCaught) {
  Classroom room;
  const CameraCalib cam = default_classroom_rig().camera(1);
  RenderOutput clean = render(room, 1.0, cam);
  RgbdCodedFrame f{clean.color, clean.depth, clean.label};
  std::vector<uint8_t> bytes;
  encode_rgbd_frame(f, 90, &bytes);
  RgbdCodedFrame back;
  std::string err;
  ASSERT_TRUE(decode_rgbd_frame(bytes.data(), bytes.size(), 960, 540, &back, &err)) << err;
  EXPECT_TRUE(vctest::same_image(back.depth, f.depth));
  EXPECT_TRUE(vctest::same_image(back.label, f.label));
  EXPECT_GT(psnr(back.color, f.color), 35.0);

  EXPECT_FALSE(decode_rgbd_frame(bytes.data(), bytes.size(), 961, 540, &back, &err));
  for (size_t cut : {size_t(0), size_t(10), bytes.size() / 3, bytes.size() - 1}) {
    EXPECT_FALSE(decode_rgbd_frame(bytes.data(), cut, 960, 540, &back, &err)) << "cut at " << cut;
    EXPECT_FALSE(err.empty());
  }
  // Flip one bit anywhere past the header: the checksum or a sanity check catches it.
  cv::RNG rng(11);
  for (int i = 0; i < 200; ++i) {
    std::vector<uint8_t> bad = bytes;
    const size_t at = 16 + static_cast<size_t>(rng.uniform(0, static_cast<int>(bad.size() - 16)));
    bad[at] ^= static_cast<uint8_t>(1u << rng.uniform(0, 8));
    EXPECT_FALSE(decode_rgbd_frame(bad.data(), bad.size(), 960, 540, &back, &err)) << "bit flip at " << at;
  }
}

namespace {

// Runs `middle` between an rgbdtestsrc and an appsink; returns frames + caps.
struct Played {
  std::vector<RgbdInfo> infos;
  std::vector<cv::Mat> color, depth, label;
  std::vector<GstClockTime> pts;
  vctest::RunResult result;
};

Played play(const std::string& middle, int frames = 3) {
  Played out;
  GError* err = nullptr;
  const std::string desc = "rgbdtestsrc camera-id=2 num-buffers=" + std::to_string(frames) + " ! " + middle +
                           (middle.empty() ? "" : " ! ") + "appsink name=out sync=false";
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  EXPECT_EQ(err, nullptr) << (err ? err->message : "");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    vctest::SampleCollector got(sink);
    out.result = vctest::run_pipeline(p);
    for (size_t i = 0; i < got.size(); ++i) {
      RgbdInfo info;
      std::string e;
      EXPECT_TRUE(rgbd_info_from_caps(got.caps(i), &info, &e)) << e;
      RgbdFrame f;
      EXPECT_TRUE(f.map(got.buffer(i), info, GST_MAP_READ, &e)) << e;
      out.infos.push_back(info);
      out.color.push_back(f.color().clone());
      out.depth.push_back(f.depth().clone());
      out.label.push_back(f.label().clone());
      out.pts.push_back(GST_BUFFER_PTS(got.buffer(i)));
    }
  }
  gst_object_unref(sink);
  gst_object_unref(p);
  return out;
}

void expect_same_stream(const Played& a, const Played& b) {
  ASSERT_EQ(a.result.error, "");
  ASSERT_EQ(b.result.error, "");
  ASSERT_EQ(a.depth.size(), b.depth.size());
  ASSERT_FALSE(a.depth.empty());
  for (size_t i = 0; i < a.depth.size(); ++i) {
    EXPECT_TRUE(vctest::same_image(a.depth[i], b.depth[i])) << "depth of frame " << i;
    EXPECT_TRUE(vctest::same_image(a.label[i], b.label[i])) << "labels of frame " << i;
    EXPECT_GT(psnr(a.color[i], b.color[i]), 35.0) << "colour of frame " << i;
    EXPECT_EQ(a.pts[i], b.pts[i]);
  }
  const CameraCalib &ca = a.infos[0].camera, &cb = b.infos[0].camera;
  EXPECT_EQ(ca.id, cb.id);
  EXPECT_EQ(ca.fx, cb.fx);
  EXPECT_EQ(ca.cx, cb.cx);
  EXPECT_TRUE(ca.cam_to_rig.matrix() == cb.cam_to_rig.matrix());
}

}  // namespace

TEST(RgbdStreamRefusal, BeyondTheLimitsOrNotTheRigsCameraAtItsSizeIsRefusedAndSaysWhy) {
  RgbdStreamLimits limits;
  limits.max_width = 1920;
  limits.max_height = 1080;
  limits.max_pixels = 1920ull * 1080;
  EXPECT_EQ(rgbd_stream_refusal(0, 1920, 1080, limits, nullptr, ""), "");
  EXPECT_NE(rgbd_stream_refusal(0, 1921, 10, limits, nullptr, "").find("beyond max-width 1920"), std::string::npos);
  limits.max_pixels = 1000;
  EXPECT_NE(rgbd_stream_refusal(0, 40, 30, limits, nullptr, "").find("caps declare 40x30"), std::string::npos);
  limits = RgbdStreamLimits();
  const Rig rig = vctest::make_rig(2, 64, 48);
  EXPECT_EQ(rgbd_stream_refusal(1, 64, 48, limits, &rig, "rig.yaml"), "");
  EXPECT_EQ(rgbd_stream_refusal(5, 64, 48, limits, &rig, "rig.yaml"), "camera 5 is not in the rig rig.yaml");
  EXPECT_EQ(rgbd_stream_refusal(1, 32, 24, limits, &rig, "rig.yaml"),
            "caps declare 32x24 but the rig rig.yaml has camera 1 at 64x48");
}

TEST(RgbdEncDec, DepthAndLabelsBitExactThroughTheElements) {
  // The coded stream carries colour, depth and labels: the reference drops depth-gt the same way.
  const Played direct = play("");
  const Played coded = play("rgbdenc quality=90 ! rgbddec");
  expect_same_stream(direct, coded);
  EXPECT_EQ(coded.infos[0].planes, (std::vector<Plane>{Plane::Color, Plane::Depth, Plane::Label}));
}

TEST(RgbdEncDec, CalibrationAndFramesCrossRtp) {
  const Played direct = play("");
  const Played rtp = play("rgbdenc ! rtpgstpay config-interval=1 mtu=1400 ! rtpgstdepay ! rgbddec");
  expect_same_stream(direct, rtp);
}

TEST(RgbdEncDec, DamagedFramesAreDroppedWithAWarning) {
  Classroom room;
  const CameraCalib cam = scale_camera(default_classroom_rig().camera(0), 64, 36);
  RgbdInfo info;
  info.camera = cam;
  RenderOutput clean = render(room, 0.5, cam);
  std::vector<uint8_t> good;
  encode_rgbd_frame({clean.color, clean.depth, cv::Mat()}, 90, &good);

  GError* err = nullptr;
  GstElement* p = gst_parse_launch(
      "appsrc name=src format=time ! rgbddec name=dec stats-interval=2 ! appsink name=out sync=false", &err);
  ASSERT_EQ(err, nullptr);
  GstElement* src = gst_bin_get_by_name(GST_BIN(p), "src");
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  vctest::SampleCollector got(out);
  GstCaps* caps = rgbd_caps_new(info);
  gst_structure_set_name(gst_caps_get_structure(caps, 0), "video/x-rgbd-coded");
  gst_caps_set_simple(caps, "codec", G_TYPE_STRING, "vcrd1", nullptr);
  gst_app_src_set_caps(GST_APP_SRC(src), caps);
  std::vector<std::vector<uint8_t>> frames = {good, good, good, good};
  frames[1].resize(frames[1].size() / 2);         // truncated
  frames[2][frames[2].size() / 2] ^= 0x5A;        // damaged in the middle
  for (size_t i = 0; i < frames.size(); ++i) {
    GstBuffer* b = gst_buffer_new_allocate(nullptr, frames[i].size(), nullptr);
    gst_buffer_fill(b, 0, frames[i].data(), frames[i].size());
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(0)), 0u);
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(1)), 3 * GST_SECOND / 30);
  // Rate-limited: the first damaged frame at once, the second within 5 s only counted.
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("truncated"), std::string::npos) << r.warnings[0];
  EXPECT_NE(r.warnings[0].find("a damaged frame from camera 0"), std::string::npos) << r.warnings[0];
  // What was lost is counted, on the properties and every 2 frames on the bus.
  GstElement* dec = gst_bin_get_by_name(GST_BIN(p), "dec");
  guint64 decoded = 0, dropped = 0, bytes = 0;
  g_object_get(dec, "frames", &decoded, "frames-dropped", &dropped, "bytes", &bytes, nullptr);
  EXPECT_EQ(decoded, 2u);
  EXPECT_EQ(dropped, 2u);
  EXPECT_EQ(bytes, 2 * good.size());
  gst_object_unref(dec);
  std::vector<std::pair<guint64, guint64>> posted;
  for (const std::string& m : r.element_messages) {
    GstStructure* st = gst_structure_from_string(m.c_str(), nullptr);
    ASSERT_NE(st, nullptr) << m;
    if (gst_structure_has_name(st, "vclassroom-codec-stats")) {
      guint64 f = 0, d = 0;
      EXPECT_TRUE(gst_structure_get_uint64(st, "frames", &f) && gst_structure_get_uint64(st, "frames-dropped", &d)) << m;
      posted.emplace_back(f, d);
    }
    gst_structure_free(st);
  }
  // After frames 2 (one good, one truncated) and 4 (the damaged one, then a good one), and at the end.
  EXPECT_EQ(posted, (std::vector<std::pair<guint64, guint64>>{{1, 1}, {2, 2}, {2, 2}}));
  gst_caps_unref(caps);
  gst_object_unref(src);
  gst_object_unref(out);
  gst_object_unref(p);
}

// Garbage on a camera's port (a flood of damaged frames) gives one warning for
// a person, not one per frame; every frame is counted in the stats, by kind.
TEST(RgbdEncDec, AHundredGarbageFramesPostOneWarningAndAreAllCounted) {
  RgbdInfo info;
  info.camera = scale_camera(default_classroom_rig().camera(2), 64, 36);
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(
      "appsrc name=src format=time ! rgbddec name=dec stats-interval=1000 ! appsink name=out sync=false", &err);
  ASSERT_EQ(err, nullptr);
  GstElement* src = gst_bin_get_by_name(GST_BIN(p), "src");
  GstCaps* caps = rgbd_caps_new(info);
  gst_structure_set_name(gst_caps_get_structure(caps, 0), "video/x-rgbd-coded");
  gst_caps_set_simple(caps, "codec", G_TYPE_STRING, "vcrd1", nullptr);
  gst_app_src_set_caps(GST_APP_SRC(src), caps);
  gst_caps_unref(caps);
  uint32_t seed = 17;  // a seeded LCG (no new includes in this shared file)
  auto rng = [&seed] { return seed = seed * 1664525u + 1013904223u, seed >> 8; };
  for (int i = 0; i < 100; ++i) {
    std::vector<uint8_t> junk(200 + rng() % 2000);
    for (auto& b : junk) b = uint8_t(rng());
    if (i % 2) junk[0] = 'V', junk[1] = 'C', junk[2] = 'R', junk[3] = 'D';  // half look like frames at first sight
    GstBuffer* b = gst_buffer_new_memdup(junk.data(), junk.size());
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(r.warnings.size(), 1u) << "one warning, then one per 5 s with the count";
  EXPECT_NE(r.warnings[0].find("dropped a damaged frame from camera 2"), std::string::npos) << r.warnings[0];
  guint64 dropped = 0, damaged = 0;
  for (const std::string& m : r.element_messages) {
    GstStructure* st = gst_structure_from_string(m.c_str(), nullptr);
    if (st && gst_structure_has_name(st, "vclassroom-codec-stats")) {
      gst_structure_get_uint64(st, "frames-dropped", &dropped);
      EXPECT_TRUE(gst_structure_get_uint64(st, "dropped-damaged", &damaged)) << m;
    }
    if (st) gst_structure_free(st);
  }
  EXPECT_EQ(dropped, 100u);
  EXPECT_EQ(damaged, 100u);
  gst_object_unref(src);
  gst_object_unref(p);
}
