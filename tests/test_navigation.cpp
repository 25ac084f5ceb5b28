// Coverage-aware navigation (docs/navigation.md): the rig's navigation
// bounds, clamping by posenav and by the server (viewfuse), the coverage the
// bounds are derived from, and the honest edge of the fused view.
#include <gtest/gtest.h>

#include <gst/check/gstharness.h>
#include <gst/video/navigation.h>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/navigation.h>
#include <gst/vclassroom/vva/view_fuse.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

// The default classroom rig at a small size with bounds: ±0.2 m right,
// ±0.1 m up, -0.1..0.5 m forward, yaw ±10°, pitch ±5°, roll ±15°.
Rig bounded_rig() {
  Rig rig = default_classroom_rig();
  for (CameraCalib& c : rig.cameras) c = scale_camera(c, 160, 90);
  NavigationBounds b;
  b.reference_camera = 0;
  b.coverage = 0.9;
  b.min = {-0.2, -0.1, -0.1, -10, -5, -15};
  b.max = {0.2, 0.1, 0.5, 10, 5, 15};
  rig.navigation = b;
  return rig;
}

std::array<double, 6> offsets_of(const Pose& p, const CameraCalib& ref) {
  const ViewOffset o = pose_to_offset(p, ref);
  return {o.right, o.up, o.forward, o.yaw, o.pitch, o.roll};
}

// The last pose event `h`'s element sent upstream since the last call (a default Pose when none).
Pose last_pose_sent(GstHarness* h) {
  Pose p;
  while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
    if (is_pose_event(ev)) {
      EXPECT_TRUE(pose_event_parse(ev, &p, nullptr));
    }
    gst_event_unref(ev);
  }
  return p;
}

bool same_pose_bits(const Pose& a, const Pose& b) {
  return a.position == b.position && a.orientation.coeffs() == b.orientation.coeffs();
}

}  // namespace

TEST(NavigationBounds, RigFilesCarryThemAndRefuseBoundsWithoutTheReferenceView) {
  const Rig rig = bounded_rig();
  const Rig back = parse_rig_text(rig_to_text(rig), "bounded.yaml");
  ASSERT_TRUE(back.navigation.has_value());
  EXPECT_EQ(back.navigation->reference_camera, 0);
  EXPECT_EQ(back.navigation->min, rig.navigation->min);
  EXPECT_EQ(back.navigation->max, rig.navigation->max);
  EXPECT_FALSE(parse_rig_text(rig_to_text(default_classroom_rig()), "plain.yaml").navigation.has_value());

  std::string text = rig_to_text(rig);
  const size_t at = text.find("min: [-0.2");
  ASSERT_NE(at, std::string::npos);
  std::string bad = text;
  bad.replace(at, 10, "min: [0.1");  // right from 0.1: the reference view is left out
  try {
    parse_rig_text(bad, "bad.yaml");
    ADD_FAILURE() << "bounds without the reference view accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("must hold 0"), std::string::npos) << e.what();
  }
  bad = text;
  bad.replace(bad.find("reference_camera: 0"), 19, "reference_camera: 7");
  EXPECT_THROW(parse_rig_text(bad, "bad.yaml"), Error);
}

TEST(NavigationBounds, APoseBeyondIsClampedToItsNearestAllowedPoseAndOneInsideIsUntouched) {
  const Rig rig = bounded_rig();
  const CameraCalib& ref = rig.camera(0);
  const NavigationBounds& b = *rig.navigation;
  // Inside: the very same bits.
  Pose inside = offset_to_pose(ViewOffset{0.1, -0.05, 0.3, 5, -2, 10}, ref);
  inside.seq = 7;
  const Pose kept = inside;
  EXPECT_FALSE(clamp_to_navigation(b, ref, &inside));
  EXPECT_TRUE(same_pose_bits(inside, kept));
  // Beyond on every axis: each offset goes to its limit, seq and viewer time stay.
  Pose beyond = offset_to_pose(ViewOffset{1.5, -0.8, 2.0, -40, 30, 60}, ref);
  beyond.seq = 9;
  beyond.viewer_time_ns = 1234;
  EXPECT_TRUE(clamp_to_navigation(b, ref, &beyond));
  const std::array<double, 6> got = offsets_of(beyond, ref);
  const std::array<double, 6> want = {0.2, -0.1, 0.5, -10, 5, 15};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(got[i], want[i], 1e-9) << "offset " << i;
  EXPECT_EQ(beyond.seq, 9u);
  EXPECT_EQ(beyond.viewer_time_ns, 1234);
  // A clamped pose is inside: clamping it again changes nothing.
  const Pose once = beyond;
  EXPECT_FALSE(clamp_to_navigation(b, ref, &beyond));
  EXPECT_TRUE(same_pose_bits(beyond, once));
}

