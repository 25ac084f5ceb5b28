// The H.264 camera link (docs/network.md, "The H.264 camera link"): the depth coder with its error bound,
// the SEI that carries it in the colour's access units, and the elements through GStreamer.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include <gst/rtp/gstrtcpbuffer.h>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/image_io.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/colour_i420.h>
#include <gst/vclassroom/net/depth_link.h>
#include <gst/vclassroom/net/depth_link_backlog.h>
#include <gst/vclassroom/net/h264_sei.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/synthetic/synthetic_camera.h>

#include "test_util.h"

using namespace vclassroom;
using namespace vctest;

namespace {

// Frames `n` of the synthetic classroom's camera 0 at w x h, sensor model on.
std::vector<SyntheticCamera::Planes> classroom_frames(int n, int w = 320, int h = 180) {
  const CameraCalib cam = scale_camera(default_classroom_rig().cameras[0], w, h);
  SyntheticCamera camera;
  camera.configure(SyntheticCameraConfig());
  std::vector<SyntheticCamera::Planes> out;
  for (int i = 0; i < n; ++i) {
    SyntheticCamera::Planes p = camera.frame(cam, i / 30.0, uint64_t(i));
    out.push_back({p.color.clone(), p.depth.clone(), p.label.clone(), p.depth_gt.clone()});
  }
  return out;
}

// The number of pixels whose decoded depth breaks the bound (a measurement lost or invented counts too).
int bound_violations(const cv::Mat& truth, const cv::Mat& coded, uint16_t tolerance) {
  int bad = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      const uint16_t z = truth.at<uint16_t>(y, x), c = coded.at<uint16_t>(y, x);
      if ((z == 0) != (c == 0) || std::abs(int(z) - int(c)) > depth_error_bound(z, tolerance)) ++bad;
    }
  return bad;
}

// Codes and decodes a sequence, checks the bound at every pixel of every frame; returns the bytes sent.
size_t round_trip_within_bound(const std::vector<cv::Mat>& depths, const std::vector<cv::Mat>& labels,
                               uint16_t tolerance, int key_interval) {
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  size_t bytes = 0;
  for (size_t i = 0; i < depths.size(); ++i) {
    std::vector<uint8_t> wire;
    const cv::Mat label = labels.empty() ? cv::Mat() : labels[i];
    enc.encode(depths[i], label, "video/x-rgbd", i % size_t(key_interval) == 0, tolerance, &wire);
    bytes += wire.size();
    DepthLinkFrame f;
    std::string err;
    EXPECT_TRUE(dec.decode(wire.data(), wire.size(), &f, &err)) << err;
    EXPECT_EQ(bound_violations(depths[i], f.depth, tolerance), 0) << "frame " << i;
    EXPECT_TRUE(same_image(f.depth, enc.reconstructed()));
    if (!label.empty()) {
      EXPECT_TRUE(same_image(f.label, label));
    }
    EXPECT_EQ(f.caps, "video/x-rgbd");
  }
  return bytes;
}

}  // namespace

TEST(DepthLink, TheBoundGrowsWithTheSquareOfDepth) {
  EXPECT_EQ(depth_error_bound(1000, 280), 2);   // 2.8 mm at 1 m, floored
  EXPECT_EQ(depth_error_bound(2000, 280), 11);  // 11.2 at 2 m
  EXPECT_EQ(depth_error_bound(5000, 280), 70);
  EXPECT_EQ(depth_error_bound(500, 280), 0);    // lossless under 0.6 m
  EXPECT_EQ(depth_error_bound(65535, 0), 0);
  EXPECT_EQ(depth_error_bound(65535, 65535), 65535);
}

TEST(DepthLink, SyntheticClassroomStaysWithinTheBoundAndCostsFarLessThanLossless) {
  auto frames = classroom_frames(12);
  std::vector<cv::Mat> depths, labels;
  for (auto& f : frames) {
    depths.push_back(f.depth);
    labels.push_back(f.label);
  }
  const size_t near = round_trip_within_bound(depths, labels, kDefaultDepthTolerance, 6);
  const size_t lossless = round_trip_within_bound(depths, labels, 0, 6);
  EXPECT_LT(near * 5, lossless * 2) << near << " vs " << lossless;  // under 40 %
}

TEST(DepthLink, LosslessModeIsBitExact) {
  auto frames = classroom_frames(4);
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  for (size_t i = 0; i < frames.size(); ++i) {
    std::vector<uint8_t> wire;
    enc.encode(frames[i].depth, cv::Mat(), "c", i == 0, 0, &wire);
    DepthLinkFrame f;
    std::string err;
    ASSERT_TRUE(dec.decode(wire.data(), wire.size(), &f, &err)) << err;
    EXPECT_TRUE(same_image(f.depth, frames[i].depth));
    EXPECT_TRUE(f.label.empty());
  }
}

TEST(DepthLink, RedwoodSequenceStaysWithinTheBound) {
  const std::string dir = shared_path("rgbd-sensor-samples/redwood_livingroom1_synthetic/depth");
  if (dir.empty() || !g_file_test(dir.c_str(), G_FILE_TEST_IS_DIR)) GTEST_SKIP() << "no shared data (../shared/data)";
  std::vector<cv::Mat> depths;
  for (int i = 0; i < 5; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/%05d.png", i);
    depths.push_back(read_depth_mm(dir + name, 1.0));
  }
  const size_t near = round_trip_within_bound(depths, {}, kDefaultDepthTolerance, 3);
  const size_t lossless = round_trip_within_bound(depths, {}, 0, 3);
  EXPECT_LT(near, lossless);
}

