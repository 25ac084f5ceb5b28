// The core family's pose: pose events, the six-slider notation and pose traces (the pose on the network,
// the net family's, is tested in test_pose_net.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_navigator.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_trace.h>

#include "test_util.h"

using namespace vclassroom;
using vctest::expect_same_pose;
using vctest::sample_pose;

namespace {

std::string parse_error(GstStructure* s) {
  GstEvent* ev = gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s);
  Pose p;
  std::string err;
  const bool ok = pose_event_parse(ev, &p, &err);
  gst_event_unref(ev);
  return ok ? "" : err;
}

GstStructure* pose_structure(double x, double qw, double qx) {
  return gst_structure_new(kPoseEventName, "x", G_TYPE_DOUBLE, x, "y", G_TYPE_DOUBLE, 0.0, "z", G_TYPE_DOUBLE, 0.0,
                           "qw", G_TYPE_DOUBLE, qw, "qx", G_TYPE_DOUBLE, qx, "qy", G_TYPE_DOUBLE, 0.0, "qz",
                           G_TYPE_DOUBLE, 0.0, "seq", G_TYPE_UINT64, G_GUINT64_CONSTANT(1), nullptr);
}

}  // namespace

TEST(PoseEvent, RoundTripKeepsEveryField) {
  const Pose p = sample_pose();
  GstEvent* ev = pose_event_new(p);
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(GST_EVENT_TYPE(ev), GST_EVENT_CUSTOM_UPSTREAM);
  EXPECT_TRUE(is_pose_event(ev));
  Pose back;
  std::string err;
  ASSERT_TRUE(pose_event_parse(ev, &back, &err)) << err;
  expect_same_pose(p, back);
  gst_event_unref(ev);
}

TEST(PoseEvent, OptionalFieldsStayAbsent) {
  Pose p;
  p.seq = 3;
  GstEvent* ev = pose_event_new(p);
  const GstStructure* s = gst_event_get_structure(ev);
  EXPECT_FALSE(gst_structure_has_field(s, "fov"));
  EXPECT_FALSE(gst_structure_has_field(s, "viewer-time"));
  Pose back;
  ASSERT_TRUE(pose_event_parse(ev, &back, nullptr));
  EXPECT_FALSE(back.has_fov());
  EXPECT_EQ(back.viewer_time_ns, -1);
  gst_event_unref(ev);
}

TEST(PoseEvent, InvalidPosesAreRejected) {
  Pose p = sample_pose();
  p.position.x() = std::nan("");
  EXPECT_THROW(pose_event_new(p), Error);
  p = sample_pose();
  p.orientation.coeffs() *= 2.0;  // norm 2
  EXPECT_THROW(pose_event_new(p), Error);
  p = sample_pose();
  p.position = Eigen::Vector3d(0, 5000, 0);
  EXPECT_THROW(pose_event_new(p), Error);
  p = sample_pose();
  p.fov_deg = 0.0;
  EXPECT_THROW(pose_event_new(p), Error);

  // The same checks apply to events made by anyone else.
  EXPECT_NE(parse_error(pose_structure(std::nan(""), 1, 0)).find("not finite"), std::string::npos);
  EXPECT_NE(parse_error(pose_structure(0, 0.5, 0)).find("unit quaternion"), std::string::npos);
  EXPECT_NE(parse_error(pose_structure(1e7, 1, 0)).find("from the rig origin"), std::string::npos);
  EXPECT_EQ(parse_error(pose_structure(0.5, std::sqrt(0.5), std::sqrt(0.5))), "");
  GstStructure* no_seq = pose_structure(0, 1, 0);
  gst_structure_remove_field(no_seq, "seq");
  EXPECT_NE(parse_error(no_seq).find("'seq'"), std::string::npos);
  GstStructure* text = pose_structure(0, 1, 0);
  gst_structure_set(text, "qz", G_TYPE_STRING, "up", nullptr);
  EXPECT_NE(parse_error(text).find("'qz'"), std::string::npos);
  // Other events are not poses.
  GstEvent* other = gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, gst_structure_new_empty("something/else"));
  EXPECT_FALSE(is_pose_event(other));
  gst_event_unref(other);
}

TEST(Sliders, CentreIsTheReferenceCamera) {
  CameraCalib ref = vctest::make_rig(1).cameras[0];
  ref.cam_to_rig.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  ref.cam_to_rig.translation() = Eigen::Vector3d(0.4, 1.2, 0);
  const Pose p = sliders_to_pose(parse_sliders("[50,50,50,50,50,50]"), ref);
  EXPECT_LT((p.position - ref.cam_to_rig.translation()).norm(), 1e-12);
  EXPECT_LT((p.cam_to_rig().linear() - ref.cam_to_rig.linear()).norm(), 1e-12);
}