// The classroom's cameras look 20° down. A lecturer turning level (about the vertical) past the yaw range
// is stopped at its edge with the horizon still level, though the range's yaw turns about the camera's
// tilted axis: the roll gives the tilt back.
TEST(NavigationBounds, AViewTurnedLevelPastTheEdgeKeepsItsHorizonLevel) {
  Rig rig = default_classroom_rig();
  NavigationBounds b;
  b.min = {-0.2, -0.1, -0.1, -10, -5, -15};
  b.max = {0.2, 0.1, 0.5, 10, 5, 15};
  const CameraCalib& ref = rig.camera(0);
  const auto level_turn = [&](double yaw_deg) {
    const Eigen::Matrix3d R = ref.cam_to_rig.linear();  // camera -> rig; turn it about the rig's vertical
    Pose p = Pose::from_cam_to_rig(Eigen::Isometry3d(Eigen::Translation3d(ref.cam_to_rig.translation()) *
                                                     Eigen::AngleAxisd(-yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()) * R));
    return p;
  };
  const auto horizon_deg = [](const Pose& p) {
    const Eigen::Matrix3d R = p.orientation.toRotationMatrix();
    return std::atan2(-R(1, 0), -R(1, 1)) * 180 / M_PI;
  };
  for (double yaw : {40.0, -40.0}) {
    Pose p = level_turn(yaw);
    ASSERT_NEAR(horizon_deg(p), 0, 1e-9);
    ASSERT_TRUE(clamp_to_navigation(b, ref, &p)) << yaw;
    const std::array<double, 6> got = offsets_of(p, ref);
    EXPECT_NEAR(std::abs(got[3]), 10, 1e-9) << "at the yaw edge, " << yaw;
    EXPECT_NEAR(horizon_deg(p), 0, 1e-6) << "the horizon tilted, " << yaw;
    EXPECT_GT(std::abs(got[5]), 1) << "the roll offset gives the tilt back, " << yaw;
  }
}

TEST(Coverage, TheReferenceViewIsSeenAndLookingAtTheCeilingIsNot) {
  const Rig rig = default_classroom_rig();
  const Classroom empty(ClassroomConfig{1, 0, 2.0});
  std::vector<CameraCalib> cams;
  std::vector<cv::Mat> depth;
  for (const CameraCalib& c : rig.cameras) {
    cams.push_back(scale_camera(c, 192, 108));
    depth.push_back(render(empty, 0.0, cams.back()).depth);
  }
  CoverageEstimator est(cams, depth, cams[0], 64);
  EXPECT_GT(est.coverage(ViewOffset{}), 0.97);
  EXPECT_LT(est.coverage(ViewOffset{0, 0, 0, 0, 60, 0}), 0.5);  // the ceiling above the cameras' view
  EXPECT_LT(est.coverage(ViewOffset{0, 0, 0, 90, 0, 0}), 0.5);  // the side wall
  NavigationSearch search;
  search.threshold = 0.9;
  search.position_step = 0.1;
  search.angle_step = 5;
  const NavigationBounds b = derive_navigation(est, 0, search);
  for (int i = 0; i < 6; ++i) {
    EXPECT_LE(b.min[i], 0) << i;
    EXPECT_GE(b.max[i], 0) << i;
  }
  EXPECT_LT(b.max[4], 60);  // not up to the ceiling
  // Where the bounds allow, the view straight ahead stays covered.
  for (double r : {b.min[0], b.max[0]})
    for (double u : {b.min[1], b.max[1]})
      for (double f : {b.min[2], b.max[2]}) {
        if (std::abs(r) + std::abs(u) + std::abs(f) == 0) continue;
        EXPECT_GE(est.coverage(ViewOffset{r, u, f, 0, 0, 0}), 0.9 - 0.02) << r << " " << u << " " << f;
      }
}