TEST(DepthLink, ADeltaFrameWithoutItsPredecessorWaitsForTheNextKeyFrame) {
  auto frames = classroom_frames(4, 64, 36);
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  std::vector<std::vector<uint8_t>> wire(4);
  // A still scene, so that frames 1 and 2 are delta frames (where more than half of the measured pixels change,
  // as between these small frames of the moving classroom, the encoder sends key frames instead).
  for (int i = 0; i < 4; ++i) enc.encode(frames[i == 3 ? 3 : 0].depth, frames[0].label, "c", i == 3, 280, &wire[i]);
  DepthLinkFrame f;
  std::string err;
  ASSERT_TRUE(dec.decode(wire[0].data(), wire[0].size(), &f, &err)) << err;
  EXPECT_TRUE(f.key);
  EXPECT_FALSE(dec.decode(wire[2].data(), wire[2].size(), &f, &err));  // frame 1 lost
  EXPECT_NE(err.find("without the frame before it"), std::string::npos) << err;
  ASSERT_TRUE(dec.decode(wire[3].data(), wire[3].size(), &f, &err)) << err;
  EXPECT_TRUE(f.key);
  EXPECT_EQ(f.number, 3u);
}

namespace {

// `n` coded frames of a still scene in which a block of nearer depth moves (so most are delta frames), a key
// frame where `key(i)`; `direct` gets each frame as a decoder fed every frame in order makes it.
std::vector<std::vector<uint8_t>> moving_block_frames(int n, bool (*key)(int), std::vector<cv::Mat>* direct) {
  const auto still = classroom_frames(1, 96, 54);
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  std::vector<std::vector<uint8_t>> wire(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    cv::Mat depth = still[0].depth.clone();
    depth(cv::Rect(4 + 3 * i, 10, 8, 8)).setTo(900);
    enc.encode(depth, still[0].label, "c", key(i), 280, &wire[size_t(i)]);
    DepthLinkFrame f;
    std::string err;
    EXPECT_TRUE(dec.decode(wire[size_t(i)].data(), wire[size_t(i)].size(), &f, &err)) << err;
    direct->push_back(f.depth);
  }
  return wire;
}

bool first_only(int i) { return i == 0; }

}  // namespace

// The server decodes a camera's depth only when a picture is taken (rgbdlinkjoin behind a leaky queue): the
// frames in between are decoded on the way, so each picture gets exactly the depth that came with it.
TEST(DepthLinkBacklog, APictureGetsItsOwnDepthThoughThePicturesBeforeItWereDropped) {
  std::vector<cv::Mat> direct;
  const auto wire = moving_block_frames(12, first_only, &direct);
  DepthLinkBacklog backlog;
  int deltas = 0;
  for (size_t i = 0; i < wire.size(); ++i) {
    DepthLinkHeader h;
    uint64_t id = 0;
    std::string err;
    ASSERT_TRUE(backlog.push(wire[i].data(), wire[i].size(), &h, &id, &err)) << err;
    EXPECT_EQ(h.number, uint32_t(i));
    EXPECT_EQ(id, uint64_t(i));
    deltas += h.key ? 0 : 1;
    if (i % 4 != 3) continue;  // three pictures of four dropped before the join
    DepthLinkFrame f;
    ASSERT_TRUE(backlog.take(id, &f, &err)) << err;
    EXPECT_EQ(f.number, uint32_t(i));
    EXPECT_TRUE(same_image(f.depth, direct[i])) << "frame " << i;
    EXPECT_EQ(backlog.queued(), 0u);  // the frames before it went with it
  }
  EXPECT_EQ(deltas, 11);
  DepthLinkFrame f;
  std::string err;
  EXPECT_FALSE(backlog.take(5, &f, &err));  // already gone
  EXPECT_NE(err.find("not queued"), std::string::npos) << err;
}

TEST(DepthLinkBacklog, AFrameThatBreaksTheChainIsRefusedAndSoAreItsSuccessorsUntilAKeyFrame) {
  std::vector<cv::Mat> direct;
  const auto wire = moving_block_frames(6, [](int i) { return i == 0 || i == 4; }, &direct);
  DepthLinkBacklog backlog;
  DepthLinkHeader h;
  uint64_t id = 0;
  std::string err;
  ASSERT_TRUE(backlog.push(wire[0].data(), wire[0].size(), &h, &id, &err)) << err;
  EXPECT_FALSE(backlog.push(wire[2].data(), wire[2].size(), &h, &id, &err));  // frame 1 lost
  EXPECT_NE(err.find("without the frame before it"), std::string::npos) << err;
  EXPECT_FALSE(backlog.push(wire[3].data(), wire[3].size(), &h, &id, &err));
  std::vector<uint8_t> damaged = wire[4];
  damaged[damaged.size() / 2] ^= 1;
  EXPECT_FALSE(backlog.push(damaged.data(), damaged.size(), &h, &id, &err));
  EXPECT_NE(err.find("checksum"), std::string::npos) << err;
  ASSERT_TRUE(backlog.push(wire[4].data(), wire[4].size(), &h, &id, &err)) << err;
  ASSERT_TRUE(backlog.push(wire[5].data(), wire[5].size(), &h, &id, &err)) << err;
  EXPECT_EQ(id, 2u);  // the third frame queued
  DepthLinkFrame f;
  ASSERT_TRUE(backlog.take(id, &f, &err)) << err;  // from key frame 4; frame 0 is never decoded
  EXPECT_TRUE(same_image(f.depth, direct[5]));
}

