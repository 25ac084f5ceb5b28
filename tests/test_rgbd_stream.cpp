// The video/x-rgbd stream: caps helpers, rgbdmux/rgbddemux, and pose events
// travelling upstream through ordinary elements.
#include <gtest/gtest.h>

#include <random>

#include <gst/app/gstappsrc.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/rgbd.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

RgbdInfo sample_info() {
  RgbdInfo info;
  info.camera = vctest::make_rig(3, 33, 17).cameras[2];
  info.camera.cam_to_rig.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  info.camera.cam_to_rig.translation() = Eigen::Vector3d(0.8, -0.0123456789, 1.0 / 3.0);
  info.camera.distortion = {0.1, -0.2, 0.001, 0.002, 1.0 / 7.0};
  info.camera.fx = 1000.0 / 3.0;
  info.fps_n = 30000;
  info.fps_d = 1001;
  return info;
}

cv::Mat random_mat(int rows, int cols, int type, unsigned seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, type == CV_16UC1 ? 65536 : 256);
  return m;
}

// A video/x-raw buffer holding `m` with GstVideoInfo's default stride.
GstBuffer* raw_buffer(const cv::Mat& m, GstVideoFormat fmt, GstClockTime pts) {
  GstVideoInfo vi;
  gst_video_info_set_format(&vi, fmt, m.cols, m.rows);
  GstBuffer* buf = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&vi), nullptr);
  GstMapInfo map;
  gst_buffer_map(buf, &map, GST_MAP_WRITE);
  memset(map.data, 0xEE, map.size);  // padding must never leak into the image
  for (int y = 0; y < m.rows; ++y)
    memcpy(map.data + y * GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0), m.ptr(y), m.cols * m.elemSize());
  gst_buffer_unmap(buf, &map);
  GST_BUFFER_PTS(buf) = pts;
  GST_BUFFER_DURATION(buf) = GST_SECOND / 30;
  return buf;
}

cv::Mat raw_to_mat(GstBuffer* buf, int w, int h, int type, GstVideoFormat fmt) {
  GstVideoInfo vi;
  gst_video_info_set_format(&vi, fmt, w, h);
  GstMapInfo map;
  gst_buffer_map(buf, &map, GST_MAP_READ);
  cv::Mat m = cv::Mat(h, w, type, map.data, GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0)).clone();
  gst_buffer_unmap(buf, &map);
  return m;
}

GstCaps* raw_caps(const char* format, int w, int h) {
  return gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, format, "width", G_TYPE_INT, w, "height",
                             G_TYPE_INT, h, "framerate", GST_TYPE_FRACTION, 30, 1, nullptr);
}

GstElement* launch(const std::string& desc) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  EXPECT_EQ(err, nullptr) << (err ? err->message : "");
  g_clear_error(&err);
  return p;
}

GstElement* by_name(GstElement* pipeline, const char* name) {
  return gst_bin_get_by_name(GST_BIN(pipeline), name);  // caller unrefs
}

}  // namespace

TEST(RgbdCaps, RoundTripThroughAStringKeepsEveryField) {
  RgbdInfo info = sample_info();
  info.planes = {Plane::Color, Plane::Depth, Plane::Label, Plane::DepthGT};
  GstCaps* caps = rgbd_caps_new(info);
  gchar* text = gst_caps_to_string(caps);
  GstCaps* parsed = gst_caps_from_string(text);
  ASSERT_NE(parsed, nullptr) << text;
  RgbdInfo back;
  std::string err;
  ASSERT_TRUE(rgbd_info_from_caps(parsed, &back, &err)) << err << " in " << text;
  EXPECT_EQ(back.planes, info.planes);
  EXPECT_EQ(back.fps_n, 30000);
  EXPECT_EQ(back.fps_d, 1001);
  EXPECT_EQ(back.camera.id, info.camera.id);
  EXPECT_EQ(back.width(), 33);
  EXPECT_EQ(back.height(), 17);
  EXPECT_EQ(back.camera.fx, info.camera.fx);  // exact: doubles serialize losslessly
  EXPECT_EQ(back.camera.cy, info.camera.cy);
  EXPECT_EQ(back.camera.distortion, info.camera.distortion);
  EXPECT_TRUE(back.camera.cam_to_rig.matrix() == info.camera.cam_to_rig.matrix());
  EXPECT_TRUE(gst_caps_is_equal(caps, parsed));
  g_free(text);
  gst_caps_unref(caps);
  gst_caps_unref(parsed);
}

