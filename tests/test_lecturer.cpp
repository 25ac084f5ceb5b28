// posenav: navigation events from the video sink become pose events upstream;
// sliders and pose traces drive the view.
#include <gtest/gtest.h>

#include <gst/check/gstharness.h>
#include <gst/video/navigation.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_offset.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

GstHarness* nav_harness(const std::string& props = "") {
  GstHarness* h = gst_harness_new_parse(("posenav " + props).c_str());
  gst_harness_set_src_caps_str(h, "video/x-raw,format=RGB,width=8,height=8,framerate=30/1");
  return h;
}

void push_frame(GstHarness* h) {
  GstBuffer* out = gst_harness_push_and_pull(h, gst_harness_create_buffer(h, 8 * 8 * 3));
  ASSERT_NE(out, nullptr);
  gst_buffer_unref(out);
}

// The next upstream pose or navigation event (the harness's own reconfigure
// and latency events are skipped); nullptr when there is none.
GstEvent* next_event(GstHarness* h) {
  while (GstEvent* ev = gst_harness_try_pull_upstream_event(h)) {
    if (is_pose_event(ev) || GST_EVENT_TYPE(ev) == GST_EVENT_NAVIGATION) return ev;
    gst_event_unref(ev);
  }
  return nullptr;
}

// The next upstream event posenav sent, parsed as a pose (fails if none or not a pose).
Pose next_pose(GstHarness* h) {
  Pose p;
  GstEvent* ev = next_event(h);
  EXPECT_NE(ev, nullptr) << "no pose event upstream";
  if (!ev) return p;
  std::string err;
  EXPECT_TRUE(pose_event_parse(ev, &p, &err)) << err;
  gst_event_unref(ev);
  return p;
}

void expect_no_upstream_event(GstHarness* h) {
  GstEvent* ev = next_event(h);
  EXPECT_EQ(ev, nullptr) << "unexpected upstream event " << (ev ? gst_event_type_get_name(GST_EVENT_TYPE(ev)) : "");
  if (ev) gst_event_unref(ev);
}

Eigen::Vector3d forward_of(const Pose& p) { return p.orientation * Eigen::Vector3d::UnitZ(); }

}  // namespace

TEST(PoseNav, SendsTheStartPoseThenFollowsKeysWheelAndDrag) {
  GstHarness* h = nav_harness();
  push_frame(h);
  const Pose start = next_pose(h);
  EXPECT_LT(start.position.norm(), 1e-12);
  EXPECT_LT((forward_of(start) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-12);  // level reference looks along -Z
  EXPECT_GT(start.viewer_time_ns, 0);
  push_frame(h);
  expect_no_upstream_event(h);  // nothing changed, nothing sent

  EXPECT_TRUE(gst_harness_push_upstream_event(h, gst_navigation_event_new_key_press("Up", GST_NAVIGATION_MODIFIER_NONE)));
  Pose p = next_pose(h);
  EXPECT_GT(p.seq, start.seq);
  EXPECT_LT((p.position - Eigen::Vector3d(0, 0, -0.1)).norm(), 1e-12);
  EXPECT_TRUE(gst_harness_push_upstream_event(h, gst_navigation_event_new_key_release("Up", GST_NAVIGATION_MODIFIER_NONE)));
  expect_no_upstream_event(h);  // used (swallowed), nothing new to send

  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_scroll(0, 0, 0, 2, GST_NAVIGATION_MODIFIER_NONE)));
  p = next_pose(h);
  EXPECT_NEAR(p.position.z(), -0.3, 1e-12);

  // Drag 50 px right with the left button: turn right by 10 degrees.
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_button_press(1, 100, 100, GST_NAVIGATION_MODIFIER_NONE)));
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_move(150, 100, GST_NAVIGATION_MODIFIER_NONE)));
  p = next_pose(h);
  const double yaw = std::atan2(forward_of(p).x(), -forward_of(p).z()) * 180 / M_PI;
  EXPECT_NEAR(yaw, 10.0, 1e-9);
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_button_release(1, 150, 100, GST_NAVIGATION_MODIFIER_NONE)));
  EXPECT_TRUE(gst_harness_push_upstream_event(
      h, gst_navigation_event_new_mouse_move(300, 100, GST_NAVIGATION_MODIFIER_NONE)));
  // A move without a button is not ours: it goes on upstream untouched.
  GstEvent* passed = next_event(h);
  ASSERT_NE(passed, nullptr);
  EXPECT_EQ(GST_EVENT_TYPE(passed), GST_EVENT_NAVIGATION);
  gst_event_unref(passed);

  // Walking forward now follows the new heading.
  const Eigen::Vector3d before = p.position;
  gst_harness_push_upstream_event(h, gst_navigation_event_new_key_press("w", GST_NAVIGATION_MODIFIER_NONE));
  p = next_pose(h);
  EXPECT_LT(((p.position - before) - 0.1 * forward_of(p)).norm(), 1e-9);

  // Home returns to the start pose.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_key_press("Home", GST_NAVIGATION_MODIFIER_NONE));
  p = next_pose(h);
  EXPECT_LT((p.position - start.position).norm(), 1e-12);
  EXPECT_LT(p.orientation.angularDistance(start.orientation), 1e-9);
  gst_harness_teardown(h);
}