// Its limits keep a starved taker from holding every frame a camera sends: the oldest go, and what builds on
// them waits for the next key frame instead of decoding wrong.
TEST(DepthLinkBacklog, ItsLimitsDropTheOldestFramesAndWhatBuildsOnThemWaitsForAKeyFrame) {
  std::vector<cv::Mat> direct;
  const auto wire = moving_block_frames(9, [](int i) { return i == 0 || i == 7; }, &direct);
  DepthLinkBacklogLimits limits;
  limits.max_frames = 3;
  DepthLinkBacklog backlog(DepthLinkLimits(), limits);
  DepthLinkHeader h;
  uint64_t id = 0;
  std::string err;
  DepthLinkFrame f;
  ASSERT_TRUE(backlog.push(wire[0].data(), wire[0].size(), &h, &id, &err)) << err;
  ASSERT_TRUE(backlog.take(id, &f, &err)) << err;
  for (size_t i = 1; i < 7; ++i) ASSERT_TRUE(backlog.push(wire[i].data(), wire[i].size(), &h, &id, &err)) << err;
  EXPECT_EQ(backlog.queued(), 3u);  // 4, 5, 6: frames 1 to 3 went
  EXPECT_FALSE(backlog.take(id, &f, &err));
  EXPECT_NE(err.find("without the frame before it"), std::string::npos) << err;
  for (size_t i = 7; i < 9; ++i) ASSERT_TRUE(backlog.push(wire[i].data(), wire[i].size(), &h, &id, &err)) << err;
  ASSERT_TRUE(backlog.take(id, &f, &err)) << err;
  EXPECT_TRUE(same_image(f.depth, direct[8]));
  limits.max_bytes = wire[8].size() - 1;
  DepthLinkBacklog small(DepthLinkLimits(), limits);
  EXPECT_FALSE(small.push(wire[0].data(), wire[0].size(), &h, &id, &err));
  EXPECT_NE(err.find("larger than the backlog"), std::string::npos) << err;
}

// A camera that restarts numbers its frames from 0 again while frames of its last run are still queued: a
// picture gets the frame it came with, never an older one of the same number.
TEST(DepthLinkBacklog, ACameraThatRestartsNeverGetsItsLastRunsFrameOfTheSameNumber) {
  std::vector<cv::Mat> first;
  const auto before = moving_block_frames(4, first_only, &first);
  DepthLinkEncoder restarted;  // the new run: a block elsewhere, its frames numbered 0 and 1 again
  std::vector<std::vector<uint8_t>> again(2);
  const auto still = classroom_frames(1, 96, 54);
  for (int i = 0; i < 2; ++i) {
    cv::Mat depth = still[0].depth.clone();
    depth(cv::Rect(40 + 5 * i, 20, 8, 8)).setTo(1500);
    restarted.encode(depth, still[0].label, "c", i == 0, 280, &again[size_t(i)]);
  }
  DepthLinkDecoder direct;
  DepthLinkFrame expected, f;
  std::string err;
  ASSERT_TRUE(direct.decode(again[0].data(), again[0].size(), &expected, &err)) << err;
  ASSERT_TRUE(direct.decode(again[1].data(), again[1].size(), &expected, &err)) << err;
  DepthLinkBacklog backlog;
  DepthLinkHeader h;
  uint64_t id = 0;
  for (const auto& frame : before) ASSERT_TRUE(backlog.push(frame.data(), frame.size(), &h, &id, &err)) << err;
  for (const auto& frame : again) ASSERT_TRUE(backlog.push(frame.data(), frame.size(), &h, &id, &err)) << err;
  EXPECT_EQ(h.number, 1u);  // as the last run's second frame
  ASSERT_TRUE(backlog.take(id, &f, &err)) << err;
  EXPECT_TRUE(same_image(f.depth, expected.depth));
  EXPECT_FALSE(same_image(f.depth, first[1]));
}

TEST(DepthLink, EveryDamageIsRefusedWithAReason) {
  auto frames = classroom_frames(1, 64, 36);
  DepthLinkEncoder enc;
  std::vector<uint8_t> wire;
  enc.encode(frames[0].depth, frames[0].label, "video/x-rgbd", true, 280, &wire);
  // Every truncation and every single flipped byte is refused (checksum or a field), never crashes.
  for (size_t n = 0; n < wire.size(); n += 7) {
    DepthLinkDecoder dec;
    DepthLinkFrame f;
    std::string err;
    EXPECT_FALSE(dec.decode(wire.data(), n, &f, &err));
    EXPECT_FALSE(err.empty());
  }
  for (size_t i = 0; i < wire.size(); ++i) {
    std::vector<uint8_t> bad = wire;
    bad[i] ^= 0x41;
    DepthLinkDecoder dec;
    DepthLinkFrame f;
    std::string err;
    EXPECT_FALSE(dec.decode(bad.data(), bad.size(), &f, &err)) << "byte " << i;
  }
  // An oversized declaration is refused before anything is allocated for it.
  std::vector<uint8_t> big = wire;
  big[8] = 0xff; big[9] = 0xff; big[10] = 0xff; big[11] = 0xff;
  DepthLinkDecoder dec;
  DepthLinkFrame f;
  std::string err;
  EXPECT_FALSE(dec.decode(big.data(), big.size(), &f, &err));
  EXPECT_NE(err.find("beyond the limits"), std::string::npos) << err;
}