TEST(RgbdCaps, BadCapsNameTheField) {
  auto error_of = [](const char* text) {
    GstCaps* caps = gst_caps_from_string(text);
    RgbdInfo info;
    std::string err;
    EXPECT_FALSE(rgbd_info_from_caps(caps, &info, &err)) << text;
    gst_caps_unref(caps);
    return err;
  };
  const std::string base =
      "video/x-rgbd, width=64, height=48, framerate=30/1, camera-id=0, fx=50.0, fy=50.0, cx=32.0, cy=24.0, "
      "distortion=<0.0,0.0,0.0,0.0,0.0>, translation=<0.0,0.0,0.0>";
  EXPECT_NE(error_of((base + ", planes=\"color,depth\"").c_str()).find("'rotation'"), std::string::npos);
  const std::string rot = ", rotation=<1.0,0.0,0.0,0.0,1.0,0.0,0.0,0.0,1.0>";
  EXPECT_NE(error_of((base + rot).c_str()).find("'planes'"), std::string::npos);
  EXPECT_NE(error_of((base + rot + ", planes=\"depth,color\"").c_str()).find("start with"), std::string::npos);
  EXPECT_NE(error_of((base + rot + ", planes=\"color,depth,smell\"").c_str()).find("smell"), std::string::npos);
  std::string zero_fx = base + rot + ", planes=\"color,depth\"";
  zero_fx.replace(zero_fx.find("fx=50.0"), 7, "fx=0.0");
  EXPECT_NE(error_of(zero_fx.c_str()).find("'fx'"), std::string::npos);
  EXPECT_NE(error_of("video/x-raw, width=64").find("video/x-rgbd"), std::string::npos);
}

TEST(RgbdBuffer, PlanesMapAsMatsAtTheirLayout) {
  RgbdInfo info = sample_info();
  info.planes = {Plane::Color, Plane::Depth, Plane::Label};
  GstBuffer* buf = rgbd_buffer_new(info);
  EXPECT_EQ(gst_buffer_n_memory(buf), 3u);
  {
    RgbdFrame f;
    std::string err;
    ASSERT_TRUE(f.map(buf, info, GST_MAP_WRITE, &err)) << err;
    EXPECT_EQ(f.color().type(), CV_8UC3);
    EXPECT_EQ(f.depth().type(), CV_16UC1);
    EXPECT_EQ(f.label().type(), CV_8UC1);
    EXPECT_TRUE(f.plane(Plane::Weight).empty());
    f.color().setTo(cv::Scalar(1, 2, 3));
    f.depth().setTo(4000);
    f.label().setTo(7);
  }
  // Without metas (as after the network), the packed default layout applies.
  GstBuffer* flat = gst_buffer_new_allocate(nullptr, gst_buffer_get_size(buf), nullptr);
  GstMapInfo src, dst;
  gst_buffer_map(buf, &src, GST_MAP_READ);
  gst_buffer_map(flat, &dst, GST_MAP_WRITE);
  memcpy(dst.data, src.data, src.size);
  gst_buffer_unmap(flat, &dst);
  gst_buffer_unmap(buf, &src);
  EXPECT_EQ(gst_buffer_get_size(flat), info.default_total_size());
  RgbdFrame f;
  ASSERT_TRUE(f.map(flat, info, GST_MAP_READ, nullptr));
  EXPECT_EQ(f.color().at<cv::Vec3b>(16, 32), cv::Vec3b(1, 2, 3));
  EXPECT_EQ(f.depth().at<uint16_t>(16, 32), 4000);
  EXPECT_EQ(f.label().at<uint8_t>(0, 0), 7);
  f.unmap();
  // A truncated buffer is refused, never read past its end (the last row's
  // stride padding may go: 33 labels need 33 of its 36 bytes).
  gst_buffer_resize(flat, 0, gst_buffer_get_size(flat) - 3);
  ASSERT_TRUE(f.map(flat, info, GST_MAP_READ, nullptr));
  f.unmap();
  gst_buffer_resize(flat, 0, gst_buffer_get_size(flat) - 1);
  std::string err;
  EXPECT_FALSE(f.map(flat, info, GST_MAP_READ, &err));
  EXPECT_NE(err.find("label"), std::string::npos) << err;
  gst_buffer_unref(flat);
  gst_buffer_unref(buf);
}