TEST(PoseNavBounds, TheLecturersViewStopsAtTheBoundsAndATraceBeyondIsClampedWithAWarning) {
  vctest::TempDir dir;
  const Rig rig = bounded_rig();
  save_rig(rig, dir / "rig.yaml");
  GstHarness* h = gst_harness_new_parse(("posenav rig=" + (dir / "rig.yaml")).c_str());
  gst_harness_set_src_caps_str(h, "video/x-raw,format=RGB,width=8,height=8,framerate=30/1");
  auto push_frame = [&] { gst_buffer_unref(gst_harness_push_and_pull(h, gst_harness_create_buffer(h, 8 * 8 * 3))); };
  auto last_pose = [&] { return last_pose_sent(h); };
  push_frame();
  last_pose();
  // Drag far to the right: 2000 px at 0.2°/px would be 400°; the view stops at yaw 10°.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_button_press(1, 0, 0, GST_NAVIGATION_MODIFIER_NONE));
  for (int x = 100; x <= 2000; x += 100)
    gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_move(x, 0, GST_NAVIGATION_MODIFIER_NONE));
  Pose p = last_pose();
  EXPECT_NEAR(offsets_of(p, rig.camera(0))[3], 10, 1e-6);
  // Back by 100 px (20°): it turns at once, no slack beyond the edge.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_move(1900, 0, GST_NAVIGATION_MODIFIER_NONE));
  p = last_pose();
  EXPECT_NEAR(offsets_of(p, rig.camera(0))[3], -10, 1e-6);
  gst_harness_teardown(h);

  // A trace that walks 3 m to the right: every pose beyond is clamped, one warning says how many.
  std::vector<PoseSample> walk(4);
  for (size_t i = 0; i < walk.size(); ++i) walk[i].pose = offset_to_pose(ViewOffset{double(i), 0, 0, 0, 0, 0}, rig.camera(0));
  save_pose_trace(walk, dir / "walk.csv");
  GstElement* pipe = gst_parse_launch(("videotestsrc num-buffers=4 ! video/x-raw,width=8,height=8 ! posenav name=nav rig=" +
                                       (dir / "rig.yaml") + " pose-trace=" + (dir / "walk.csv") + " ! fakesink")
                                          .c_str(),
                                      nullptr);
  const vctest::RunResult r = vctest::run_pipeline(pipe);
  gst_object_unref(pipe);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(r.warnings.size(), 1u);  // the first at once; the other two within 5 s are counted, not posted
  EXPECT_NE(r.warnings[0].find("a pose outside the navigation bounds from the pose trace was moved"), std::string::npos)
      << r.warnings[0];
}