// rgbdlinksplit's and rgbdlinkjoin's own conversions: grey stays grey at BT.601's levels, a smooth image comes
// back within a few levels, and odd sizes are converted whole (the sanitizer build checks the edges).
TEST(ColourI420, RgbComesBackFromI420AndOddSizesAreWhole) {
  for (const cv::Size size : {cv::Size(64, 48), cv::Size(7, 5), cv::Size(1, 1)}) {
    const int w = size.width, h = size.height, cw = (w + 1) / 2, ch = (h + 1) / 2;
    cv::Mat rgb(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(uint8_t(40 + 2 * x), uint8_t(90 + y), 150);
    cv::Mat luma(h, w, CV_8UC1, cv::Scalar(0)), cb(ch, cw, CV_8UC1, cv::Scalar(0)), cr(ch, cw, CV_8UC1, cv::Scalar(0));
    rgb_to_i420(rgb.data, int(rgb.step), w, h, luma.data, int(luma.step), cb.data, int(cb.step), cr.data,
                int(cr.step));
    cv::Mat back(h, w, CV_8UC3, cv::Scalar(0, 0, 0));
    i420_to_rgb(luma.data, int(luma.step), cb.data, int(cb.step), cr.data, int(cr.step), w, h, back.data,
                int(back.step));
    cv::Mat diff;
    cv::absdiff(rgb, back, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, 3) << w << "x" << h;
  }
  cv::Mat grey(2, 2, CV_8UC3, cv::Scalar(255, 255, 255)), l(2, 2, CV_8UC1), u(1, 1, CV_8UC1), v(1, 1, CV_8UC1);
  rgb_to_i420(grey.data, int(grey.step), 2, 2, l.data, int(l.step), u.data, 1, v.data, 1);
  EXPECT_EQ(l.at<uint8_t>(0, 0), 235);
  EXPECT_EQ(u.at<uint8_t>(0, 0), 128);
  EXPECT_EQ(v.at<uint8_t>(0, 0), 128);
}

TEST(DepthLink, ADepthThatStaysWithinTheBoundCostsLittleAcrossTime) {
  // The same scene again with fresh sensor noise (frame 0's instant, noise of frames 1..7): the delta frames
  // keep most pixels from the frame before and cost clearly less than the key frame (the sensor's holes,
  // drawn anew in every frame, are most of what is left).
  Rig rig = default_classroom_rig();
  CameraCalib cam = scale_camera(rig.cameras[0], 320, 180);
  SyntheticCamera camera;
  camera.configure(SyntheticCameraConfig());
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  std::vector<size_t> bytes;
  for (int i = 0; i < 8; ++i) {
    const cv::Mat depth = camera.frame(cam, 0.0, uint64_t(i)).depth.clone();
    std::vector<uint8_t> wire;
    enc.encode(depth, cv::Mat(), "c", i == 0, kDefaultDepthTolerance, &wire);
    DepthLinkFrame f;
    std::string err;
    ASSERT_TRUE(dec.decode(wire.data(), wire.size(), &f, &err)) << err;
    EXPECT_EQ(bound_violations(depth, f.depth, kDefaultDepthTolerance), 0);
    bytes.push_back(wire.size());
  }
  // (Frame 1 re-sends the pixels whose key-frame bin centre lay near the bound; then the values settle near
  // the encoder's estimate of the truth.)
  for (int i = 4; i < 8; ++i) EXPECT_LT(bytes[size_t(i)] * 20, bytes[0] * 17) << "frame " << i << ": " << bytes[size_t(i)];
}

TEST(DepthLink, ASectionTooShortForItsDeclaredImageIsRefusedBeforeAllocating) {
  DepthLinkEncoder enc;
  std::vector<uint8_t> wire;
  enc.encode(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1500)), cv::Mat(), "", true, 280, &wire);
  // Declared 2000 x 2000 (within the limits): its section would need at least 3906 bytes.
  wire[8] = 0xd0; wire[9] = 0x07; wire[10] = 0xd0; wire[11] = 0x07;
  DepthLinkDecoder dec;
  DepthLinkFrame f;
  std::string err;
  EXPECT_FALSE(dec.decode(wire.data(), wire.size(), &f, &err));
  EXPECT_NE(err.find("too short for its image"), std::string::npos) << err;
  // Nothing of the declared size was made: the frame's images are still empty.
  EXPECT_TRUE(f.depth.empty());
  EXPECT_TRUE(f.label.empty());
}

TEST(DepthLink, WrongInputIsTheProjectsError) {
  DepthLinkEncoder enc;
  std::vector<uint8_t> out;
  EXPECT_THROW(enc.encode(cv::Mat(4, 4, CV_8UC1), cv::Mat(), "", true, 0, &out), Error);
  EXPECT_THROW(enc.encode(cv::Mat(4, 4, CV_16UC1), cv::Mat(3, 4, CV_8UC1), "", true, 0, &out), Error);
}

TEST(H264Sei, UserDataRoundTripsThroughEmulationPrevention) {
  // SPS, PPS, IDR slice (contents are placeholders: only the NAL structure matters here).
  const std::vector<uint8_t> au = {0, 0, 0, 1, 0x67, 0x42, 0, 0x1e, 0, 0, 0, 1, 0x68, 0xce, 0x3c, 0x80,
                                   0, 0, 1, 0x65, 0x88, 0x84, 0x21, 0xa0};
  std::vector<uint8_t> data = {0, 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0xff, 0, 0};
  data.resize(700, 0);  // a payload size that needs 0xff extension bytes
  std::vector<uint8_t> out;
  h264_insert_user_data(au.data(), au.size(), kDepthLinkSeiUuid, data.data(), data.size(), &out);
  EXPECT_TRUE(h264_is_idr(out.data(), out.size()));
  // The original units are still there, after the SEI.
  EXPECT_TRUE(std::equal(au.end() - 9, au.end(), out.end() - 9));
  for (size_t i = 0; i + 2 < out.size() - 9; ++i)  // no start code emulated inside the SEI
    if (i > 20 && out[i] == 0 && out[i + 1] == 0) {
      EXPECT_GE(out[i + 2], 3) << i;
    }
  std::vector<uint8_t> back;
  std::string err;
  ASSERT_EQ(h264_find_user_data(out.data(), out.size(), kDepthLinkSeiUuid, 1 << 20, &back, &err), SeiFind::kFound);
  EXPECT_EQ(back, data);
  EXPECT_EQ(h264_find_user_data(au.data(), au.size(), kDepthLinkSeiUuid, 1 << 20, &back, &err), SeiFind::kAbsent);
  EXPECT_EQ(h264_find_user_data(out.data(), out.size(), kDepthLinkSeiUuid, 100, &back, &err), SeiFind::kMalformed);
  // Cut inside the SEI: malformed, never read past the end.
  for (size_t n = 30; n < 200; n += 13) {
    SeiFind r = h264_find_user_data(out.data(), n, kDepthLinkSeiUuid, 1 << 20, &back, &err);
    EXPECT_NE(r, SeiFind::kFound) << n;
  }
  EXPECT_THROW(h264_insert_user_data(au.data(), 16, kDepthLinkSeiUuid, data.data(), 4, &out), Error);
}