TEST(Sliders, EachSliderMovesAsDocumented) {
  CameraCalib ref = vctest::make_rig(1).cameras[0];
  ref.cam_to_rig.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();  // level, Y up in the rig
  const Eigen::Matrix3d R = ref.cam_to_rig.linear();
  // s1 = 100: one metre to the camera's right, which is rig +X here.
  EXPECT_LT((sliders_to_pose({100, 50, 50, 50, 50, 50}, ref).position - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  // s2 = 75: half a metre up (rig +Y).
  EXPECT_LT((sliders_to_pose({50, 75, 50, 50, 50, 50}, ref).position - Eigen::Vector3d(0, 0.5, 0)).norm(), 1e-12);
  // s3 = 0: one metre backwards (the camera looks along rig -Z).
  EXPECT_LT((sliders_to_pose({50, 50, 0, 50, 50, 50}, ref).position - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
  // s4 = 75: turn right by 45 degrees: the optical axis swings towards the camera's right.
  const Eigen::Vector3d fwd = sliders_to_pose({50, 50, 50, 75, 50, 50}, ref).cam_to_rig().linear() * Eigen::Vector3d::UnitZ();
  EXPECT_LT((fwd - R * Eigen::Vector3d(std::sqrt(0.5), 0, std::sqrt(0.5))).norm(), 1e-12);
  // s5 = 75: look up by 45 degrees.
  const Eigen::Vector3d up = sliders_to_pose({50, 50, 50, 50, 75, 50}, ref).cam_to_rig().linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(up.y(), std::sqrt(0.5), 1e-12);
}

TEST(Sliders, RoundTripThroughAPose) {
  CameraCalib ref = vctest::make_rig(1).cameras[0];
  ref.cam_to_rig.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                            Eigen::Vector3d(1, -1, -1).asDiagonal();
  ref.cam_to_rig.translation() = Eigen::Vector3d(-0.8, 0.1, 0.05);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> any(0, 100), pitch(1, 99);
  for (int i = 0; i < 500; ++i) {
    Sliders s{any(rng), any(rng), any(rng), pitch(rng), pitch(rng), pitch(rng)};
    const Sliders back = pose_to_sliders(sliders_to_pose(s, ref), ref);
    for (int k = 0; k < 6; ++k) ASSERT_NEAR(back[k], s[k], 1e-9) << "slider " << k << " of " << format_sliders(s);
  }
  const Sliders s{10, 20.5, 30, 40, 60, 70};
  EXPECT_EQ(parse_sliders(format_sliders(s)), s);
}

TEST(Sliders, BadNotationIsRejected) {
  EXPECT_THROW(parse_sliders("[50,50,50,50,50]"), Error);
  EXPECT_THROW(parse_sliders("[50,50,50,50,50,50,50]"), Error);
  EXPECT_THROW(parse_sliders("[50,50,x,50,50,50]"), Error);
  EXPECT_THROW(parse_sliders("[50,50,150,50,50,50]"), Error);
  EXPECT_EQ(parse_sliders("50 50 50 50 50 50")[0], 50);
}

// ---- The lecturer's mouse and keys (core/view_navigator.h); posenav's events: test_lecturer.

TEST(ViewNavigator, KeysAndWheelWalkLevelAlongTheHeadingAndHomeReturns) {
  ViewNavigator nav;
  nav.start.up = 0.5;
  nav.view = nav.start;
  EXPECT_EQ(nav.key_press("Up"), Navigated::kMoved);
  EXPECT_NEAR(nav.view.forward, 0.1, 1e-12);
  EXPECT_EQ(nav.key_release("Up"), Navigated::kTaken);  // the press moved; the release changes nothing
  EXPECT_EQ(nav.key_release("o"), Navigated::kNotOurs);  // a key of its own, not a piece of "Home"'s name
  EXPECT_EQ(nav.key_release(""), Navigated::kNotOurs);
  EXPECT_EQ(nav.key_press("x"), Navigated::kNotOurs);
  EXPECT_EQ(nav.scroll(2), Navigated::kMoved);
  EXPECT_NEAR(nav.view.forward, 0.3, 1e-12);
  nav.view.yaw = 90;  // facing right: forward is the reference's right
  EXPECT_EQ(nav.press(4, 0, 0), Navigated::kMoved);  // an X11 wheel notch away from you
  EXPECT_NEAR(nav.view.right, 0.1, 1e-12);
  EXPECT_NEAR(nav.view.forward, 0.3, 1e-12);
  EXPECT_EQ(nav.release(4), Navigated::kTaken);
  EXPECT_EQ(nav.key_press("q"), Navigated::kMoved);
  EXPECT_NEAR(nav.view.up, 0.6, 1e-12);
  EXPECT_EQ(nav.key_press("Home"), Navigated::kMoved);
  EXPECT_EQ(nav.view.up, 0.5);
  EXPECT_EQ(nav.view.forward, 0.0);
}

TEST(ViewNavigator, DraggingWithTheLeftButtonTurnsAndPitchStopsShortOfStraightUp) {
  ViewNavigator nav;
  EXPECT_EQ(nav.pointer_move(10, 10), Navigated::kNotOurs);  // no drag: the pointer is not ours
  EXPECT_EQ(nav.press(3, 0, 0), Navigated::kNotOurs);
  EXPECT_EQ(nav.press(1, 100, 100), Navigated::kTaken);
  EXPECT_EQ(nav.pointer_move(150, 100), Navigated::kMoved);
  EXPECT_NEAR(nav.view.yaw, 50 * ViewNavigator::kDefaultTurnSpeed, 1e-12);
  EXPECT_EQ(nav.pointer_move(150, -10000), Navigated::kMoved);  // dragged far up
  EXPECT_EQ(nav.view.pitch, 89.0);
  EXPECT_EQ(nav.release(1), Navigated::kTaken);
  EXPECT_EQ(nav.pointer_move(0, 0), Navigated::kNotOurs);
}

TEST(PoseTrace, LoadsWhatWasSaved) {
  vctest::TempDir dir;
  std::vector<PoseSample> trace;
  for (int i = 0; i < 30; ++i) {
    PoseSample s;
    s.t = i / 30.0;
    s.pose.position = Eigen::Vector3d(0.01 * i, 0, -0.02 * i);
    s.pose.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * i, Eigen::Vector3d::UnitY()));
    s.pose.fov_deg = 75;
    s.pose.seq = 100 + i;
    trace.push_back(s);
  }
  save_pose_trace(trace, dir / "trace.csv");
  const auto back = load_pose_trace(dir / "trace.csv");
  ASSERT_EQ(back.size(), trace.size());
  for (size_t i = 0; i < trace.size(); ++i) {
    EXPECT_DOUBLE_EQ(back[i].t, trace[i].t);
    expect_same_pose(trace[i].pose, back[i].pose);
  }
}

TEST(PoseTrace, MinimalTraceNumbersFramesAndErrorsNameLineAndColumn) {
  vctest::TempDir dir;
  vctest::write_text(dir / "a.csv", "# walk\nx,y,z,qw,qx,qy,qz\n0,0,0,1,0,0,0\n0.1,0,0,1,0,0,0\n");
  const auto t = load_pose_trace(dir / "a.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[1].pose.seq, 1u);
  EXPECT_TRUE(std::isnan(t[1].t));

  auto error_of = [&](const std::string& text) {
    vctest::write_text(dir / "b.csv", text);
    try {
      load_pose_trace(dir / "b.csv");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  std::string e = error_of("x,y,z,qw,qx,qy\n");
  EXPECT_NE(e.find("'qz'"), std::string::npos) << e;
  e = error_of("x,y,z,qw,qx,qy,qz\n0,0,0,1,0,0,0\n0,0,zz,1,0,0,0\n");
  EXPECT_NE(e.find("b.csv:3"), std::string::npos) << e;
  EXPECT_NE(e.find("'z'"), std::string::npos) << e;
  e = error_of("x,y,z,qw,qx,qy,qz\n0,0,0,2,0,0,0\n");
  EXPECT_NE(e.find("unit quaternion"), std::string::npos) << e;
  e = error_of("x,y,z,qw,qx,qy,qz\n0,0,0,1,0,0\n");
  EXPECT_NE(e.find("columns"), std::string::npos) << e;
  e = error_of("t,x,y,z,qw,qx,qy,qz\n0.1,0,0,0,1,0,0,0\n0.05,0,0,0,1,0,0,0\n");
  EXPECT_NE(e.find("b.csv:3"), std::string::npos) << e;
  EXPECT_NE(e.find("'t'"), std::string::npos) << e;
  EXPECT_THROW(load_pose_trace(dir / "missing.csv"), Error);
}

TEST(PoseTrace, TheSampleForAFrameComesFromItsTimeOrItsNumber) {
  std::vector<PoseSample> timed(3);
  for (int i = 0; i < 3; ++i) timed[size_t(i)].t = i / 30.0;
  EXPECT_EQ(pose_trace_index(timed, 0.0, 7), 0u);            // the time decides, not the frame number
  EXPECT_EQ(pose_trace_index(timed, 0.02, 0), 0u);           // between samples: the one before
  EXPECT_EQ(pose_trace_index(timed, 2 / 30.0 - 1e-9, 0), 2u);  // rounding of the frame time
  EXPECT_EQ(pose_trace_index(timed, -1.0, 0), 0u);           // before the trace: its first sample
  EXPECT_EQ(pose_trace_index(timed, 10.0, 0), 2u);           // after it: the last is held
  std::vector<PoseSample> untimed(3);
  EXPECT_EQ(pose_trace_index(untimed, 5.0, 1), 1u);
  EXPECT_EQ(pose_trace_index(untimed, 0.0, 9), 2u);
}