// A posenav without the server's bounds (no rig) learns them from the frames: when the frame showing its
// latest pose says the server clamped it, the view moves to that edge, so a drag back turns at once. An
// echo of an older pose, or of one not clamped, changes nothing.
TEST(PoseNavBounds, AViewTheServerClampedMovesToWhereTheServerHeldIt) {
  GstHarness* h = gst_harness_new("posenav");
  gst_harness_set_src_caps_str(h, "video/x-raw,format=RGB,width=8,height=8,framerate=30/1");
  auto push_frame = [&](bool with_meta, uint64_t seq, const Pose& rendered) {
    GstBuffer* b = gst_harness_create_buffer(h, 8 * 8 * 3);
    if (with_meta) buffer_add_pose_meta(b, seq, 0, rendered_pose_of(rendered));
    gst_buffer_unref(gst_harness_push_and_pull(h, b));
  };
  auto last_pose = [&] { return last_pose_sent(h); };
  const CameraCalib level = rig_origin_reference();
  push_frame(false, 0, Pose());
  last_pose();
  // Drag 400 px right: 80°. The server holds the view at 30°.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_button_press(1, 0, 0, GST_NAVIGATION_MODIFIER_NONE));
  gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_move(400, 0, GST_NAVIGATION_MODIFIER_NONE));
  const Pose sent = last_pose();
  EXPECT_NEAR(pose_to_offset(sent, level).yaw, 80, 1e-6);
  guint64 seq = 0;
  g_object_get(h->element, "seq", &seq, nullptr);
  Pose held = offset_to_pose(ViewOffset{0, 0, 0, 30, 0, 0}, level);
  held.clamped = true;
  push_frame(true, seq - 1, held);  // an older pose's frame: nothing
  Pose not_clamped = held;
  not_clamped.clamped = false;
  push_frame(true, seq, not_clamped);  // not clamped: nothing
  guint64 followed = 1;
  g_object_get(h->element, "server-clamped", &followed, nullptr);
  EXPECT_EQ(followed, 0u);
  push_frame(true, seq, held);
  g_object_get(h->element, "server-clamped", &followed, nullptr);
  EXPECT_EQ(followed, 1u);
  // Back by 50 px (10°): from the held 30°, not from 80°.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_mouse_move(350, 0, GST_NAVIGATION_MODIFIER_NONE));
  EXPECT_NEAR(pose_to_offset(last_pose(), level).yaw, 20, 1e-3);
  gst_harness_teardown(h);
}

TEST(ViewFuseBounds, TheServerClampsEveryPoseItSendsToTheCameras) {
  vctest::TempDir dir;
  const Rig rig = bounded_rig();
  save_rig(rig, dir / "rig.yaml");
  GstElement* fuse = gst_element_factory_make("viewfuse", nullptr);
  g_object_set(fuse, "rig", (dir / "rig.yaml").c_str(), nullptr);
  GstHarness* h = gst_harness_new_with_element(fuse, "cam_0", "src");
  gst_object_unref(fuse);
  gst_harness_play(h);
  auto sent = [&](const Pose& p) {
    EXPECT_TRUE(gst_harness_push_upstream_event(h, pose_event_new(p)));
    Pose got;
    bool found = false;
    while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
      if (is_pose_event(ev)) found = pose_event_parse(ev, &got, nullptr);
      gst_event_unref(ev);
    }
    EXPECT_TRUE(found) << "no pose reached the camera branch";
    return got;
  };
  const CameraCalib& ref = rig.camera(0);
  Pose inside = offset_to_pose(ViewOffset{0.1, 0, 0.2, 3, 1, 0}, ref);
  inside.seq = 1;
  const Pose inside_got = sent(inside);
  EXPECT_TRUE(same_pose_bits(inside_got, inside));  // inside: untouched, bit for bit
  Pose headset = offset_to_pose(ViewOffset{0, 0, 0, 0, 70, 0}, ref);  // looking at the ceiling
  headset.seq = 2;
  const Pose got = sent(headset);
  EXPECT_NEAR(offsets_of(got, ref)[4], 5, 1e-6);
  EXPECT_EQ(got.seq, 2u);
  guint64 clamped = 0;
  g_object_get(h->element, "poses-clamped", &clamped, nullptr);
  EXPECT_EQ(clamped, 1u);
  gst_harness_teardown(h);
}