// --- Through GStreamer -----------------------------------------------------------------------------------

namespace {

// The camera's side and the server's of the link, without the network.
std::string link_chain(int key_int) {
  return "rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast "
         "key-int-max=" + std::to_string(key_int) + " ! video/x-h264,profile=constrained-baseline ! "
         "rgbdlinkmux name=mux ! rtph264pay mtu=1400 ! rtph264depay ! rgbdlinkdemux name=demux ! openh264dec ! "
         "videoconvert ! rgbdlinkjoin name=join";
}

GstElement* launch(const std::string& desc) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  EXPECT_EQ(err, nullptr) << (err ? err->message : "");
  if (err) g_error_free(err);
  return p;
}

guint64 uint64_property(GstElement* bin, const char* element, const char* property) {
  GstElement* e = gst_bin_get_by_name(GST_BIN(bin), element);
  guint64 v = 0;
  g_object_get(e, property, &v, nullptr);
  gst_object_unref(e);
  return v;
}

// `frames` camera frames of `rig` (rgbdtestsrc, `extra` its further properties) both as they are, to the appsink
// "truth", and through `chain`, to the appsink "out".
GstElement* launch_beside_truth(const std::string& rig, int frames, const std::string& chain,
                                const std::string& extra = "") {
  return launch("rgbdtestsrc rig=" + rig + " num-buffers=" + std::to_string(frames) + extra +
                " ! tee name=t t. ! queue ! appsink name=truth sync=false t. ! queue ! " + chain +
                " ! appsink name=out sync=false");
}

// Maps frame `i` of `out` and frame `t` of `truth`, each with its own caps; false (and a failure added) when
// either cannot be.
bool map_pair(const SampleCollector& out, size_t i, const SampleCollector& truth, size_t t, RgbdFrame* o,
              RgbdFrame* tf) {
  RgbdInfo oi, ti;
  std::string err;
  const bool ok = rgbd_info_from_caps(out.caps(i), &oi, &err) && rgbd_info_from_caps(truth.caps(t), &ti, &err) &&
                  o->map(out.buffer(i), oi, GST_MAP_READ, &err) && tf->map(truth.buffer(t), ti, GST_MAP_READ, &err);
  if (!ok) ADD_FAILURE() << "frames " << i << " / " << t << ": " << err;
  return ok;
}

}  // namespace

// A decoder whose pictures change size while the depth keeps its caps (a new SPS, or a scaler between them):
// each such picture is dropped, never read at the depth's size past its planes (the sanitizer build would see
// that read).
TEST(CameraLink, APictureThatChangesSizeUnderTheSameDepthIsDroppedNotRead) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 320, 180);
  GstElement* p = launch("rgbdtestsrc rig=" + rig + " num-buffers=20 ground-truth=false ! rgbdlinksplit ! "
                         "videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast "
                         "key-int-max=30 ! video/x-h264,profile=constrained-baseline ! rgbdlinkmux ! rgbdlinkdemux ! "
                         "avdec_h264 max-threads=1 ! videoscale ! capsfilter name=size "
                         "caps=video/x-raw,width=320,height=180 ! rgbdlinkjoin name=join ! "
                         "appsink name=out sync=false");
  GstElement* size = gst_bin_get_by_name(GST_BIN(p), "size");
  GstElement* join = gst_bin_get_by_name(GST_BIN(p), "join");
  GstPad* pad = gst_element_get_static_pad(join, "sink");
  // After the 8th picture the scaler makes them smaller; the depth's caps stay as they were.
  static int pictures;
  pictures = 0;
  gst_pad_add_probe(
      pad, GST_PAD_PROBE_TYPE_BUFFER,
      [](GstPad*, GstPadProbeInfo*, gpointer filter) {
        if (++pictures == 8) {
          GstCaps* smaller = gst_caps_from_string("video/x-raw,width=160,height=90");
          g_object_set(filter, "caps", smaller, nullptr);
          gst_caps_unref(smaller);
        }
        return GST_PAD_PROBE_OK;
      },
      size, nullptr);
  GstElement* out_sink = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    SampleCollector out(out_sink);
    RunResult r = run_pipeline(p);
    EXPECT_EQ(r.error, "");
    EXPECT_GE(pictures, 12);  // the pictures after the change reached the join
    EXPECT_EQ(uint64_property(p, "join", "frames"), out.size());
    EXPECT_GE(out.size(), 7u);
    EXPECT_LE(out.size(), 10u);  // the first pictures, of the depth's size; none after the change
    EXPECT_GE(uint64_property(p, "join", "frames-dropped"), 10u);
  }
  gst_object_unref(pad);
  gst_object_unref(join);
  gst_object_unref(size);
  gst_object_unref(out_sink);
  gst_object_unref(p);
}