// Colour and depth go in as plain video, come out of rgbddemux bit-exact.
// 33x17 makes GStreamer pad every row, so strides are exercised too.
TEST(RgbdMuxDemux, BitExactRoundTrip) {
  const int w = 33, h = 17, frames = 4;
  GstElement* p = launch(
      "appsrc name=c format=time ! m.color appsrc name=d format=time ! m.depth "
      "rgbdmux name=m ! tee name=t ! queue ! appsink name=rgbd sync=false "
      "t. ! queue ! rgbddemux name=x x.color ! queue ! appsink name=oc sync=false "
      "x.depth ! queue ! appsink name=od sync=false");
  GstElement *c = by_name(p, "c"), *d = by_name(p, "d"), *rgbd = by_name(p, "rgbd"), *oc = by_name(p, "oc"),
             *od = by_name(p, "od");
  vctest::SampleCollector got_rgbd(rgbd), got_c(oc), got_d(od);
  GstCaps* cc = raw_caps("RGB", w, h);
  GstCaps* dc = raw_caps("GRAY16_LE", w, h);
  gst_app_src_set_caps(GST_APP_SRC(c), cc);
  gst_app_src_set_caps(GST_APP_SRC(d), dc);
  std::vector<cv::Mat> colors, depths;
  for (int i = 0; i < frames; ++i) {
    colors.push_back(random_mat(h, w, CV_8UC3, 10 + i));
    depths.push_back(random_mat(h, w, CV_16UC1, 20 + i));
    gst_app_src_push_buffer(GST_APP_SRC(c), raw_buffer(colors.back(), GST_VIDEO_FORMAT_RGB, i * GST_SECOND / 30));
    gst_app_src_push_buffer(GST_APP_SRC(d),
                            raw_buffer(depths.back(), GST_VIDEO_FORMAT_GRAY16_LE, i * GST_SECOND / 30));
  }
  gst_app_src_end_of_stream(GST_APP_SRC(c));
  gst_app_src_end_of_stream(GST_APP_SRC(d));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got_c.size(), static_cast<size_t>(frames));
  ASSERT_EQ(got_d.size(), static_cast<size_t>(frames));
  ASSERT_EQ(got_rgbd.size(), static_cast<size_t>(frames));
  RgbdInfo info;
  std::string err;
  ASSERT_TRUE(rgbd_info_from_caps(got_rgbd.caps(0), &info, &err)) << err;
  for (int i = 0; i < frames; ++i) {
    EXPECT_TRUE(vctest::same_image(raw_to_mat(got_c.buffer(i), w, h, CV_8UC3, GST_VIDEO_FORMAT_RGB), colors[i]))
        << "colour frame " << i;
    EXPECT_TRUE(
        vctest::same_image(raw_to_mat(got_d.buffer(i), w, h, CV_16UC1, GST_VIDEO_FORMAT_GRAY16_LE), depths[i]))
        << "depth frame " << i;
    EXPECT_EQ(GST_BUFFER_PTS(got_c.buffer(i)), i * GST_SECOND / 30);
    RgbdFrame f;
    ASSERT_TRUE(f.map(got_rgbd.buffer(i), info, GST_MAP_READ, &err)) << err;
    EXPECT_TRUE(vctest::same_image(f.color(), colors[i]));
    EXPECT_TRUE(vctest::same_image(f.depth(), depths[i]));
  }
  gst_caps_unref(cc);
  gst_caps_unref(dc);
  for (GstElement* e : {c, d, rgbd, oc, od}) gst_object_unref(e);
  gst_object_unref(p);
}