// The frame names the pose it shows: the server's camera branch (viewwarp) renders the pose viewfuse clamped,
// and the fused frame's pose meta (what the RTP header extension and the WHEP data channel echo to the
// lecturer) carries that clamped pose and says it was clamped; a pose inside comes back as sent, and its
// frame is the one a server without bounds renders, bit for bit.
TEST(ViewFuseBounds, TheFrameCarriesThePoseAsClampedAndRendered) {
  vctest::TempDir dir;
  const Rig rig = bounded_rig();
  save_rig(rig, dir / "rig.yaml");
  const std::string r = dir / "rig.yaml";
  GstHarness* bounded = gst_harness_new_parse(("viewwarp rig=" + r + " ! viewfuse rig=" + r).c_str());
  GstHarness* unbounded = gst_harness_new_parse(("viewwarp rig=" + r + " ! viewfuse").c_str());
  RgbdInfo info;
  info.camera = rig.camera(0);
  info.planes = {Plane::Color, Plane::Depth};
  gst_harness_set_src_caps(bounded, rgbd_caps_new(info));
  gst_harness_set_src_caps(unbounded, rgbd_caps_new(info));
  const Classroom room(ClassroomConfig{1, 3, 2.0});
  const RenderOutput frame = render(room, 0.0, info.camera);
  auto rendered_for = [&](GstHarness* h, const Pose& p, GstClockTime pts, std::vector<uint8_t>* bytes) {
    EXPECT_TRUE(gst_harness_push_upstream_event(h, pose_event_new(p)));
    GstBuffer* buf = rgbd_buffer_new(info);
    {
      RgbdFrame f;
      std::string err;
      EXPECT_TRUE(f.map(buf, info, GST_MAP_WRITE, &err)) << err;
      frame.color.copyTo(f.color());
      frame.depth.copyTo(f.depth());
    }
    GST_BUFFER_PTS(buf) = pts;
    GST_BUFFER_DURATION(buf) = GST_SECOND / 30;
    EXPECT_EQ(gst_harness_push(h, buf), GST_FLOW_OK);
    GstBuffer* out = gst_harness_pull(h);
    PoseMeta m{};
    if (const PoseMeta* got = out ? buffer_get_pose_meta(out) : nullptr) m = *got;
    EXPECT_TRUE(m.rendered.known) << "the fused frame names no rendered pose";
    if (out) {
      bytes->resize(gst_buffer_get_size(out));
      gst_buffer_extract(out, 0, bytes->data(), bytes->size());
      gst_buffer_unref(out);
    }
    return m;
  };
  const CameraCalib& ref = rig.camera(0);
  Pose inside = offset_to_pose(ViewOffset{0.1, 0, 0.2, 3, 1, 0}, ref);
  inside.seq = 1;
  std::vector<uint8_t> with_bounds, without_bounds;
  const PoseMeta a = rendered_for(bounded, inside, 0, &with_bounds);
  EXPECT_EQ(a.seq, 1u);
  EXPECT_FALSE(a.rendered.clamped);
  EXPECT_FLOAT_EQ(a.rendered.position[0], float(inside.position.x()));
  EXPECT_FLOAT_EQ(a.rendered.position[2], float(inside.position.z()));
  rendered_for(unbounded, inside, 0, &without_bounds);
  EXPECT_FALSE(with_bounds.empty());
  EXPECT_TRUE(with_bounds == without_bounds) << "a pose inside the bounds renders differently with them";
  Pose ceiling = offset_to_pose(ViewOffset{0.6, 0, 0, 0, 70, 0}, ref);  // too far right, looking up
  ceiling.seq = 2;
  const PoseMeta b = rendered_for(bounded, ceiling, GST_SECOND / 30, &with_bounds);
  EXPECT_EQ(b.seq, 2u);
  EXPECT_TRUE(b.rendered.clamped);
  const std::array<double, 6> o = offsets_of(pose_of(b.rendered), ref);
  EXPECT_NEAR(o[0], 0.2, 1e-5);  // the nearest allowed pose: 0.2 m right, pitch 5°
  EXPECT_NEAR(o[4], 5, 1e-4);
  gst_harness_teardown(bounded);
  gst_harness_teardown(unbounded);
}