TEST(CameraLink, EveryFrameArrivesWithItsOwnDepthWithinTheBoundAndItsLabels) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 320, 180);
  GstElement* p = launch_beside_truth(rig, 40, link_chain(15), " ground-truth=true");
  GstElement* truth_sink = gst_bin_get_by_name(GST_BIN(p), "truth");
  GstElement* out_sink = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    SampleCollector truth(truth_sink), out(out_sink);
    RunResult r = run_pipeline(p);
    EXPECT_EQ(r.error, "");
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
    ASSERT_EQ(out.size(), 40u);
    ASSERT_EQ(truth.size(), 40u);
    for (size_t i = 0; i < out.size(); ++i) {
      RgbdInfo oi, ti;
      std::string err;
      ASSERT_TRUE(rgbd_info_from_caps(out.caps(i), &oi, &err)) << err;
      ASSERT_TRUE(rgbd_info_from_caps(truth.caps(i), &ti, &err)) << err;
      EXPECT_EQ(oi.camera.fx, ti.camera.fx);  // the calibration crossed
      // The same instant (x264enc moves every timestamp by the same offset).
      ASSERT_EQ(GST_BUFFER_PTS(out.buffer(i)) - GST_BUFFER_PTS(out.buffer(0)),
                GST_BUFFER_PTS(truth.buffer(i)) - GST_BUFFER_PTS(truth.buffer(0)));
      RgbdFrame o, t;
      ASSERT_TRUE(o.map(out.buffer(i), oi, GST_MAP_READ, &err)) << err;
      ASSERT_TRUE(t.map(truth.buffer(i), ti, GST_MAP_READ, &err)) << err;
      EXPECT_EQ(bound_violations(t.depth(), o.depth(), kDefaultDepthTolerance), 0) << "frame " << i;
      EXPECT_TRUE(same_image(t.label(), o.label())) << "frame " << i;
      EXPECT_GT(cv::PSNR(t.color(), o.color()), 30.0) << "frame " << i;
    }
  }
  EXPECT_EQ(uint64_property(p, "join", "frames"), 40u);
  gst_object_unref(truth_sink);
  gst_object_unref(out_sink);
  gst_object_unref(p);
}

// As pipelines/server.sh runs the link: a leaky queue before rgbdlinkjoin drops most pictures, and the join
// decodes their depth frames only on the way to the next picture it takes. Each joined frame still has its
// own instant's depth (within the bound) and labels.
TEST(CameraLink, PicturesDroppedBeforeTheJoinLeaveTheOthersTheirOwnDepth) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 320, 180);
  std::string chain = link_chain(30);
  chain.replace(chain.find("rgbdlinkjoin"), 0, "identity name=gate ! ");
  GstElement* p = launch_beside_truth(rig, 40, chain, " ground-truth=true");
  GstElement* gate = gst_bin_get_by_name(GST_BIN(p), "gate");
  GstPad* gate_src = gst_element_get_static_pad(gate, "src");
  guint seen = 0;
  gst_pad_add_probe(gate_src, GST_PAD_PROBE_TYPE_BUFFER,
                    [](GstPad*, GstPadProbeInfo*, gpointer n) -> GstPadProbeReturn {
                      return (*static_cast<guint*>(n))++ % 3 == 0 ? GST_PAD_PROBE_OK : GST_PAD_PROBE_DROP;
                    },
                    &seen, nullptr);
  GstElement* truth_sink = gst_bin_get_by_name(GST_BIN(p), "truth");
  GstElement* out_sink = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    SampleCollector truth(truth_sink), out(out_sink);
    RunResult r = run_pipeline(p);
    EXPECT_EQ(r.error, "");
    ASSERT_EQ(truth.size(), 40u);
    ASSERT_EQ(out.size(), 14u);  // pictures 0, 3, ..., 39
    for (size_t i = 0; i < out.size(); ++i) {
      const size_t t_index = 3 * i;
      ASSERT_EQ(GST_BUFFER_PTS(out.buffer(i)) - GST_BUFFER_PTS(out.buffer(0)),
                GST_BUFFER_PTS(truth.buffer(t_index)) - GST_BUFFER_PTS(truth.buffer(0)));
      RgbdFrame o, t;
      ASSERT_TRUE(map_pair(out, i, truth, t_index, &o, &t));
      EXPECT_EQ(bound_violations(t.depth(), o.depth(), kDefaultDepthTolerance), 0) << "frame " << t_index;
      EXPECT_TRUE(same_image(t.label(), o.label())) << "frame " << t_index;
    }
  }
  EXPECT_EQ(seen, 40u);
  EXPECT_EQ(uint64_property(p, "join", "frames"), 14u);
  EXPECT_EQ(uint64_property(p, "demux", "frames"), 40u);  // every depth frame came whole and was queued
  gst_object_unref(gate_src);
  gst_object_unref(gate);
  gst_object_unref(truth_sink);
  gst_object_unref(out_sink);
  gst_object_unref(p);
}

// A server given its rig (server.sh passes RIG or the model's to rgbdlinkdemux as to rgbddec) refuses a
// camera the rig has at another size, with the reason, before anything is decoded; a rig it cannot read stops
// the pipeline with an error.
TEST(CameraLink, TheDemuxRefusesACameraTheRigHasAtAnotherSize) {
  TempDir dir, other;
  const std::string rig = small_classroom_rig(dir, 160, 90);
  const std::string server_rig = small_classroom_rig(other, 320, 180);
  std::string chain = link_chain(10);
  chain.replace(chain.find("rgbdlinkdemux name=demux"), std::string("rgbdlinkdemux name=demux").size(),
                "rgbdlinkdemux name=demux rig=" + server_rig);
  GstElement* p = launch("rgbdtestsrc rig=" + rig + " num-buffers=10 ! " + chain + " ! fakesink");
  RunResult r = run_pipeline(p);
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(uint64_property(p, "join", "frames"), 0u);
  EXPECT_EQ(uint64_property(p, "demux", "frames-dropped"), 10u);
  ASSERT_GE(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("has camera 0 at 320x180"), std::string::npos) << r.warnings[0];
  gst_object_unref(p);
  chain.replace(chain.find(server_rig), server_rig.size(), dir / "missing.yaml");
  p = launch("rgbdtestsrc rig=" + rig + " num-buffers=10 ! " + chain + " ! fakesink");
  r = run_pipeline(p);
  EXPECT_NE(r.error.find("Cannot read the rig"), std::string::npos) << r.error;
  gst_object_unref(p);
}