// rgbdmux puts the rig's calibration in the caps, pairs by running time and
// drops a frame that has no partner.
TEST(RgbdMuxDemux, MuxUsesTheRigAndPairsByRunningTime) {
  vctest::TempDir dir;
  vclassroom::Rig rig = vctest::make_rig(2, 32, 16);
  rig.cameras[1].fx = 123.25;
  save_rig(rig, dir / "rig.yaml");
  GstElement* p = launch("appsrc name=c format=time ! m.color appsrc name=d format=time ! m.depth "
                         "rgbdmux name=m rig=" + dir / "rig.yaml" + " camera-id=1 ! appsink name=out sync=false");
  GstElement *c = by_name(p, "c"), *d = by_name(p, "d"), *out = by_name(p, "out");
  vctest::SampleCollector got(out);
  GstCaps* cc = raw_caps("RGB", 32, 16);
  GstCaps* dc = raw_caps("GRAY16_LE", 32, 16);
  gst_app_src_set_caps(GST_APP_SRC(c), cc);
  gst_app_src_set_caps(GST_APP_SRC(d), dc);
  const GstClockTime f = GST_SECOND / 30;
  for (int i : {0, 1, 2, 3})
    gst_app_src_push_buffer(GST_APP_SRC(c), raw_buffer(random_mat(16, 32, CV_8UC3, i), GST_VIDEO_FORMAT_RGB, i * f));
  for (int i : {0, 2, 3})  // depth frame 1 was lost
    gst_app_src_push_buffer(GST_APP_SRC(d),
                            raw_buffer(random_mat(16, 32, CV_16UC1, i), GST_VIDEO_FORMAT_GRAY16_LE, i * f + 1000));
  gst_app_src_end_of_stream(GST_APP_SRC(c));
  gst_app_src_end_of_stream(GST_APP_SRC(d));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(0)), 0u);
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(1)), 2 * f);
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(2)), 3 * f);
  RgbdInfo info;
  ASSERT_TRUE(rgbd_info_from_caps(got.caps(0), &info, nullptr));
  EXPECT_EQ(info.camera.id, 1);
  EXPECT_EQ(info.camera.fx, 123.25);
  EXPECT_EQ(info.camera.center_in_rig().x(), 0.1);
  gst_caps_unref(cc);
  gst_caps_unref(dc);
  for (GstElement* e : {c, d, out}) gst_object_unref(e);
  gst_object_unref(p);
}

TEST(RgbdMuxDemux, MismatchedSizesAndBadRigPostErrors) {
  auto r = vctest::run_launch(
      "videotestsrc num-buffers=2 ! video/x-raw,format=RGB,width=64,height=48 ! m.color "
      "videotestsrc num-buffers=2 ! video/x-raw,format=GRAY16_LE,width=32,height=24 ! m.depth "
      "rgbdmux name=m ! fakesink");
  EXPECT_NE(r.error.find("depth is 32x24 but colour is 64x48"), std::string::npos) << r.error;
  r = vctest::run_launch(
      "videotestsrc num-buffers=2 ! video/x-raw,format=RGB,width=64,height=48 ! m.color "
      "videotestsrc num-buffers=2 ! video/x-raw,format=GRAY16_LE,width=64,height=48 ! m.depth "
      "rgbdmux name=m rig=/nonexistent/rig.yaml ! fakesink");
  EXPECT_NE(r.error.find("/nonexistent/rig.yaml"), std::string::npos) << r.error;
}

// The label plane gets its own output pad when the stream has it; a corrupt
// (short) buffer is dropped with a warning and the stream goes on.
TEST(RgbdMuxDemux, DemuxExposesLabelsAndDropsCorruptFrames) {
  RgbdInfo info = sample_info();
  info.planes = {Plane::Color, Plane::Depth, Plane::Label};
  GstElement* p = launch("appsrc name=src format=time ! rgbddemux name=x x.color ! queue ! fakesink "
                         "x.depth ! queue ! fakesink x.label ! queue ! appsink name=lab sync=false");
  GstElement *src = by_name(p, "src"), *lab = by_name(p, "lab");
  vctest::SampleCollector got(lab);
  GstCaps* caps = rgbd_caps_new(info);
  gst_app_src_set_caps(GST_APP_SRC(src), caps);
  cv::Mat labels = random_mat(info.height(), info.width(), CV_8UC1, 5);
  for (int i = 0; i < 3; ++i) {
    GstBuffer* buf = rgbd_buffer_new(info);
    {
      RgbdFrame f;
      ASSERT_TRUE(f.map(buf, info, GST_MAP_WRITE, nullptr));
      f.color().setTo(0);
      f.depth().setTo(1000);
      labels.copyTo(f.label());
    }
    if (i == 1) {  // cut short, metas gone: as a broken network frame would arrive
      GstBuffer* bad = gst_buffer_new_allocate(nullptr, 100, nullptr);
      gst_buffer_unref(buf);
      buf = bad;
    }
    GST_BUFFER_PTS(buf) = i * GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(src), buf);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  const auto r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got.size(), 2u);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("corrupt"), std::string::npos) << r.warnings[0];
  GstStructure* s = gst_caps_get_structure(got.caps(0), 0);
  EXPECT_STREQ(gst_structure_get_string(s, "format"), "GRAY8");
  EXPECT_TRUE(vctest::same_image(raw_to_mat(got.buffer(1), info.width(), info.height(), CV_8UC1,
                                            GST_VIDEO_FORMAT_GRAY8),
                                 labels));
  EXPECT_EQ(GST_BUFFER_PTS(got.buffer(1)), 2 * GST_SECOND / 30);
  gst_caps_unref(caps);
  gst_object_unref(src);
  gst_object_unref(lab);
  gst_object_unref(p);
}