// The fade as documented: the whole frame's distance transform, then the smoothstep towards grey. The fuse may
// take the distance only where it matters, and fill only the holes whose fill can show; what it paints must
// be this.
static void fade_whole_frame(cv::Mat& color, const cv::Mat& depth, double start, double length) {
  cv::Mat distance;
  cv::distanceTransform(depth == 0, distance, cv::DIST_L2, cv::DIST_MASK_3);
  for (int y = 0; y < color.rows; ++y)
    for (int x = 0; x < color.cols; ++x) {
      const float d = distance.at<float>(y, x);
      if (d <= float(start)) continue;
      float a = std::min(1.0f, (d - float(start)) * (1.0f / float(length)));
      a = a * a * (3 - 2 * a);
      cv::Vec3b& c = color.at<cv::Vec3b>(y, x);
      for (int k = 0; k < 3; ++k) c[k] = uint8_t(float(c[k]) * (1 - a) + 96.0f * a + 0.5f);
    }
}

TEST(HonestEdge, TheFadeIsTheWholeFramesDistanceFadeWhateverTheHolesLookLike) {
  cv::RNG rng(20261126);
  for (int trial = 0; trial < 24; ++trial) {
    // Every third frame small (the fade starts nearer than a block's diagonal: the whole frame is transformed).
    const cv::Size size = trial % 3 == 2 ? cv::Size(200, 120) : cv::Size(960, 540);
    WarpedView v;
    v.color.create(size, CV_8UC3);
    rng.fill(v.color, cv::RNG::UNIFORM, 0, 256);
    v.depth.create(size, CV_16UC1);
    rng.fill(v.depth, cv::RNG::UNIFORM, 1500, 5000);
    v.weight = cv::Mat(size, CV_8UC1, cv::Scalar(255));
    // Unseen: rectangles (some at the frame's edges), discs and speckle; trial 0 only speckle, trial 1 nothing seen,
    // trial 4 two pixels seen.
    const int shapes = trial == 0 ? 0 : rng.uniform(1, 6);
    for (int i = 0; i < shapes; ++i) {
      const cv::Point p(rng.uniform(-size.width / 4, size.width), rng.uniform(-size.height / 4, size.height));
      if (rng.uniform(0, 2))
        cv::rectangle(v.depth, cv::Rect(p, cv::Size(rng.uniform(4, size.width / 2), rng.uniform(4, size.height / 2))),
                      cv::Scalar(0), cv::FILLED);
      else
        cv::circle(v.depth, p, rng.uniform(3, size.height / 3), cv::Scalar(0), cv::FILLED);
    }
    for (int i = 0; i < 400; ++i) v.depth.at<uint16_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) = 0;
    if (trial == 1) v.depth.setTo(0);
    if (trial == 4) {  // two pixels seen: too little for the pyramid's cells, so it fills nothing
      v.depth.setTo(0);
      v.depth.at<uint16_t>(100, 200) = 3000, v.depth.at<uint16_t>(300, 700) = 2500;
    }
    FuseParams fade, plain;
    plain.fade_unseen = false;
    FusedView faded, unfaded;
    fuse_views({&v}, fade, &faded);
    fuse_views({&v}, plain, &unfaded);
    fade_whole_frame(unfaded.color, unfaded.depth, fade.fade_start * size.width, fade.fade_length * size.width);
    ASSERT_EQ(cv::norm(faded.color, unfaded.color, cv::NORM_INF), 0) << "trial " << trial;
    // The holes the fade paints grey the fill leaves alone (a lecturer looking away from the cameras is
    // half holes): they still count as made, as when it filled them.
    ASSERT_EQ(cv::norm(faded.filled, unfaded.filled, cv::NORM_INF), 0) << "trial " << trial;
  }
}