TEST(CameraLink, LosslessDepthComesBackBitExact) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 160, 90);
  std::string chain = link_chain(30);
  chain.replace(chain.find("rgbdlinkmux name=mux"), 20, "rgbdlinkmux name=mux depth-tolerance=0");
  GstElement* p = launch_beside_truth(rig, 12, chain);
  GstElement* truth_sink = gst_bin_get_by_name(GST_BIN(p), "truth");
  GstElement* out_sink = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    SampleCollector truth(truth_sink), out(out_sink);
    EXPECT_EQ(run_pipeline(p).error, "");
    ASSERT_EQ(out.size(), 12u);
    for (size_t i = 0; i < out.size(); ++i) {
      RgbdFrame o, t;
      ASSERT_TRUE(map_pair(out, i, truth, i, &o, &t));
      EXPECT_TRUE(same_image(t.depth(), o.depth())) << "frame " << i;
    }
  }
  gst_object_unref(truth_sink);
  gst_object_unref(out_sink);
  gst_object_unref(p);
}

namespace {

// Flips a byte inside the depth SEI of access unit number `*(int*)data` (counted from 0).
GstPadProbeReturn damage_depth(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* state = static_cast<std::pair<int, int>*>(data);  // (frames seen, frame to damage)
  if (state->first++ != state->second) return GST_PAD_PROBE_OK;
  GstBuffer* buf = gst_buffer_make_writable(GST_PAD_PROBE_INFO_BUFFER(info));
  GstMapInfo map;
  gst_buffer_map(buf, &map, GST_MAP_READWRITE);
  for (size_t i = 0; i + 16 < map.size; ++i) {
    if (std::memcmp(map.data + i, kDepthLinkSeiUuid, 16) == 0) {
      map.data[i + 16 + 40] ^= 0x5a;  // inside the VCDL header's checksummed bytes
      break;
    }
  }
  gst_buffer_unmap(buf, &map);
  GST_PAD_PROBE_INFO_DATA(info) = buf;
  return GST_PAD_PROBE_OK;
}

}  // namespace

TEST(CameraLink, ADamagedDepthIsDroppedWithOneWarningUntilTheNextKeyFrameAndColourNeverPairsWithOtherDepth) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 160, 90);
  GstElement* p = launch("rgbdtestsrc rig=" + rig + " num-buffers=30 ! " + link_chain(10) + " ! fakesink");
  GstElement* demux = gst_bin_get_by_name(GST_BIN(p), "demux");
  GstPad* pad = gst_element_get_static_pad(demux, "sink");
  std::pair<int, int> state{0, 3};
  gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, damage_depth, &state, nullptr);
  RunResult r = run_pipeline(p);
  EXPECT_EQ(r.error, "");
  // Frame 3's depth is damaged; 4..9 build on it and wait for the key frame that comes with IDR 10.
  EXPECT_EQ(uint64_property(p, "join", "frames"), 23u);
  EXPECT_EQ(uint64_property(p, "join", "frames-dropped"), 7u);
  EXPECT_EQ(uint64_property(p, "demux", "frames-dropped"), 7u);
  ASSERT_GE(r.warnings.size(), 1u);
  EXPECT_LE(r.warnings.size(), 2u) << "rate-limited: the demuxer's and the joiner's first warnings";
  EXPECT_NE(r.warnings[0].find("checksum"), std::string::npos) << r.warnings[0];
  gst_object_unref(pad);
  gst_object_unref(demux);
  gst_object_unref(p);
}

namespace {

// Per access unit leaving rgbdlinkmux: whether it is an IDR picture and whether its depth is a key frame.
struct KeyLog {
  std::vector<std::pair<bool, bool>> units;
  GstElement* rtcp_src = nullptr;
  int pli_after = -1;  // push a PLI into the camera's session after this many units
};

GstBuffer* pli_packet(guint32 sender, guint32 media) {
  GstBuffer* buf = gst_rtcp_buffer_new(1400);
  GstRTCPBuffer rtcp = GST_RTCP_BUFFER_INIT;
  gst_rtcp_buffer_map(buf, GST_MAP_READWRITE, &rtcp);
  GstRTCPPacket packet;
  gst_rtcp_buffer_add_packet(&rtcp, GST_RTCP_TYPE_RR, &packet);
  gst_rtcp_packet_rr_set_ssrc(&packet, sender);
  gst_rtcp_buffer_add_packet(&rtcp, GST_RTCP_TYPE_PSFB, &packet);
  gst_rtcp_packet_fb_set_type(&packet, GST_RTCP_PSFB_TYPE_PLI);
  gst_rtcp_packet_fb_set_sender_ssrc(&packet, sender);
  gst_rtcp_packet_fb_set_media_ssrc(&packet, media);
  gst_rtcp_buffer_unmap(&rtcp);
  return buf;
}

GstPadProbeReturn log_keys(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* log = static_cast<KeyLog*>(data);
  GstMapInfo map;
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  gst_buffer_map(buf, &map, GST_MAP_READ);
  std::vector<uint8_t> vcdl;
  std::string err;
  const bool found = h264_find_user_data(map.data, map.size, kDepthLinkSeiUuid, 1 << 24, &vcdl, &err) == SeiFind::kFound;
  log->units.emplace_back(h264_is_idr(map.data, map.size), found && vcdl.size() > 5 && (vcdl[5] & 1));
  gst_buffer_unmap(buf, &map);
  if (int(log->units.size()) == log->pli_after) {
    GstBuffer* pli = pli_packet(0x1234, 0x56430000);
    GstFlowReturn ret;
    g_signal_emit_by_name(log->rtcp_src, "push-buffer", pli, &ret);
    gst_buffer_unref(pli);
  }
  return GST_PAD_PROBE_OK;
}

}  // namespace