namespace {
struct SeenPoses {
  GMutex lock;
  std::vector<uint64_t> seqs;
};

GstPadProbeReturn record_pose(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* seen = static_cast<SeenPoses*>(data);
  GstEvent* ev = GST_PAD_PROBE_INFO_EVENT(info);
  Pose pose;
  if (is_pose_event(ev) && pose_event_parse(ev, &pose, nullptr)) {
    g_mutex_lock(&seen->lock);
    seen->seqs.push_back(pose.seq);
    g_mutex_unlock(&seen->lock);
    // Stand in for the consumer (viewwarp): the event stops here, handled.
    gst_event_unref(ev);
    GST_PAD_PROBE_INFO_DATA(info) = nullptr;
    return GST_PAD_PROBE_HANDLED;
  }
  return GST_PAD_PROBE_OK;
}
}  // namespace

// A pose sent from the sink reaches both sources through queue, tee, an
// aggregator (rgbdmux) and rgbddemux, in order and with its seq.
TEST(PoseEvents, SurviveQueueTeeAndAggregator) {
  GstElement* p = launch(
      "videotestsrc name=sc is-live=true ! video/x-raw,format=RGB,width=32,height=24,framerate=30/1 ! queue ! "
      "m.color videotestsrc name=sd is-live=true ! video/x-raw,format=GRAY16_LE,width=32,height=24,framerate=30/1 ! "
      "queue ! m.depth rgbdmux name=m ! tee name=t ! queue ! fakesink "
      "t. ! queue ! rgbddemux name=x x.color ! queue ! fakesink name=sink x.depth ! queue ! fakesink");
  GstElement *sc = by_name(p, "sc"), *sd = by_name(p, "sd"), *sink = by_name(p, "sink");
  SeenPoses seen_c, seen_d;
  g_mutex_init(&seen_c.lock);
  g_mutex_init(&seen_d.lock);
  GstPad* pc = gst_element_get_static_pad(sc, "src");
  GstPad* pd = gst_element_get_static_pad(sd, "src");
  gst_pad_add_probe(pc, GST_PAD_PROBE_TYPE_EVENT_UPSTREAM, record_pose, &seen_c, nullptr);
  gst_pad_add_probe(pd, GST_PAD_PROBE_TYPE_EVENT_UPSTREAM, record_pose, &seen_d, nullptr);
  ASSERT_NE(gst_element_set_state(p, GST_STATE_PLAYING), GST_STATE_CHANGE_FAILURE);
  ASSERT_EQ(gst_element_get_state(p, nullptr, nullptr, 30 * GST_SECOND), GST_STATE_CHANGE_SUCCESS);
  for (uint64_t seq : {7ull, 8ull, 1000000000000ull}) {
    Pose pose;
    pose.position = Eigen::Vector3d(0.1 * static_cast<double>(seq % 10), 0, 0.5);
    pose.seq = seq;
    // Upstream events travel synchronously: when this returns, both sources saw it.
    EXPECT_TRUE(gst_element_send_event(sink, pose_event_new(pose)));
  }
  gst_element_set_state(p, GST_STATE_NULL);
  const std::vector<uint64_t> expected{7, 8, 1000000000000ull};
  EXPECT_EQ(seen_c.seqs, expected);
  EXPECT_EQ(seen_d.seqs, expected);
  gst_object_unref(pc);
  gst_object_unref(pd);
  for (GstElement* e : {sc, sd, sink}) gst_object_unref(e);
  gst_object_unref(p);
  g_mutex_clear(&seen_c.lock);
  g_mutex_clear(&seen_d.lock);
}