TEST(HonestEdge, WhatNoCameraSawFadesToGreyAndIsCounted) {
  // One view seeing only the left quarter of a 200x100 image.
  WarpedView v;
  v.color = cv::Mat(100, 200, CV_8UC3, cv::Scalar(200, 50, 50));
  v.depth = cv::Mat::zeros(100, 200, CV_16UC1);
  v.depth(cv::Rect(0, 0, 50, 100)).setTo(3000);
  v.weight = cv::Mat(100, 200, CV_8UC1, cv::Scalar(255));
  FusedView out;
  fuse_views({&v}, FuseParams(), &out);
  EXPECT_NEAR(out.unseen_share, 0.75, 1e-9);
  // Next to what was seen, the fill; far from it, the neutral grey (no red streak across the frame).
  const cv::Vec3b near_edge = out.color.at<cv::Vec3b>(50, 52), far = out.color.at<cv::Vec3b>(50, 199);
  EXPECT_GT(near_edge[0], 150);
  EXPECT_EQ(far, cv::Vec3b(96, 96, 96));
  // Without the fade, the edge pixel is smeared to the far border: what this replaces.
  FuseParams smear;
  smear.fade_unseen = false;
  fuse_views({&v}, smear, &out);
  EXPECT_GT(out.color.at<cv::Vec3b>(50, 199)[0], 150);
}

// viewwarp without a rig shows, until the first pose event, the camera its caps describe. A real classroom's
// camera (here placed, turned and sized unlike any of the synthetic rig's) so sees its own frame; viewwarp
// used to fall back to the synthetic classroom's rig and showed its camera 0's view instead.
TEST(ViewWarpReference, WithoutARigTheFirstViewIsTheCapsCameraItself) {
  CameraCalib cam;
  cam.id = 0;
  cam.name = "real";
  cam.width = 80;
  cam.height = 60;
  cam.fx = cam.fy = 70;
  cam.cx = 40;
  cam.cy = 30;
  cam.cam_to_rig = Eigen::Translation3d(1.5, -0.4, 0.8) * Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY());
  RgbdInfo info;
  info.camera = cam;
  info.planes = {Plane::Color, Plane::Depth};
  GstHarness* h = gst_harness_new_parse("viewwarp");
  gst_harness_set_src_caps(h, rgbd_caps_new(info));
  // A textured wall 2 m in front of the camera: its identity view is the frame itself.
  cv::Mat color(cam.height, cam.width, CV_8UC3), depth(cam.height, cam.width, CV_16UC1, cv::Scalar(2000));
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) color.at<cv::Vec3b>(y, x) = cv::Vec3b(3 * x, 4 * y, 2 * (x + y));
  GstBuffer* buf = rgbd_buffer_new(info);
  {
    RgbdFrame f;
    std::string err;
    ASSERT_TRUE(f.map(buf, info, GST_MAP_WRITE, &err)) << err;
    color.copyTo(f.color());
    depth.copyTo(f.depth());
  }
  GST_BUFFER_PTS(buf) = 0;
  ASSERT_EQ(gst_harness_push(h, buf), GST_FLOW_OK);
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  GstCaps* oc = gst_pad_get_current_caps(h->sinkpad);
  RgbdInfo oi;
  ASSERT_TRUE(rgbd_info_from_caps(oc, &oi, nullptr));
  gst_caps_unref(oc);
  EXPECT_TRUE(oi.camera.cam_to_rig.isApprox(cam.cam_to_rig, 1e-9)) << "the caps name another view than the camera's";
  const PoseMeta* m = buffer_get_pose_meta(out);
  ASSERT_NE(m, nullptr);
  ASSERT_TRUE(m->rendered.known);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(m->rendered.position[i], cam.cam_to_rig.translation()[i], 1e-5);
  RgbdFrame f;
  ASSERT_TRUE(f.map(out, oi, GST_MAP_READ, nullptr));
  int differ = 0;
  const cv::Rect inner(2, 2, cam.width - 4, cam.height - 4);
  for (int y = inner.y; y < inner.br().y; ++y)
    for (int x = inner.x; x < inner.br().x; ++x) {
      const cv::Vec3b a = f.color().at<cv::Vec3b>(y, x), b = color.at<cv::Vec3b>(y, x);
      if (std::abs(a[0] - b[0]) > 2 || std::abs(a[1] - b[1]) > 2 || std::abs(a[2] - b[2]) > 2) ++differ;
    }
  EXPECT_EQ(differ, 0) << "pixels of the first view unlike the camera's own frame";
  f.unmap();
  gst_buffer_unref(out);
  gst_harness_teardown(h);
}