// A server's picture loss indication (RFC 4585 PLI) reaching the camera's RTCP session makes x264enc send an
// IDR picture, and its access unit carries a depth key frame: a server can start or recover at once.
TEST(CameraLink, APictureLossIndicationBringsAKeyFrameOfColourAndDepth) {
  TempDir dir;
  const std::string rig = small_classroom_rig(dir, 160, 90);
  // No periodic key frame in these 40 frames: only the first one and the one asked for.
  GstElement* p = launch(
      "rtpsession name=session rtp-profile=avpf appsrc name=rtcp is-live=true format=time caps=application/x-rtcp ! "
      "session.recv_rtcp_sink "
      "rgbdtestsrc rig=" + rig + " num-buffers=40 is-live=true ! rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! "
      "x264enc tune=zerolatency speed-preset=ultrafast key-int-max=1000 ! video/x-h264,profile=constrained-baseline ! "
      "rgbdlinkmux name=mux ! rtph264pay pt=96 ssrc=1447231488 ! session.send_rtp_sink session.send_rtp_src ! fakesink "
      "sync=false async=false");
  KeyLog log;
  log.rtcp_src = gst_bin_get_by_name(GST_BIN(p), "rtcp");
  log.pli_after = 10;
  GstElement* mux = gst_bin_get_by_name(GST_BIN(p), "mux");
  GstPad* pad = gst_element_get_static_pad(mux, "src");
  gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, log_keys, &log, nullptr);
  RunResult r = run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(log.units.size(), 40u);
  EXPECT_TRUE(log.units[0].first && log.units[0].second);
  int asked = -1;
  for (size_t i = 1; i < log.units.size(); ++i) {
    EXPECT_EQ(log.units[i].first, log.units[i].second) << "colour and depth key frames go together, unit " << i;
    if (log.units[i].first && asked < 0) asked = int(i);
  }
  EXPECT_GE(asked, 10) << "a key frame only after the request";
  EXPECT_GT(asked, 0) << "no key frame after the PLI";
  gst_object_unref(pad);
  gst_object_unref(mux);
  gst_object_unref(log.rtcp_src);
  gst_object_unref(p);
}

// The seeds of the depth link's fuzz target were written (in Python) from docs/network.md's description of
// the depth frame alone: they decode to what that description says, so it is enough to write a sender.
TEST(DepthLink, FramesWrittenFromTheDocumentationDecode) {
  const char* src = std::getenv("VCLASSROOM_SOURCE_DIR");
  if (!src) GTEST_SKIP() << "VCLASSROOM_SOURCE_DIR not set (run through meson test)";
  auto read = [&](const std::string& name) {
    std::vector<uint8_t> b;
    FILE* f = std::fopen((std::string(src) + "/tests/fuzz/corpus/depth_link/" + name).c_str(), "rb");
    if (!f) return b;
    int c;
    while ((c = std::fgetc(f)) != EOF) b.push_back(uint8_t(c));
    std::fclose(f);
    return b;
  };
  DepthLinkDecoder dec;
  DepthLinkFrame f;
  std::string err;
  const std::vector<uint8_t> au = read("access-unit-with-depth-sei.h264");
  std::vector<uint8_t> key;
  ASSERT_EQ(h264_find_user_data(au.data(), au.size(), kDepthLinkSeiUuid, 1 << 20, &key, &err), SeiFind::kFound);
  EXPECT_EQ(key, read("key-4x2-lossless.vcdl"));
  ASSERT_TRUE(dec.decode(key.data(), key.size(), &f, &err)) << err;
  EXPECT_TRUE(same_image(f.depth, (cv::Mat_<uint16_t>(2, 4) << 1000, 1000, 0, 1002, 0, 0, 1003, 1003)));
  EXPECT_TRUE(same_image(f.label, (cv::Mat_<uint8_t>(2, 4) << 0, 0, 1, 1, 0, 2, 2, 0)));
  const std::vector<uint8_t> delta = read("delta-4x2-lossless.vcdl");
  ASSERT_TRUE(dec.decode(delta.data(), delta.size(), &f, &err)) << err;
  EXPECT_FALSE(f.key);
  EXPECT_TRUE(same_image(f.depth, (cv::Mat_<uint16_t>(2, 4) << 1000, 1001, 1001, 1002, 0, 0, 1003, 0)));
  // Within the default bound: kept values, a step, bins (make_depth_link_seeds.py's measurements).
  DepthLinkDecoder near;
  const std::vector<uint8_t> near_key = read("key-4x2-t280.vcdl"), near_delta = read("delta-4x2-t280.vcdl");
  ASSERT_TRUE(near.decode(near_key.data(), near_key.size(), &f, &err)) << err;
  EXPECT_EQ(bound_violations((cv::Mat_<uint16_t>(2, 4) << 1000, 1001, 3000, 0, 2990, 0, 3003, 3010), f.depth, 280), 0);
  ASSERT_TRUE(near.decode(near_delta.data(), near_delta.size(), &f, &err)) << err;
  EXPECT_EQ(bound_violations((cv::Mat_<uint16_t>(2, 4) << 1001, 1009, 3040, 3000, 2995, 2990, 0, 3012), f.depth, 280), 0);
}