TEST(PoseNav, SlidersAreRelativeToTheRigsReferenceCamera) {
  vctest::TempDir dir;
  Rig rig = vctest::make_rig(2);
  rig.cameras[1].cam_to_rig.translation() = Eigen::Vector3d(0.8, 0.1, 0);
  save_rig(rig, dir / "rig.yaml");
  GstHarness* h = nav_harness("rig=" + dir / "rig.yaml" + " reference-camera=1 sliders=\"[100,50,50,50,50,50]\"");
  push_frame(h);
  Pose p = next_pose(h);
  // Reference camera 1 has identity rotation: slider 1 at 100 is 1 m along its x.
  EXPECT_LT((p.position - Eigen::Vector3d(1.8, 0.1, 0)).norm(), 1e-12);
  // Setting the sliders while playing jumps there at once.
  GstElement* nav = gst_harness_find_element(h, "posenav");  // new_parse wraps it in a bin
  g_object_set(nav, "sliders", "[50,50,50,75,50,50]", nullptr);
  p = next_pose(h);
  EXPECT_LT((p.position - Eigen::Vector3d(0.8, 0.1, 0)).norm(), 1e-12);
  EXPECT_NEAR(forward_of(p).x(), std::sqrt(0.5), 1e-12);
  gchar* now = nullptr;
  g_object_get(nav, "sliders", &now, nullptr);
  ASSERT_NE(now, nullptr);
  const Sliders s = parse_sliders(now);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(s[k], k == 3 ? 75 : 50, 1e-9) << now;
  g_free(now);
  gst_object_unref(nav);
  gst_harness_teardown(h);
}

TEST(PoseNav, APoseTraceSendsOnePosePerFrame) {
  vctest::TempDir dir;
  vctest::write_text(dir / "walk.csv",
                     "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.033,0.1,0,0,1,0,0,0\n0.067,0.2,0,0,1,0,0,0\n");
  GstHarness* h = nav_harness("pose-trace=" + dir / "walk.csv");
  uint64_t last_seq = 0;
  for (double x : {0.0, 0.1, 0.2, 0.2}) {
    push_frame(h);
    const Pose p = next_pose(h);
    EXPECT_DOUBLE_EQ(p.position.x(), x);
    EXPECT_GT(p.seq, last_seq);
    last_seq = p.seq;
  }
  // Navigation is ignored while a trace drives the view, and passes on.
  gst_harness_push_upstream_event(h, gst_navigation_event_new_key_press("Up", GST_NAVIGATION_MODIFIER_NONE));
  GstEvent* ev = next_event(h);
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(GST_EVENT_TYPE(ev), GST_EVENT_NAVIGATION);
  gst_event_unref(ev);
  gst_harness_teardown(h);
}

TEST(PoseNav, BadTraceOrRigPostsAnError) {
  for (const std::string props : {"pose-trace=/nonexistent/walk.csv", "rig=/nonexistent/rig.yaml"}) {
    const auto r = vctest::run_launch("videotestsrc num-buffers=1 ! posenav " + props + " ! fakesink");
    EXPECT_NE(r.error.find("/nonexistent/"), std::string::npos) << props << ": " << r.error;
  }
}
