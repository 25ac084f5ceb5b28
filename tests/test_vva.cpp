// V-VA, the library alone (GStreamer-free): view warping, fusion and hole filling, virtual views, learner
// segmentation, the background memory, and how a view's cameras start warping together.
#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/check/gstharness.h>
#include <gst/gst.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/background_memory.h>
#include <gst/vclassroom/vva/fuse_inputs.h>
#include <gst/vclassroom/vva/hole_fill.h>
#include <gst/vclassroom/vva/learner_seg.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/view_cull.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_turns.h>
#include <gst/vclassroom/vva/view_warp.h>
#include <gst/vclassroom/vva/virtual_view.h>
#include <gst/vclassroom/vva/warp_start.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

CameraCalib pinhole(int w, int h, double f) {
  CameraCalib c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = (w - 1) / 2.0;
  c.cy = (h - 1) / 2.0;
  return c;
}

// A smooth texture that bilinear sampling reproduces closely: colour of column u.
cv::Vec3b ramp_color(double u, double v) {
  return cv::Vec3b(uint8_t(128 + 100 * std::sin(u * 0.21)), uint8_t(128 + 100 * std::cos(v * 0.17)),
                   uint8_t(128 + 60 * std::sin((u + v) * 0.11)));
}

WarpSource fronto_plane(int w, int h, uint16_t depth_mm) {
  WarpSource s;
  s.color.create(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) s.color.at<cv::Vec3b>(y, x) = ramp_color(x, y);
  s.depth = cv::Mat(h, w, CV_16UC1, cv::Scalar(depth_mm));
  return s;
}

}  // namespace

TEST(ViewWarp, OwnPoseReproducesTheCleanClassroom) {
  const Classroom room(ClassroomConfig{3, 4, 2.0});
  const CameraCalib cam = scale_camera(default_classroom_rig().camera(1), 320, 180);
  const RenderOutput r = render(room, 1.0, cam);
  WarpSource src{r.color, r.depth, r.label, cv::Mat()};
  for (bool mesh : {false, true}) {
    WarpParams p;
    p.mesh = mesh;
    const WarpedView w = warp_view(cam, src, cam, p);
    FusedView f;
    fuse_views({&w}, FuseParams(), &f);
    EXPECT_GT(psnr_rgb(f.color, r.color), 40.0) << (mesh ? "mesh" : "splat");
  }
}

TEST(ViewWarp, SidewaysMoveOfAFrontoParallelPlaneShiftsByTheDisparity) {
  const int w = 120, h = 60;
  const double f = 100, z = 2.0, baseline = 0.113;  // disparity 5.65 px, not an integer
  const CameraCalib src = pinhole(w, h, f);
  CameraCalib virt = src;
  virt.cam_to_rig.translation() = Eigen::Vector3d(baseline, 0, 0);
  const WarpSource in = fronto_plane(w, h, uint16_t(z * 1000));
  const double d = f * baseline / z;
  for (bool mesh : {false, true}) {
    WarpParams p;
    p.mesh = mesh;
    const WarpedView out = warp_view(src, in, virt, p);
    double max_err = 0;
    int checked = 0;
    for (int y = 2; y < h - 2; ++y)
      for (int x = 2; x < w - 2 - int(std::ceil(d)); ++x) {
        ASSERT_GT(out.weight.at<uint8_t>(y, x), 0) << "hole at " << x << "," << y;
        EXPECT_EQ(out.depth.at<uint16_t>(y, x), 2000);
        // The point seen at virtual x was at source x + d.
        const double u = x + d;
        const int u0 = int(u);
        const double a = u - u0;
        const cv::Vec3b c0 = in.color.at<cv::Vec3b>(y, u0), c1 = in.color.at<cv::Vec3b>(y, u0 + 1);
        for (int ch = 0; ch < 3; ++ch) {
          const double expect = (1 - a) * c0[ch] + a * c1[ch];
          max_err = std::max(max_err, std::abs(expect - out.color.at<cv::Vec3b>(y, x)[ch]));
        }
        ++checked;
      }
    EXPECT_GT(checked, 5000);
    EXPECT_LE(max_err, 1.01) << (mesh ? "mesh" : "splat") << ": sub-pixel shift off";
    // What moved out of view on the right is a hole, not smeared.
    EXPECT_EQ(out.weight.at<uint8_t>(h / 2, w - 1), 0);
  }
}

// Inside one smooth surface 2x2 blocks of pixels are drawn as one cell
// (WarpParams::coarse_cells): a slanted plane seen from a moved and turned
// view comes out as from every pixel's own cell, without a hole.
TEST(ViewWarp, CoarseCellsOnASmoothPlaneMatchTheFineCells) {
  const int w = 161, h = 91;  // odd: the last column and row are not in a block
  const CameraCalib src = pinhole(w, h, 120);
  WarpSource in = fronto_plane(w, h, 2000);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) in.depth.at<uint16_t>(y, x) = uint16_t(1800 + 3 * x + 2 * y);
  CameraCalib virt = src;
  virt.cam_to_rig = Eigen::Translation3d(0.07, -0.03, 0.05) * Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX());
  for (double f : {120.0, 150.0}) {  // 150: the view magnifies, some block cells take the big-cell path
    virt.fx = virt.fy = f;
    WarpParams fine_prm, coarse_prm;
    fine_prm.coarse_cells = false;
    coarse_prm.coarse_cells = true;
    const WarpedView fine = warp_view(src, in, virt, fine_prm), coarse = warp_view(src, in, virt, coarse_prm);
    ASSERT_GT(cv::countNonZero(fine.weight), w * h / 2);
    int only_fine = 0, only_coarse = 0;
    double max_color = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool a = fine.weight.at<uint8_t>(y, x) > 0, b = coarse.weight.at<uint8_t>(y, x) > 0;
        only_fine += a && !b;
        only_coarse += b && !a;
        if (a && b) {
          for (int ch = 0; ch < 3; ++ch)
            max_color = std::max(max_color, std::abs(double(fine.color.at<cv::Vec3b>(y, x)[ch]) -
                                                     coarse.color.at<cv::Vec3b>(y, x)[ch]));
          // One depth for the block: its pixels' differ by 3 + 2 mm (and the view's scale).
          EXPECT_NEAR(fine.depth.at<uint16_t>(y, x), coarse.depth.at<uint16_t>(y, x), 10) << x << "," << y;
          EXPECT_NEAR(fine.weight.at<uint8_t>(y, x), coarse.weight.at<uint8_t>(y, x), 2) << x << "," << y;
        }
      }
    EXPECT_EQ(only_fine, 0) << "holes the fine cells do not leave, f " << f;
    EXPECT_EQ(only_coarse, 0) << "f " << f;
    EXPECT_LE(max_color, 1.0) << "f " << f;
  }
}

// A warper keeps its buffers between frames (the z-buffer is emptied as the
// result is read out): a frame must come out the same as from a fresh warper,
// whatever the frames before it were, at any virtual size.
TEST(ViewWarp, AReusedWarperGivesWhatAFreshOneGives) {
  const Classroom room(ClassroomConfig{2, 5, 2.0});
  const Rig rig = default_classroom_rig();
  const CameraCalib cam = scale_camera(rig.camera(1), 240, 135);
  const RenderOutput a = render(room, 0.5, cam), b = render(room, 2.0, cam);
  auto view = [&](double x_slider, int w, int h) {
    const Pose p = sliders_to_pose(Sliders{x_slider, 50, 50, 55, 50, 50}, rig.camera(0));
    return virtual_camera(scale_camera(rig.camera(0), w, h), p.cam_to_rig(), NAN);
  };
  WarpParams prm;
  prm.boundary_px = 1;
  ViewWarper reused;
  WarpedView out;
  reused.warp(cam, WarpSource{a.color, a.depth, a.label, cv::Mat()}, view(30, 240, 135), prm, &out);
  reused.warp(cam, WarpSource{a.color, a.depth, a.label, cv::Mat()}, view(40, 200, 100), prm, &out);
  for (auto [w, h] : {std::pair{200, 100}, std::pair{240, 135}}) {
    const WarpSource src{b.color, b.depth, b.label, cv::Mat()};
    reused.warp(cam, src, view(45, w, h), prm, &out);
    const WarpedView fresh = warp_view(cam, src, view(45, w, h), prm);
    ASSERT_EQ(out.color.size(), cv::Size(w, h));
    EXPECT_GT(cv::countNonZero(fresh.weight), w * h / 4) << "the test view should see much of the room";
    EXPECT_EQ(cv::norm(out.color, fresh.color, cv::NORM_INF), 0) << w << "x" << h;
    EXPECT_EQ(cv::norm(out.depth, fresh.depth, cv::NORM_INF), 0) << w << "x" << h;
    EXPECT_EQ(cv::norm(out.label, fresh.label, cv::NORM_INF), 0) << w << "x" << h;
    EXPECT_EQ(cv::norm(out.weight, fresh.weight, cv::NORM_INF), 0) << w << "x" << h;
  }
}

// With the room view, what goes forward from a camera (WarpParams::learners_only) is its learners, the room's
// pixels beside them and those without a static depth; not a surface one pixel thin, which each camera's cells
// drew a pixel off from the others' (the nearest camera's mesh draws it: RoomMesh's edge parts).
TEST(ViewWarp, WhatGoesForwardBesideTheRoomIsTheLearnersAndWhatTheRoomHasNoDepthFor) {
  CameraCalib cam;
  cam.width = 40, cam.height = 30, cam.fx = cam.fy = 40, cam.cx = 19.5, cam.cy = 14.5;
  cv::Mat color(30, 40, CV_8UC3, cv::Scalar(120, 120, 120)), depth(30, 40, CV_16UC1, cv::Scalar(4000));
  cv::Mat label(30, 40, CV_8UC1, cv::Scalar(0));
  depth.col(20).setTo(2000);  // a chair's leg before the wall, one pixel wide
  cv::Mat static_depth = depth.clone();
  static_depth.at<uint16_t>(5, 5) = 0;  // the room's model has no depth here
  depth(cv::Rect(30, 10, 4, 4)).setTo(3000);
  label(cv::Rect(30, 10, 4, 4)).setTo(1);  // a learner
  WarpParams learners_only;
  learners_only.learners_only = true;
  PreparedSource prepared;
  ViewWarper().prepare(cam, WarpSource{color, depth, label, static_depth}, learners_only, &prepared);
  ASSERT_EQ(prepared.learner_depth.size(), size_t(40 * 30));
  auto forward = [&](int x, int y) { return prepared.learner_depth[size_t(y) * 40 + x] != 0; };
  EXPECT_TRUE(forward(31, 11)) << "the learner";
  EXPECT_TRUE(forward(29, 11)) << "the room beside the learner";
  EXPECT_TRUE(forward(5, 5)) << "no static depth";
  EXPECT_FALSE(forward(20, 20)) << "the thin leg: the room's mesh draws it";
  EXPECT_FALSE(forward(10, 20)) << "the wall";
  int forwarded = 0;
  for (uint16_t d : prepared.learner_depth) forwarded += d != 0;
  EXPECT_LT(forwarded, 40) << "the learner's 16 pixels, the 16 around it, the one without static depth";
}

TEST(ViewWarp, ThePreparedHalvesWarpAsTheWholeForAnyWarperAndAnyNumberOfViews) {
  // viewwarp prepares the source before it reads the pose, then warps it for the pose.
  const Classroom room(ClassroomConfig{2, 5, 2.0});
  const Rig rig = default_classroom_rig();
  const CameraCalib cam = scale_camera(rig.camera(1), 240, 135);
  const RenderOutput r = render(room, 1.5, cam);
  const Pose p = sliders_to_pose(Sliders{35, 50, 50, 55, 50, 50}, rig.camera(0));
  const CameraCalib virt = virtual_camera(cam, p.cam_to_rig(), NAN);
  const WarpSource src{r.color, r.depth, r.label, cv::Mat()};
  const WarpedView whole = warp_view(cam, src, virt);
  ViewWarper preparer, view1, view2;
  PreparedSource prepared;
  preparer.prepare(cam, src, WarpParams(), &prepared);
  EXPECT_GT(cv::countNonZero(whole.weight), 240 * 135 / 4) << "the test view should see much of the room";
  // Any warper warps it, any number of times (one camera's frame prepared once for several views).
  for (ViewWarper* w : {&view1, &view2, &view1}) {
    WarpedView out;
    w->warp_prepared(cam, src, prepared, virt, WarpParams(), &out);
    EXPECT_EQ(cv::norm(out.color, whole.color, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(out.depth, whole.depth, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(out.label, whole.label, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(out.weight, whole.weight, cv::NORM_INF), 0);
  }
  PreparedSource other_size = prepared;
  other_size.width = 120;
  WarpedView out;
  EXPECT_THROW(view1.warp_prepared(cam, src, other_size, virt, WarpParams(), &out), cv::Exception);
}

// The learners' view (WarpParams::learners_only) is unpacked, cleared and fused over the tiles its cells mark
// (SampleTiles), not over the whole view: warped again and again into the same planes, for poses that move the
// learners about, it is the view a fresh warper gives into fresh planes, pixel for pixel (and the one warp()
// gives, which finds the learners' rows itself: SparseRows); every sample lies in its tiles, and the tiles hold
// much less than the box around the learners.
namespace {
// Camera 1 of the default rig at `width` x `height` over a classroom of 6 learners: its frame and the empty
// room's depth (what the room view's tests warp).
struct LearnersFrame {
  Rig rig = default_classroom_rig();
  CameraCalib cam;
  RenderOutput r;
  cv::Mat static_depth;
};
LearnersFrame learners_frame(int width, int height) {
  LearnersFrame f;
  f.cam = scale_camera(f.rig.camera(1), width, height);
  f.r = render(Classroom(ClassroomConfig{2, 6, 2.0}), 1.5, f.cam);
  f.static_depth = render(Classroom(ClassroomConfig{2, 0, 2.0}), 0.0, f.cam).depth;
  return f;
}
}  // namespace

TEST(ViewWarp, ALearnersViewWarpedIntoTheSamePlanesAgainIsTheFreshOneAndLiesInItsTiles) {
  const LearnersFrame frame = learners_frame(320, 180);
  const Rig& rig = frame.rig;
  const CameraCalib& cam = frame.cam;
  const RenderOutput& r = frame.r;
  const cv::Mat& static_depth = frame.static_depth;
  WarpParams params;
  params.learners_only = true;
  const WarpSource src{r.color, r.depth, r.label, static_depth};
  PreparedSource prepared;
  ViewWarper().prepare(cam, src, params, &prepared);
  ViewWarper reused;
  WarpedView out;
  for (const Sliders& s : {Sliders{50, 50, 50, 50, 50, 50}, Sliders{20, 60, 40, 70, 50, 50},
                           Sliders{80, 40, 60, 30, 45, 50}, Sliders{50, 50, 50, 50, 50, 50}}) {
    const CameraCalib virt =
        virtual_camera(cam, sliders_to_pose(s, rig.camera(0)).cam_to_rig(), NAN);
    WarpedView fresh, unprepared;
    ViewWarper().warp_prepared(cam, src, prepared, virt, params, &fresh);
    reused.warp_prepared(cam, src, prepared, virt, params, &out);
    // Warped whole, the learners' rows found as it warps rather than by prepare(): the same view.
    ViewWarper().warp(cam, src, virt, params, &unprepared);
    EXPECT_EQ(cv::norm(unprepared.color, fresh.color, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(unprepared.depth, fresh.depth, cv::NORM_INF), 0) << format_sliders(s);
    ASSERT_GT(cv::countNonZero(fresh.depth), 1000) << format_sliders(s) << ": the learners should be in view";
    EXPECT_EQ(cv::norm(out.color, fresh.color, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(out.depth, fresh.depth, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(out.label, fresh.label, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(out.weight, fresh.weight, cv::NORM_INF), 0) << format_sliders(s);
    ASSERT_FALSE(out.tiles.anywhere());
    ASSERT_TRUE(out.tiles.fit(virt.width, virt.height));
    cv::Mat in_tiles(virt.height, virt.width, CV_8UC1, cv::Scalar(0));
    for_each_tile_span(out.tiles, virt.height, [&](int y, int x0, int x1) { in_tiles.row(y).colRange(x0, x1) = 255; });
    EXPECT_EQ(cv::countNonZero((out.weight != 0) & (in_tiles == 0)), 0) << format_sliders(s);
    EXPECT_EQ(cv::countNonZero((out.depth != 0) & (in_tiles == 0)), 0) << format_sliders(s);
    cv::Mat drawn;
    cv::findNonZero(out.depth, drawn);
    EXPECT_LT(cv::countNonZero(in_tiles), cv::boundingRect(drawn).area() * 3 / 4) << format_sliders(s);
  }
  // Tiles of another size are not taken for this view's.
  EXPECT_FALSE(out.tiles.fit(cam.width, cam.height + SampleTiles::kPx));
  EXPECT_FALSE(out.tiles.fit(cam.width / 2, cam.height));
}

// A sparse layer is drawn over its rows' spans (SparseRows: each row projected and linked once, over the
// columns of every pair that reads it), a full layer over whole rows: where every pixel is a learner and the
// room has no depth, the learners' warp (all of the source as a sparse layer) is the full warp's view, pixel for
// pixel, at poses that stretch, shrink and turn the source.
TEST(ViewWarp, ALayerDrawnSparselyOverItsSpansIsTheOneDrawnWhole) {
  const Classroom room(ClassroomConfig{2, 5, 2.0});
  const Rig rig = default_classroom_rig();
  const CameraCalib cam = scale_camera(rig.camera(1), 240, 135);
  const RenderOutput r = render(room, 1.5, cam);
  cv::Mat label(r.depth.size(), CV_8UC1, cv::Scalar(1));
  label.setTo(0, r.depth == 0);
  label.setTo(2, r.label != 0);  // two "learners", so that the labels' edges count as in the full warp
  const WarpSource src{r.color, r.depth, label, cv::Mat()};
  WarpParams whole;
  whole.coarse_cells = false;  // a sparse layer has no 2x2 block cells
  WarpParams sparse = whole;
  sparse.learners_only = true;
  for (const Sliders& s : {Sliders{35, 50, 50, 55, 50, 50}, Sliders{60, 40, 60, 40, 55, 50},
                           Sliders{50, 55, 30, 60, 50, 50}}) {
    const CameraCalib virt = virtual_camera(cam, sliders_to_pose(s, rig.camera(0)).cam_to_rig(), NAN);
    WarpedView full, learners;
    ViewWarper().warp(cam, src, virt, whole, &full);
    ViewWarper().warp(cam, src, virt, sparse, &learners);
    ASSERT_GT(cv::countNonZero(full.depth), 240 * 135 / 4) << format_sliders(s);
    EXPECT_EQ(cv::norm(learners.color, full.color, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(learners.depth, full.depth, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(learners.label, full.label, cv::NORM_INF), 0) << format_sliders(s);
    EXPECT_EQ(cv::norm(learners.weight, full.weight, cv::NORM_INF), 0) << format_sliders(s);
  }
}

// Every warper on a thread shares one z-buffer, which each warp leaves empty: after learners' warps of several
// sizes by other warpers (their records in tiles only), a full warp on the thread is the one a fresh thread
// gives, pixel for pixel.
TEST(ViewWarp, WarpersSharingAThreadsZBufferLeaveItEmpty) {
  const LearnersFrame frame = learners_frame(240, 135);
  const Rig& rig = frame.rig;
  const CameraCalib& cam = frame.cam;
  const RenderOutput& r = frame.r;
  const WarpSource learners_src{r.color, r.depth, r.label, frame.static_depth};
  const WarpSource whole_src{r.color, r.depth, r.label, cv::Mat()};
  const Pose pose = sliders_to_pose(Sliders{40, 50, 50, 55, 50, 50}, rig.camera(0));
  const CameraCalib virt = virtual_camera(cam, pose.cam_to_rig(), NAN);
  WarpParams learners;
  learners.learners_only = true;
  for (const CameraCalib& v : {virt, scale_camera(virt, 120, 68), virt}) {
    WarpedView out;
    ViewWarper().warp(cam, learners_src, v, learners, &out);
  }
  WarpedView here, elsewhere;
  ViewWarper().warp(cam, whole_src, virt, WarpParams(), &here);
  std::thread([&] { ViewWarper().warp(cam, whole_src, virt, WarpParams(), &elsewhere); }).join();
  ASSERT_GT(cv::countNonZero(here.depth), 240 * 135 / 4);
  EXPECT_EQ(cv::norm(here.color, elsewhere.color, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(here.depth, elsewhere.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(here.weight, elsewhere.weight, cv::NORM_INF), 0);
}

// The indices of spans an element passes on (SampleTiles in viewwarp's meta, SparseRows in a prepared frame) are
// checked whole before a span is read: an index that goes back or past the spans, spans out of order or past
// the width, are not taken.
TEST(ViewWarp, MalformedSpanIndicesDoNotFit) {
  SampleTiles tiles;
  tiles.row_first = {0, 1, 2};  // a 16 x 16 view: two rows of tiles
  tiles.spans = {{0, 8}, {8, 16}};
  EXPECT_TRUE(tiles.fit(16, 16));
  tiles.row_first = {0, 100, 2};
  EXPECT_FALSE(tiles.fit(16, 16)) << "an index past the spans";
  tiles.row_first = {0, 2, 1};
  tiles.spans = {{0, 8}, {8, 16}};
  EXPECT_FALSE(tiles.fit(16, 16)) << "an index that goes back";
  tiles.row_first = {0, 2, 2};
  tiles.spans = {{8, 16}, {0, 8}};
  EXPECT_FALSE(tiles.fit(16, 16)) << "spans out of order";
  tiles.spans = {{0, 8}, {8, 17}};
  EXPECT_FALSE(tiles.fit(16, 16)) << "a span past the width";
  SparseRows rows;
  rows.row_begin = 1, rows.row_end = 3, rows.first_pair = 0, rows.end_pair = 4;
  rows.pair_first = {0, 1, 2};
  rows.spans = {{0, 4}, {2, 6}};
  EXPECT_TRUE(rows.fit(8, 4));
  rows.pair_first = {0, 100, 2};
  EXPECT_FALSE(rows.fit(8, 4)) << "an index past the spans";
  rows.pair_first = {0, 1, 2};
  rows.first_pair = 1;
  EXPECT_FALSE(rows.fit(8, 4)) << "pairs start on even rows";
}

TEST(ViewWarp, SkippingWhatCannotLandInTheViewChangesNoPixel) {
  // The warp spends its per-pixel work only on the source columns that can land in the view
  // (WarpParams::cull_outside_view): for views that see all, part or none of the camera, walking, turning and
  // looking up, the picture is the one every column gives, pixel for pixel - and the views that turn away
  // do skip columns (the warper's own account), or the test would prove nothing. Two cameras: one whose
  // size is a whole number of tiles, with clean depth, and one of odd size (a narrower last row and column
  // of tiles, the odd last column's cells) with the sensor's noisy depth, a static layer and labels.
  const Classroom room(ClassroomConfig{3, 6, 2.0});
  const Classroom empty(ClassroomConfig{3, 0, 2.0});
  const Rig rig = default_classroom_rig();
  const CameraCalib clean_cam = scale_camera(rig.camera(2), 320, 180);
  const CameraCalib noisy_cam = scale_camera(rig.camera(1), 331, 185);
  const RenderOutput clean = render(room, 0.7, clean_cam);
  RenderOutput noisy = render(room, 0.7, noisy_cam);
  cv::Mat noisy_depth, noisy_color;
  apply_sensor_model(noisy, noisy_cam, SensorParams(), 3, 7, &noisy_depth, &noisy_color);
  const struct {
    CameraCalib cam;
    WarpSource src;
  } sources[] = {{clean_cam, WarpSource{clean.color, clean.depth, clean.label, cv::Mat()}},
                 {noisy_cam, WarpSource{noisy_color, noisy_depth, noisy.label, render(empty, 0.0, noisy_cam).depth}}};
  WarpParams every_column;
  every_column.cull_outside_view = false;
  // Sliders: x, y, z, yaw, pitch, roll around camera 0 (50 = centre; a step is 2 cm or 1.8 degrees).
  const Sliders poses[] = {{50, 50, 50, 50, 50, 50}, {35, 50, 50, 65, 50, 50}, {50, 50, 50, 80, 50, 50},
                           {60, 45, 60, 30, 40, 50}, {50, 50, 50, 50, 25, 50}, {50, 50, 50, 100, 50, 50},
                           {45, 55, 40, 55, 60, 70}, {50, 50, 50, 0, 50, 50},  {20, 50, 80, 70, 35, 50}};
  for (const auto& [cam, src] : sources) {
    ViewWarper culled_warper, full_warper;
    PreparedSource prepared;
    culled_warper.prepare(cam, src, WarpParams(), &prepared);
    int views_cut = 0;
    for (const Sliders& s : poses) {
      const CameraCalib virt = virtual_camera(scale_camera(rig.camera(0), 320, 180),
                                              sliders_to_pose(s, rig.camera(0)).cam_to_rig(), NAN);
      WarpedView culled, full;
      culled_warper.warp_prepared(cam, src, prepared, virt, WarpParams(), &culled);
      full_warper.warp_prepared(cam, src, prepared, virt, every_column, &full);
      EXPECT_EQ(cv::norm(culled.color, full.color, cv::NORM_INF), 0) << cam.width << " " << format_sliders(s);
      EXPECT_EQ(cv::norm(culled.depth, full.depth, cv::NORM_INF), 0) << cam.width << " " << format_sliders(s);
      EXPECT_EQ(cv::norm(culled.label, full.label, cv::NORM_INF), 0) << cam.width << " " << format_sliders(s);
      EXPECT_EQ(cv::norm(culled.weight, full.weight, cv::NORM_INF), 0) << cam.width << " " << format_sliders(s);
      EXPECT_EQ(full_warper.warped_share(), 1.0);
      views_cut += culled_warper.warped_share() < 0.9;
    }
    EXPECT_GE(views_cut, 4) << cam.width << "x" << cam.height << ": most of these views should skip some of it";
  }
}

TEST(ViewCull, ATileLandsWhereItsPointsLandAndNotWhereNoneOfThemCan) {
  // A 64x32 camera looking at a wall 2 m away: the camera itself sees all of it, a view turned round sees
  // nothing of it (all behind its lens), and a view moved 1 m left sees the tiles on the left (the wall's
  // points there project into it) but not those on the right.
  const CameraCalib cam = pinhole(64, 32, 40);
  std::vector<float> rx(64 * 32), ry(64 * 32);
  for (int v = 0; v < 32; ++v)
    for (int u = 0; u < 64; ++u) rx[size_t(v) * 64 + u] = float((u - cam.cx) / 40), ry[size_t(v) * 64 + u] = float((v - cam.cy) / 40);
  std::vector<float> boxes;
  tile_ray_boxes(64, 32, rx.data(), ry.data(), &boxes);
  ASSERT_EQ(boxes.size(), size_t(4 * 2 * 4));
  const std::vector<uint16_t> depth(64 * 32, 2000);
  std::vector<uint16_t> nearest, farthest;
  tile_depth_ranges(64, 32, depth.data(), &nearest, &farthest);
  EXPECT_EQ(nearest, std::vector<uint16_t>(8, 2000));
  auto columns = [&](const Eigen::Isometry3d& source_to_view) {
    CameraCalib view = cam;  // the source at the rig's origin, the view placed relative to it
    view.cam_to_rig = source_to_view.inverse();
    std::vector<std::pair<int, int>> out;
    columns_in_view(64, 32, boxes, nearest, farthest, frustum_between(cam, view), 0.05f, 0, &out);
    return out;
  };
  using Cols = std::vector<std::pair<int, int>>;
  EXPECT_EQ(columns(Eigen::Isometry3d::Identity()), (Cols{{0, 64}, {0, 64}}));
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_EQ(columns(turned), (Cols{{0, 0}, {0, 0}}));
  // The view 1 m to the left of the camera (x -1 m): a source point X lands at x = 40 (X + 1) / 2 + cx, so
  // the wall's points right of X = 0.575 m (source column 43) land beyond the view's last column; the tile
  // of columns 48..63 (from column 47 with the pixel around it: X from 0.775 m) cannot land, the one of
  // 32..47 can.
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.translation() = Eigen::Vector3d(1.0, 0, 0);
  EXPECT_EQ(columns(moved), (Cols{{0, 48}, {0, 48}}));
  // A tile without depth, the pixel around it included, never lands; with one column of depth beside it,
  // it does (that column's cells reach half a pixel into it).
  std::vector<uint16_t> holes = depth;
  for (int v = 0; v < 32; ++v)
    for (int u = 0; u < 16; ++u) holes[size_t(v) * 64 + u] = 0;
  tile_depth_ranges(64, 32, holes.data(), &nearest, &farthest);
  EXPECT_EQ(nearest[0], 2000);
  for (int v = 0; v < 32; ++v) holes[size_t(v) * 64 + 16] = 0;
  tile_depth_ranges(64, 32, holes.data(), &nearest, &farthest);
  EXPECT_EQ(nearest[0], 0);
  EXPECT_EQ(columns(Eigen::Isometry3d::Identity()), (Cols{{16, 64}, {16, 64}}));
}

TEST(ViewCull, ATilesDepthRangeIsThatOfItsPixelsAndTheRingAroundIt) {
  // Odd sizes (partial tiles at the right and the bottom), random depth with holes, against the definition
  // taken pixel by pixel: the nearest non-zero and the farthest depth over the tile grown by one pixel.
  const int W = 70, H = 37;
  cv::RNG rng(7);
  std::vector<uint16_t> depth(size_t(W) * H);
  for (auto& z : depth) z = rng.uniform(0, 4) == 0 ? 0 : uint16_t(rng.uniform(300, 9000));
  // One tile and its ring without depth at all.
  for (int v = 15; v < 33; ++v)
    for (int u = 15; u < 33; ++u) depth[size_t(v) * W + u] = 0;
  std::vector<uint16_t> nearest, farthest;
  tile_depth_ranges(W, H, depth.data(), &nearest, &farthest);
  const TileGrid g = tile_grid(W, H);
  ASSERT_EQ(nearest.size(), size_t(g.cols) * g.rows);
  for (int ty = 0; ty < g.rows; ++ty)
    for (int tx = 0; tx < g.cols; ++tx) {
      int lo = 0x10000, hi = 0;
      for (int v = std::max(0, ty * kTileSize - 1); v < std::min(H, (ty + 1) * kTileSize + 1); ++v)
        for (int u = std::max(0, tx * kTileSize - 1); u < std::min(W, (tx + 1) * kTileSize + 1); ++u) {
          const int z = depth[size_t(v) * W + u];
          if (z) lo = std::min(lo, z);
          hi = std::max(hi, z);
        }
      const size_t i = size_t(ty) * g.cols + size_t(tx);
      EXPECT_EQ(nearest[i], hi ? lo : 0) << "tile " << tx << ", " << ty;
      EXPECT_EQ(farthest[i], hi) << "tile " << tx << ", " << ty;
    }
  EXPECT_EQ(farthest[size_t(1) * g.cols + 1], 0);  // the tile without depth
}

TEST(ViewWarp, OccluderInFrontIsNeverOverwrittenByTheBackground) {
  const int w = 120, h = 80;
  const CameraCalib src = pinhole(w, h, 100);
  WarpSource in = fronto_plane(w, h, 4000);
  const cv::Rect box(50, 25, 20, 30);
  in.depth(box).setTo(cv::Scalar(1000));
  in.color(box).setTo(cv::Scalar(255, 0, 255));
  for (double dx : {-0.15, 0.15}) {
    CameraCalib virt = src;
    virt.cam_to_rig.translation() = Eigen::Vector3d(dx, 0, 0);
    for (bool mesh : {false, true}) {
      WarpParams p;
      p.mesh = mesh;
      p.boundary_px = 1;
      const WarpedView out = warp_view(src, in, virt, p);
      // The box moves by f * dx / 1 m = 15 px; the background by 3.75 px.
      const int shift = int(std::lround(-100 * dx / 1.0));
      const cv::Rect moved(box.x + shift + 1, box.y + 1, box.width - 2, box.height - 2);
      for (int y = moved.y; y < moved.br().y; ++y)
        for (int x = moved.x; x < moved.br().x; ++x) {
          ASSERT_EQ(out.depth.at<uint16_t>(y, x), 1000) << x << "," << y << " dx " << dx;
          ASSERT_EQ(out.color.at<cv::Vec3b>(y, x), cv::Vec3b(255, 0, 255));
        }
      // No magenta smeared into the disocclusion or onto the background.
      int magenta_on_background = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (out.depth.at<uint16_t>(y, x) > 1000 && out.color.at<cv::Vec3b>(y, x)[1] < 40 &&
              out.color.at<cv::Vec3b>(y, x)[0] > 200 && out.color.at<cv::Vec3b>(y, x)[2] > 200)
            ++magenta_on_background;
      EXPECT_EQ(magenta_on_background, 0);
    }
  }
}

// The far-side pixel next to a depth edge is the object's rim when its
// colour is partly the object's: it moves with the object
// (WarpParams::edge_to_near) instead of staying behind as a ghost contour on
// the revealed background. A pixel that shows only background stays there,
// so a depth map that fattens objects does not fatten them more, and so does
// one whose depth is the static layer's (the room model's).
TEST(ViewWarp, AnObjectsRimMovesWithItAndTheBackgroundStays) {
  const int w = 120, h = 80;
  const CameraCalib src = pinhole(w, h, 100);
  const cv::Rect box(50, 25, 20, 30);
  const cv::Vec3b object(255, 0, 255), background(0, 160, 0), mixed(128, 80, 128);
  CameraCalib virt = src;
  virt.cam_to_rig.translation() = Eigen::Vector3d(0.15, 0, 0);  // the box moves 15 px left, the wall 3.75
  const int y = box.y + box.height / 2, rim_x = box.br().x, rim_with_box = rim_x - 15;
  for (bool rim_shows_object : {true, false}) {
    WarpSource in;
    in.color = cv::Mat(h, w, CV_8UC3, cv::Scalar(background));
    in.depth = cv::Mat(h, w, CV_16UC1, cv::Scalar(4000));
    in.label = cv::Mat::zeros(h, w, CV_8UC1);
    in.color(box).setTo(cv::Scalar(object));
    in.depth(box).setTo(cv::Scalar(1000));
    in.label(box).setTo(cv::Scalar(1));
    in.color(cv::Rect(rim_x, box.y, 1, box.height)).setTo(cv::Scalar(rim_shows_object ? mixed : background));
    for (bool edge_to_near : {true, false}) {
      WarpParams p;
      p.edge_to_near = edge_to_near;
      const WarpedView out = warp_view(src, in, virt, p);
      const bool moved = rim_shows_object && edge_to_near;
      SCOPED_TRACE(std::string(rim_shows_object ? "a mixed rim" : "a background rim") +
                   (edge_to_near ? ", edge_to_near" : ""));
      EXPECT_EQ(cv::countNonZero(out.depth.row(y) == 1000), box.width + (moved ? 1 : 0));
      if (moved) {
        EXPECT_EQ(out.color.at<cv::Vec3b>(y, rim_with_box), mixed);
        EXPECT_EQ(out.label.at<uint8_t>(y, rim_with_box), 1) << "the rim is the learner's";
      }
      // Anything but background on the background: the ghost contour.
      int ghost = 0;
      for (int x = 0; x < w; ++x)
        ghost += out.depth.at<uint16_t>(y, x) > 1000 && cv::norm(out.color.at<cv::Vec3b>(y, x), background) > 40;
      EXPECT_EQ(ghost > 0, rim_shows_object && !edge_to_near);
      // The rows above and below the box show background beside it: they stay.
      EXPECT_EQ(cv::countNonZero(out.depth.row(box.y - 1) == 1000), 0);
    }
    // The room's depth from the static layer (a model's, not a sensor's edge): its rim stays.
    in.static_depth = in.depth.clone();
    const WarpedView layered = warp_view(src, in, virt);
    EXPECT_EQ(cv::countNonZero(layered.depth.row(y) == 1000), box.width);
  }
}

// A slanted plane whose depth comes in steps, as from a sensor that
// measures disparity in quarter pixels, in front of a far wall: no virtual
// pixel inside the plane may show the wall (a see-through crack) or stay
// empty, whichever way the view moves, turns or zooms - alone and fused.
namespace {

struct SteppedPlane {
  // The plane z = z0 + slope * x in the source camera's frame (metres).
  double z0 = 2.0, slope = 0.6;
  double wall_m = 5.0;
  cv::Rect region{40, 20, 120, 80};  // source pixels on the plane
  double disparity_fb = 15.0;        // f * baseline of the sensor (px m)
  double disparity_step = 0.25;      // its resolution (px)

  // The t at which the ray origin + t * dir (in the source camera's frame)
  // meets the plane; NAN when it runs parallel to it.
  double ray_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const {
    // n . P = z0 with n = (-slope, 0, 1).
    const Eigen::Vector3d n(-slope, 0, 1);
    const double den = n.dot(dir);
    return std::abs(den) < 1e-9 ? NAN : (z0 - n.dot(origin)) / den;
  }

  WarpSource render(const CameraCalib& cam) const {
    WarpSource s = fronto_plane(cam.width, cam.height, uint16_t(wall_m * 1000));
    for (int y = region.y; y < region.br().y; ++y)
      for (int x = region.x; x < region.br().x; ++x) {
        const Eigen::Vector3d dir((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1);
        const double z = ray_hit(Eigen::Vector3d::Zero(), dir);  // dir.z = 1: t is z
        const double d = std::round(disparity_fb / z / disparity_step) * disparity_step;
        s.depth.at<uint16_t>(y, x) = uint16_t(std::lround(1000 * disparity_fb / d));
        s.color.at<cv::Vec3b>(y, x) = cv::Vec3b(240, 40, 40);
      }
    return s;
  }

  // The virtual pixels whose ray meets the plane inside `region` of the
  // source camera `src`, `margin` px in from its border, with the plane's
  // depth (mm) along the virtual axis; 0 elsewhere.
  cv::Mat true_depth(const CameraCalib& src, const CameraCalib& virt, int margin) const {
    cv::Mat out(virt.height, virt.width, CV_32FC1, cv::Scalar(0));
    const Eigen::Isometry3d v_to_s = src.cam_to_rig.inverse() * virt.cam_to_rig;
    const cv::Rect inner(region.x + margin, region.y + margin, region.width - 2 * margin, region.height - 2 * margin);
    for (int y = 0; y < virt.height; ++y)
      for (int x = 0; x < virt.width; ++x) {
        const Eigen::Vector3d dir_v((x - virt.cx) / virt.fx, (y - virt.cy) / virt.fy, 1);
        const Eigen::Vector3d o = v_to_s.translation(), dir = v_to_s.linear() * dir_v;
        const double t = ray_hit(o, dir);
        if (!(t > 0)) continue;
        const Eigen::Vector3d p = o + t * dir;
        const double u = src.fx * p.x() / p.z() + src.cx, v = src.fy * p.y() / p.z() + src.cy;
        if (u >= inner.x && u < inner.br().x && v >= inner.y && v < inner.br().y) out.at<float>(y, x) = float(1000 * t);
      }
    return out;
  }
};

// Virtual pixels of the plane (true_depth > 0) whose depth is not the
// plane's: behind it by more than 5 % (the wall shows through) or empty.
int see_through(const cv::Mat& depth, const cv::Mat& truth) {
  int bad = 0;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const float t = truth.at<float>(y, x);
      const int d = depth.at<uint16_t>(y, x);
      if (t > 0 && (d == 0 || d > 1.05 * t)) ++bad;
    }
  return bad;
}

std::vector<CameraCalib> views_of_the_plane(const CameraCalib& src) {
  std::vector<CameraCalib> views;
  for (double dx : {-0.3, 0.3})
    for (double yaw : {-0.2, 0.15})
      for (double f : {1.0, 1.6}) {  // 1.6: the view magnifies, the steps open
        CameraCalib v = src;
        v.fx = v.fy = src.fx * f;
        v.cam_to_rig = Eigen::Translation3d(dx, 0.05, -0.2) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY());
        views.push_back(v);
      }
  return views;
}

}  // namespace

TEST(ViewWarp, ASteppedSlantedPlaneShowsNoCracks) {
  const CameraCalib src = pinhole(200, 120, 150);
  const SteppedPlane plane;
  const WarpSource in = plane.render(src);
  int views = 0;
  for (const CameraCalib& virt : views_of_the_plane(src)) {
    const cv::Mat truth = plane.true_depth(src, virt, 2);
    ASSERT_GT(cv::countNonZero(truth), 2000) << "the plane should fill much of view " << views;
    for (bool coarse : {true, false}) {
      WarpParams p;
      p.boundary_px = 1;
      p.coarse_cells = coarse;
      const WarpedView w = warp_view(src, in, virt, p);
      EXPECT_EQ(see_through(w.depth, truth), 0) << "view " << views << (coarse ? " coarse" : " fine");
    }
    ++views;
  }
}

TEST(ViewFuse, ASteppedSlantedPlaneSeenByTwoCamerasShowsNoCracks) {
  CameraCalib left = pinhole(200, 120, 150), right = left;
  left.cam_to_rig.translation() = Eigen::Vector3d(-0.1, 0, 0);
  right.cam_to_rig.translation() = Eigen::Vector3d(0.1, 0, 0);
  // The same plane in the rig, seen from each camera: z0 and the region
  // move with the camera.
  SteppedPlane from_left, from_right;
  from_left.z0 = 2.0 - 0.6 * 0.1;
  from_right.z0 = 2.0 + 0.6 * 0.1;
  from_left.region = cv::Rect(50, 20, 120, 80);
  from_right.region = cv::Rect(30, 20, 120, 80);
  const WarpSource in_left = from_left.render(left), in_right = from_right.render(right);
  const CameraCalib centre = pinhole(200, 120, 150);
  int views = 0;
  for (const CameraCalib& virt : views_of_the_plane(centre)) {
    // Only where both cameras see the plane.
    cv::Mat truth = from_left.true_depth(left, virt, 2);
    const cv::Mat truth_right = from_right.true_depth(right, virt, 2);
    truth.setTo(0, truth_right == 0);
    ASSERT_GT(cv::countNonZero(truth), 1500) << "view " << views;
    WarpParams p;
    p.boundary_px = 1;
    const WarpedView a = warp_view(left, in_left, virt, p), b = warp_view(right, in_right, virt, p);
    FuseParams fp;
    fp.fill_holes = false;
    FusedView fused;
    fuse_views({&a, &b}, fp, &fused);
    EXPECT_EQ(see_through(fused.depth, truth), 0) << "view " << views;
    ++views;
  }
}

TEST(ViewFuse, NearestSurfaceWinsWhateverTheWeights) {
  WarpedView near_view, far_view;
  for (WarpedView* v : {&near_view, &far_view}) {
    v->color.create(4, 4, CV_8UC3);
    v->depth.create(4, 4, CV_16UC1);
    v->label = cv::Mat::zeros(4, 4, CV_8UC1);
    v->weight.create(4, 4, CV_8UC1);
  }
  near_view.color.setTo(cv::Scalar(200, 0, 0));
  near_view.depth.setTo(cv::Scalar(1000));
  near_view.label.setTo(cv::Scalar(3));
  near_view.weight.setTo(cv::Scalar(5));  // a poor camera
  far_view.color.setTo(cv::Scalar(0, 200, 0));
  far_view.depth.setTo(cv::Scalar(3000));
  far_view.weight.setTo(cv::Scalar(255));
  FusedView f;
  fuse_views({&far_view, &near_view}, FuseParams(), &f);
  EXPECT_EQ(f.color.at<cv::Vec3b>(1, 1), cv::Vec3b(200, 0, 0));
  EXPECT_EQ(f.depth.at<uint16_t>(1, 1), 1000);
  EXPECT_EQ(f.label.at<uint8_t>(1, 1), 3);
  // Two views of one surface blend by weight.
  WarpedView other = near_view;
  other.color = cv::Mat(4, 4, CV_8UC3, cv::Scalar(100, 0, 0));
  other.weight = cv::Mat(4, 4, CV_8UC1, cv::Scalar(5));
  fuse_views({&near_view, &other}, FuseParams(), &f);
  EXPECT_EQ(f.color.at<cv::Vec3b>(1, 1), cv::Vec3b(150, 0, 0));
}

TEST(VirtualView, TheBaseCameraIsTheSourceAtTheNegotiatedSizeAndFieldOfViewWithoutDistortion) {
  CameraCalib src = pinhole(640, 480, 500);
  src.distortion[0] = 0.1;
  src.cam_to_rig.translation() = Eigen::Vector3d(1, 2, 3);
  CameraCalib v = virtual_view_base(src, 320, 240, 0);
  EXPECT_EQ(v.width, 320);
  EXPECT_EQ(v.height, 240);
  EXPECT_NEAR(v.fx, 250, 1e-9);
  EXPECT_EQ(v.distortion[0], 0);
  EXPECT_TRUE(v.cam_to_rig.isApprox(Eigen::Isometry3d::Identity()));
  v = virtual_view_base(src, 0, 0, 90);  // the source's size, 90 degrees across
  EXPECT_EQ(v.width, 640);
  EXPECT_NEAR(v.fx, 320, 1e-9);
  EXPECT_NEAR(v.fy, 320, 1e-9);
  EXPECT_NEAR(virtual_view_base(src, 640, 480, 0).fx, 500, 1e-9);
}

TEST(VirtualView, ATracePosesEachFrameByItsMomentOrItsNumber) {
  std::vector<PoseSample> trace(3);
  for (int i = 0; i < 3; ++i) {
    trace[i].t = 0.5 * i;
    trace[i].pose.position = Eigen::Vector3d(i, 0, 0);
  }
  Pose p = trace_pose_for_frame(trace, 0.6, 0);  // the last sample at or before 0.6 s
  EXPECT_EQ(p.seq, 2u);
  EXPECT_EQ(p.viewer_time_ns, 500'000'000);
  EXPECT_EQ(p.position.x(), 1);
  EXPECT_EQ(trace_pose_for_frame(trace, NAN, 1).seq, 2u);  // no running time: by frame number
  EXPECT_EQ(trace_pose_for_frame(trace, NAN, 10).seq, 3u);  // the last pose held
  EXPECT_EQ(trace_pose_for_frame(trace, 5.0, 0).seq, 3u);
  std::vector<PoseSample> untimed = trace;
  for (auto& s : untimed) s.t = NAN;
  p = trace_pose_for_frame(untimed, 0.6, 2);  // without a t column: by frame number
  EXPECT_EQ(p.seq, 3u);
  EXPECT_EQ(p.viewer_time_ns, -1);
  EXPECT_EQ(trace_pose_in_turn(trace, 0).seq, 1u);
  EXPECT_EQ(trace_pose_in_turn(trace, 7).seq, 3u);
  EXPECT_EQ(trace_pose_in_turn(trace, 7).position.x(), 2);
}

TEST(ViewFuse, LivePairingToleratesPosesTakenCloseTogether) {
  const int64_t ms = 1000000;
  const WarpedPose none, p10{true, 10, 1000 * ms, {}}, p11{true, 11, 1033 * ms, {}}, p13{true, 13, 1100 * ms, {}},
      p11_untimed{true, 11, -1, {}};
  // One pose period apart: fused together.
  EXPECT_EQ(stale_poses({p10, p11, p11}, 50 * ms), (std::vector<bool>{false, false, false}));
  // Without a window only exactly the newest pose counts.
  EXPECT_EQ(stale_poses({p10, p11, p11}, 0), (std::vector<bool>{true, false, false}));
  // 100 ms apart: the older frame is stale, and only it.
  EXPECT_EQ(stale_poses({p10, p11, p13}, 50 * ms), (std::vector<bool>{true, true, false}));
  // No viewer time to compare: only the newest seq is fresh.
  EXPECT_EQ(stale_poses({p10, p11_untimed}, 50 * ms), (std::vector<bool>{true, false}));
  // A frame without a pose is stale beside one with a pose; frames without any are all fine.
  EXPECT_EQ(stale_poses({none, p10}, 50 * ms), (std::vector<bool>{true, false}));
  EXPECT_EQ(stale_poses({none, none}, 50 * ms), (std::vector<bool>{false, false}));
}

// Seqs are ordered within a session only (issue 29): a new lecturer's seq 1 is not older than the last
// lecturer's seq 41. With the steering session known, the other session's frames are the stale ones.
TEST(ViewFuse, PosesOfDifferentSessionsAreNeverComparedBySeq) {
  const int64_t ms = 1000000;
  const WarpedPose a41{true, 41, 1000 * ms, {}, 0xA}, a40{true, 40, 900 * ms, {}, 0xA}, b1{true, 1, 5 * ms, {}, 0xB};
  EXPECT_EQ(stale_poses({a41, b1}, 50 * ms, 0xB), (std::vector<bool>{true, false}));
  EXPECT_EQ(stale_poses({a41, b1}, 50 * ms, 0xA), (std::vector<bool>{false, true}));
  // Not known: neither is stale for the other, but within a session the older still is.
  EXPECT_EQ(stale_poses({a41, b1, a40}, 50 * ms), (std::vector<bool>{false, false, true}));
  // The fused frame names a pose of one session: the oldest within it.
  const OutputStamp stamp = output_stamp({FrameStamp{10, b1}, FrameStamp{10, a41}, FrameStamp{10, a40}});
  EXPECT_EQ(stamp.pose_from, 0);
  const OutputStamp same = output_stamp({FrameStamp{10, a41}, FrameStamp{10, a40}});
  EXPECT_EQ(same.pose_from, 1);
}

TEST(ViewFuse, HolesTakeTheBackgroundNotTheForeground) {
  // Row: foreground (near, red) | hole | background (far, green).
  cv::Mat color(5, 30, CV_8UC3, cv::Scalar(0, 0, 0)), depth(5, 30, CV_16UC1, cv::Scalar(0));
  color.colRange(0, 10).setTo(cv::Scalar(255, 0, 0));
  depth.colRange(0, 10).setTo(cv::Scalar(1000));
  color.colRange(20, 30).setTo(cv::Scalar(0, 255, 0));
  depth.colRange(20, 30).setTo(cv::Scalar(4000));
  cv::Mat filled;
  fill_holes_from_background(color, depth, 0.08, 0, &filled);
  for (int x = 10; x < 20; ++x) {
    EXPECT_EQ(filled.at<uint8_t>(2, x), 255);
    EXPECT_EQ(color.at<cv::Vec3b>(2, x), cv::Vec3b(0, 255, 0)) << x;
    EXPECT_EQ(depth.at<uint16_t>(2, x), 4000);
  }
}

// A hole beside a foreground object, in front of a striped wall: the smooth fill leaves the stripes out,
// the textured fill carries them into the hole from the wall's side (the mirror image across the hole's
// edge), never the foreground's colour.
TEST(ViewFuse, ATexturedFillCarriesTheBackgroundsGrainIntoTheHole) {
  const int w = 64, h = 16;
  cv::Mat wall(h, w, CV_8UC3), depth(h, w, CV_16UC1, cv::Scalar(3000));
  for (int x = 0; x < w; ++x) wall.col(x).setTo(x % 4 < 2 ? cv::Scalar(158, 158, 158) : cv::Scalar(98, 98, 98));
  wall.colRange(10, 20).setTo(cv::Scalar(230, 20, 20));  // the foreground
  depth.colRange(10, 20).setTo(cv::Scalar(1000));
  depth.colRange(20, 30).setTo(cv::Scalar(0));  // what it uncovers
  auto fill = [&](double texture) {
    cv::Mat c = wall.clone(), d = depth.clone();
    fill_holes_from_background(c, d, 0.08, 3, nullptr, texture);
    // Along a row of the hole's far part (the smoothing also reaches over the foreground's edge).
    const cv::Mat row = c(cv::Rect(24, 8, 6, 1));
    std::vector<cv::Mat> ch;
    cv::split(row, ch);
    cv::Scalar mean, sd;
    cv::meanStdDev(ch[1], mean, sd);
    return std::make_tuple(sd[0], cv::mean(ch[0])[0] - mean[0]);  // grain, and how red
  };
  cv::Scalar wall_mean, wall_sd;
  cv::meanStdDev(wall(cv::Rect(32, 8, 8, 1)).reshape(1), wall_mean, wall_sd);
  const auto [smooth_grain, smooth_red] = fill(0);
  const auto [grain, red] = fill(1);
  // (The detail is taken against a 3x3 mean, which holds part of a stripe 2 px wide: about 0.6 of it comes.)
  EXPECT_LT(smooth_grain, 0.2 * wall_sd[0]) << "the smooth fill is flat";
  EXPECT_GT(grain, 0.4 * wall_sd[0]) << "the textured fill carries the stripes";
  EXPECT_LT(std::abs(smooth_red), 10);
  EXPECT_LT(std::abs(red), 10) << "the wall's grey, not the foreground's red";
}

// Issue 35: a hole takes the colour of the side that lies behind, never of the object that caused it, along
// rows and columns, however wide it is, smoothing included. (The fill before issue 35, fill-method=rays, fails
// this: its blur reaches over the object's edge into the hole's first two pixels.)
TEST(HoleFill, AHoleBesideABrightObjectTakesTheWallsColourNotTheObjects) {
  const vctest::HoleBesideAnObject scene;
  cv::Mat color = scene.color.clone(), mask = cv::Mat::zeros(color.size(), CV_8UC1), filled_depth = scene.depth.clone();
  fill_holes(color, scene.depth, HoleFillParams(), mask, &filled_depth);
  {
    int checked = 0;
    for (int y = 0; y < color.rows; ++y)
      for (int x = 0; x < color.cols; ++x) {
        if (!scene.hole.at<uint8_t>(y, x)) {
          EXPECT_EQ(mask.at<uint8_t>(y, x), 0);
          continue;
        }
        ASSERT_EQ(mask.at<uint8_t>(y, x), 255) << "hole pixel " << x << "," << y << " not filled";
        const cv::Vec3b c = color.at<cv::Vec3b>(y, x);
        EXPECT_TRUE(scene.wall_like(c)) << "at " << x << "," << y << ": " << c << ", not the wall's colour";
        EXPECT_GE(filled_depth.at<uint16_t>(y, x), 2900) << "at " << x << "," << y << ": not the wall's depth";
        ++checked;
      }
    EXPECT_EQ(checked, cv::countNonZero(scene.hole));
  }
}

// The fill depends on the image alone: what it keeps between calls (the pyramid's buffers) leaves no trace,
// so a hole that stays put is filled alike frame after frame, whatever was filled in between.
TEST(HoleFill, TheSameViewIsFilledAlikeWhateverCameBefore) {
  const vctest::HoleBesideAnObject scene;
  auto fill = [](const cv::Mat& color_in, const cv::Mat& depth) {
    cv::Mat color = color_in.clone(), mask = cv::Mat::zeros(color.size(), CV_8UC1);
    fill_holes(color, depth, HoleFillParams(), mask);
    return color;
  };
  const cv::Mat first = fill(scene.color, scene.depth);
  // Other views in between: other holes, another size.
  cv::Mat other_depth = scene.depth.clone();
  other_depth(cv::Rect(0, 0, 20, 72)).setTo(0);
  fill(scene.color, other_depth);
  const vctest::HoleBesideAnObject big_scene;
  cv::Mat big_color, big_depth;
  cv::resize(big_scene.color, big_color, cv::Size(), 2, 2, cv::INTER_NEAREST);
  cv::resize(big_scene.depth, big_depth, cv::Size(), 2, 2, cv::INTER_NEAREST);
  fill(big_color, big_depth);
  EXPECT_TRUE(vctest::same_image(first, fill(scene.color, scene.depth)));
}

// Issue 35's fourth round: a hole that stays put while the noise on its border moves the fill by a few grey
// levels keeps most of its last fill (HoleFillHistory); a real change of the border (30 levels) passes whole;
// another background depth, or a cleared history, fills as without one.
TEST(HoleFill, AHoleThatStaysPutKeepsItsFillThroughItsBordersNoiseButNotThroughAChange) {
  const vctest::HoleBesideAnObject scene;
  auto fill = [&](const cv::Mat& color_in, const cv::Mat& depth, HoleFillHistory* history) {
    cv::Mat color = color_in.clone(), mask = cv::Mat::zeros(color.size(), CV_8UC1);
    fill_holes(color, depth, HoleFillParams(), mask, nullptr, history);
    return color;
  };
  // The largest change of a hole pixel's channel between two fills.
  auto largest_change = [&](const cv::Mat& a, const cv::Mat& b) {
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    double most = 0;
    diff.setTo(cv::Scalar::all(0), scene.hole == 0);
    cv::minMaxLoc(diff.reshape(1), nullptr, &most);
    return most;
  };
  HoleFillHistory history;
  const cv::Mat first = fill(scene.color, scene.depth, &history);
  EXPECT_TRUE(vctest::same_image(first, fill(scene.color, scene.depth, nullptr))) << "the first frame as without";
  // The border 4 levels brighter (its noise): without the history the fill moves by about 4.
  cv::Mat noisy = scene.color + cv::Scalar(4, 4, 4);
  noisy.setTo(cv::Scalar(0, 0, 0), scene.hole);
  const cv::Mat plain = fill(noisy, scene.depth, nullptr);
  EXPECT_GE(largest_change(plain, first), 3);
  HoleFillHistory kept = history;
  kept.color = history.color.clone(), kept.depth = history.depth.clone();
  const cv::Mat steady = fill(noisy, scene.depth, &kept);
  EXPECT_LE(largest_change(steady, first), 2) << "the noise passes at a quarter";
  for (int y = 0; y < scene.hole.rows; ++y)
    for (int x = 0; x < scene.hole.cols; ++x)
      if (scene.hole.at<uint8_t>(y, x)) {
        ASSERT_TRUE(scene.wall_like(steady.at<cv::Vec3b>(y, x))) << x << "," << y;
      }
  // A change of 30 levels passes whole.
  cv::Mat changed = scene.color + cv::Scalar(30, 30, 30);
  changed.setTo(cv::Scalar(0, 0, 0), scene.hole);
  HoleFillHistory kept2 = history;
  kept2.color = history.color.clone(), kept2.depth = history.depth.clone();
  EXPECT_TRUE(vctest::same_image(fill(changed, scene.depth, &kept2), fill(changed, scene.depth, nullptr)));
  // The wall 10 % farther back: another background, nothing kept.
  cv::Mat farther = scene.depth.clone();
  farther.setTo(cv::Scalar(3300), farther == 3000);
  HoleFillHistory kept3 = history;
  kept3.color = history.color.clone(), kept3.depth = history.depth.clone();
  EXPECT_TRUE(vctest::same_image(fill(noisy, farther, &kept3), fill(noisy, farther, nullptr)));
  history.clear();
  EXPECT_TRUE(vctest::same_image(fill(noisy, scene.depth, &history), plain)) << "a cleared history keeps nothing";
}

// Issue 35's fourth round: one bright pixel on a wide hole's border (the grain or noise of a single pixel)
// runs on along its row into the hole as a faint streak; deep in the hole the smoothing widens and averages it
// out, next to the border it stays as narrow (the nearest pixels' detail is kept). A fixed 1-px smoothing
// leaves more of it deep in.
TEST(HoleFill, ASinglePixelsGrainDoesNotStreakDeepIntoAWideHole) {
  const int w = 120, h = 60, hole_x0 = 40, hole_x1 = 79, hole_y0 = 20, hole_y1 = 39, row = 30;
  cv::Mat wall(h, w, CV_8UC3, cv::Scalar(50, 50, 50));
  wall.at<cv::Vec3b>(row, hole_x0 - 1) = cv::Vec3b(250, 250, 250);
  cv::Mat depth(h, w, CV_16UC1, cv::Scalar(3000));
  depth(cv::Rect(hole_x0, hole_y0, hole_x1 - hole_x0 + 1, hole_y1 - hole_y0 + 1)).setTo(0);
  auto fill = [&](int smooth_px) {
    cv::Mat color = wall.clone(), mask = cv::Mat::zeros(color.size(), CV_8UC1);
    HoleFillParams p;
    p.smooth_px = smooth_px;
    fill_holes(color, depth, p, mask);
    return color;
  };
  const cv::Mat own = fill(-1), narrow = fill(1);
  const int deep = hole_x0 + 10;  // 11 px from the bright pixel, 10 from the rows above and below
  // (The streak there before any smoothing: about 0.2 of the pixel's 200 levels over the wall.)
  EXPECT_LE(own.at<cv::Vec3b>(row, deep)[0], 61) << "the streak deep in the hole";
  EXPECT_GE(narrow.at<cv::Vec3b>(row, deep)[0], 62) << "(a 1-px smoothing leaves more: the test tells them apart)";
  EXPECT_GE(own.at<cv::Vec3b>(row, hole_x0)[0], 85) << "next to the border the pixel's detail stays";
  EXPECT_EQ(own.at<cv::Vec3b>(row, hole_x0), narrow.at<cv::Vec3b>(row, hole_x0)) << "smoothed alike there";
}

// The fill's history is kept across frames of one rendered view only.
TEST(HoleFill, TheHistoryIsKeptForTheSameRenderedViewOnly) {
  WarpedPose a;
  a.known = a.rendered.known = true;
  a.rendered.position[0] = 0.5f;
  WarpedPose b = a;
  b.seq = 7;  // a later pose event of the same view
  EXPECT_TRUE(same_rendered_view(a, b));
  b.rendered.position[2] = 0.001f;
  EXPECT_FALSE(same_rendered_view(a, b));
  b = a;
  b.rendered.orientation[1] = 0.01f;
  EXPECT_FALSE(same_rendered_view(a, b));
  EXPECT_FALSE(same_rendered_view(a, WarpedPose{})) << "an unknown pose is another view";
  EXPECT_FALSE(same_rendered_view(WarpedPose{}, WarpedPose{}));
}

// A wide hole in one wall whose left part is dark and right part light (both at the wall's depth): the fill
// goes from one shade to the other across it, every row alike (the ray ends weigh by distance, the pyramid
// bridges the middle): no streak of one side's colour drawn over the whole hole, no shade outside the two,
// and the pixels next to each side close to that side. Holds the falloff of the ray ends' weights and the
// pyramid's coarser base (issue 35's second round) to a fill that still follows its border.
TEST(HoleFill, AWideHoleBetweenTwoShadesOfAWallGoesFromOneToTheOther) {
  const int w = 120, h = 60, hole_x0 = 40, hole_x1 = 79;  // a hole 40 px wide, the height of the image
  cv::Mat color(h, w, CV_8UC3, cv::Scalar(60, 60, 60));
  color(cv::Rect(hole_x1 + 1, 0, w - hole_x1 - 1, h)).setTo(cv::Scalar(200, 200, 200));
  cv::Mat depth(h, w, CV_16UC1, cv::Scalar(3000));
  depth(cv::Rect(hole_x0, 0, hole_x1 - hole_x0 + 1, h)).setTo(0);
  cv::Mat mask = cv::Mat::zeros(color.size(), CV_8UC1);
  fill_holes(color, depth, HoleFillParams(), mask);
  for (int y = 0; y < h; ++y) {
    int last = 0;
    for (int x = hole_x0; x <= hole_x1; ++x) {
      ASSERT_EQ(mask.at<uint8_t>(y, x), 255) << x << "," << y;
      const cv::Vec3b c = color.at<cv::Vec3b>(y, x);
      EXPECT_TRUE(c[0] == c[1] && c[1] == c[2]) << "at " << x << "," << y << ": " << c << ", not grey";
      EXPECT_GE(c[0], 60) << x << "," << y;
      EXPECT_LE(c[0], 200) << x << "," << y;
      EXPECT_GE(c[0] + 1, last) << "at " << x << "," << y << ": darker than the pixel left of it";  // rounding
      last = c[0];
    }
    EXPECT_LT(color.at<cv::Vec3b>(y, hole_x0)[0], 90) << "row " << y << ": the first pixel is not the dark side's";
    EXPECT_GT(color.at<cv::Vec3b>(y, hole_x1)[0], 170) << "row " << y << ": the last pixel is not the light side's";
    const int middle = color.at<cv::Vec3b>(y, (hole_x0 + hole_x1) / 2)[0];
    EXPECT_GT(middle, 90) << "row " << y << ": the dark side streaked over the middle";
    EXPECT_LT(middle, 170) << "row " << y << ": the light side streaked over the middle";
    if (y > 0) {
      for (int x = hole_x0; x <= hole_x1; ++x)
        EXPECT_EQ(color.at<cv::Vec3b>(y, x), color.at<cv::Vec3b>(0, x)) << "row " << y << " differs from row 0";
    }
  }
}

// The pyramid's smoothing as defined (HoleFillParams::smooth_px): each filled pixel becomes the mean of the
// pixels of its (2r+1)^2 box that are filled too or lie behind the depth it was filled from (within the
// background ratio), rounded as the fill rounds; never the object in front. Random colours and depths with
// rectangles and speckle of holes, some at the image's edges; narrow boxes, the widest with 16-bit sums (7 px),
// one that needs 32-bit sums (17x17 taps of 255), and the pyramid's own radius by the distance to the border.
TEST(HoleFill, EachFilledPixelIsTheMeanOfWhatLiesBehindItInItsBox) {
  cv::RNG rng(20261127);
  for (int r : {1, 2, 7, 8, -1}) {  // -1: the pyramid's own, 1 px next to the border and 2 px deeper in
    const cv::Size size(150, 90);
    cv::Mat color(size, CV_8UC3), depth(size, CV_16UC1);
    rng.fill(color, cv::RNG::UNIFORM, 0, 256);
    rng.fill(depth, cv::RNG::UNIFORM, 1500, 5000);
    for (int i = 0; i < 6; ++i)
      cv::rectangle(depth, cv::Rect(rng.uniform(-20, size.width), rng.uniform(-10, size.height), rng.uniform(2, 40),
                                    rng.uniform(2, 30)),
                    cv::Scalar(0), cv::FILLED);
    for (int i = 0; i < 200; ++i) depth.at<uint16_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) = 0;
    HoleFillParams p;
    p.smooth_px = 0;
    cv::Mat unsmoothed = color.clone(), mask0 = cv::Mat::zeros(size, CV_8UC1), fill_depth = depth.clone();
    fill_holes(unsmoothed, depth, p, mask0, &fill_depth);
    p.smooth_px = r;
    cv::Mat smoothed = color.clone(), mask = cv::Mat::zeros(size, CV_8UC1);
    fill_holes(smoothed, depth, p, mask);
    ASSERT_EQ(cv::norm(mask, mask0, cv::NORM_INF), 0);
    const float keep = float(1.0 - p.background_ratio);
    int checked = 0;
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        if (!mask.at<uint8_t>(y, x)) continue;
        const int bound = int(std::ceil(keep * float(fill_depth.at<uint16_t>(y, x))));
        int radius = r;
        if (r < 0) {  // the nearest known pixel along the row and the column, less one, within 1..2
          int nearest = 255;
          for (const cv::Point step : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)})
            for (cv::Point q(x, y), k(1, 1); k.x < nearest; ++k.x) {
              q += step;
              if (q.x < 0 || q.y < 0 || q.x >= size.width || q.y >= size.height) break;
              if (depth.at<uint16_t>(q)) {
                nearest = k.x;
                break;
              }
            }
          radius = std::clamp(nearest - 1, 1, 2);
        }
        int sum[3] = {0, 0, 0}, n = 0;
        for (int v = std::max(0, y - radius); v <= std::min(size.height - 1, y + radius); ++v)
          for (int u = std::max(0, x - radius); u <= std::min(size.width - 1, x + radius); ++u) {
            const int d = depth.at<uint16_t>(v, u);
            if (d ? d < bound : !mask.at<uint8_t>(v, u)) continue;  // in front, or a hole left unfilled
            const cv::Vec3b c = unsmoothed.at<cv::Vec3b>(v, u);
            for (int k = 0; k < 3; ++k) sum[k] += c[k];
            ++n;
          }
        ASSERT_GE(n, 1);
        const float inv = 1.0f / float(n);
        for (int k = 0; k < 3; ++k)
          ASSERT_EQ(smoothed.at<cv::Vec3b>(y, x)[k], uint8_t(float(sum[k]) * inv + 0.5f))
              << "radius " << r << " at " << x << "," << y << " channel " << k;
        ++checked;
      }
    EXPECT_GT(checked, 500) << "radius " << r;
  }
}

// Holes left to the caller (viewfuse's fade paints them): untouched, colour, mask and depth; every other pixel
// whose smoothing box (2 px) holds none of them filled as without them, bit for bit.
TEST(HoleFill, HolesLeftToTheCallerChangeNothingElse) {
  cv::RNG rng(20261128);
  const cv::Size size(160, 100);
  cv::Mat color(size, CV_8UC3), depth(size, CV_16UC1);
  rng.fill(color, cv::RNG::UNIFORM, 0, 256);
  rng.fill(depth, cv::RNG::UNIFORM, 1500, 5000);
  depth(cv::Rect(30, 20, 90, 60)).setTo(0);
  for (int i = 0; i < 150; ++i) depth.at<uint16_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) = 0;
  cv::Mat left = cv::Mat::zeros(size, CV_8UC1);
  left(cv::Rect(50, 20, 50, 60)).setTo(255);  // whole columns of the hole: their ends are marked by left pixels only
  for (int i = 0; i < 40; ++i) left.at<uint8_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) = 255;
  left.setTo(0, depth != 0);  // only holes are left
  auto fill = [&](const cv::Mat* leave, cv::Mat* mask, cv::Mat* filled_depth) {
    cv::Mat c = color.clone();
    *mask = cv::Mat::zeros(size, CV_8UC1);
    *filled_depth = depth.clone();
    fill_holes(c, depth, HoleFillParams(), *mask, filled_depth, nullptr, leave);
    return c;
  };
  cv::Mat mask_all, depth_all, mask_left, depth_left;
  const cv::Mat all = fill(nullptr, &mask_all, &depth_all), with_left = fill(&left, &mask_left, &depth_left);
  cv::Mat near_left;
  cv::dilate(left, near_left, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  int compared = 0;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      if (left.at<uint8_t>(y, x)) {
        ASSERT_EQ(with_left.at<cv::Vec3b>(y, x), color.at<cv::Vec3b>(y, x)) << x << "," << y;
        ASSERT_EQ(mask_left.at<uint8_t>(y, x), 0) << x << "," << y;
        ASSERT_EQ(depth_left.at<uint16_t>(y, x), 0) << x << "," << y;
      } else if (!near_left.at<uint8_t>(y, x)) {
        ASSERT_EQ(with_left.at<cv::Vec3b>(y, x), all.at<cv::Vec3b>(y, x)) << x << "," << y;
        ASSERT_EQ(mask_left.at<uint8_t>(y, x), mask_all.at<uint8_t>(y, x)) << x << "," << y;
        ASSERT_EQ(depth_left.at<uint16_t>(y, x), depth_all.at<uint16_t>(y, x)) << x << "," << y;
        compared += mask_all.at<uint8_t>(y, x) != 0;
      }
    }
  EXPECT_GT(compared, 1500);
}

TEST(LearnerSeg, IdsStayStableThroughMotionOcclusionAndReturn) {
  const int w = 160, h = 100;
  const cv::Mat room(h, w, CV_16UC1, cv::Scalar(3000));
  cv::Mat wall(h, w, CV_8UC3, cv::Scalar(180, 180, 170));
  LearnerSegmenter seg;
  seg.set_static_depth(room);
  int id_a = -1, id_b = -1;
  for (int f = 0; f < 30; ++f) {
    cv::Mat color = wall.clone(), depth = room.clone();
    // A walks right; B sits still (wall-coloured clothes) and is hidden for frames 12..19.
    const cv::Rect a(10 + 2 * f, 20, 16, 40), b(120, 30, 18, 40);
    color(a).setTo(cv::Scalar(200, 40, 40));
    depth(a).setTo(cv::Scalar(1500));
    const bool b_visible = f < 12 || f >= 20;
    if (b_visible) {
      color(b).setTo(cv::Scalar(180, 180, 170));  // like the wall: only depth tells it apart
      depth(b).setTo(cv::Scalar(2200));
    }
    cv::Mat label;
    seg.segment(color, depth, &label);
    const int la = label.at<uint8_t>(a.y + a.height / 2, a.x + a.width / 2);
    ASSERT_GT(la, 0) << "frame " << f;
    if (id_a < 0) id_a = la;
    EXPECT_EQ(la, id_a) << "frame " << f;
    const int lb = label.at<uint8_t>(b.y + b.height / 2, b.x + b.width / 2);
    if (b_visible) {
      ASSERT_GT(lb, 0) << "frame " << f;
      if (id_b < 0) id_b = lb;
      EXPECT_EQ(lb, id_b) << "frame " << f << ": B should get its id back";
      EXPECT_NE(lb, id_a);
    } else {
      EXPECT_EQ(lb, 0) << "frame " << f;
    }
  }
}

TEST(LearnerSeg, FindsTheClassroomLearners) {
  const Classroom room(ClassroomConfig{1, 6, 2.0}), empty(ClassroomConfig{1, 0, 2.0});
  const CameraCalib cam = scale_camera(default_classroom_rig().camera(0), 320, 180);
  LearnerSegmenter seg;
  seg.set_static_depth(render(empty, 0.0, cam).depth);
  SegScore s;
  for (int f = 0; f < 3; ++f) {
    const RenderOutput r = render(room, f / 10.0, cam);
    cv::Mat depth, color, label;
    apply_sensor_model(r, cam, SensorParams(), 1, uint64_t(f), &depth, &color);
    seg.segment(color, depth, &label);
    s = score_segmentation(label, r.label);
  }
  EXPECT_GT(s.fg_iou, 0.6);
}

// Without the empty room's depth (server.sh without a model) learnerseg learns the room's depth from what it
// sees: after a few frames of the empty room, the learners who come in stand out in front of it.
TEST(LearnerSeg, WithoutAPriorLearnsTheRoomAndFindsTheLearnersInFrontOfIt) {
  const Classroom room(ClassroomConfig{1, 6, 2.0}), empty(ClassroomConfig{1, 0, 2.0});
  const CameraCalib cam = scale_camera(default_classroom_rig().camera(0), 320, 180);
  LearnerSegmenter seg;
  cv::Mat depth, color, label;
  for (int f = 0; f < 10; ++f) {
    apply_sensor_model(render(empty, f / 10.0, cam), cam, SensorParams(), 1, uint64_t(f), &depth, &color);
    seg.segment(color, depth, &label);
  }
  EXPECT_EQ(cv::countNonZero(label), 0) << "the empty room's own noise taken for learners";
  SegScore s;
  for (int f = 0; f < 3; ++f) {
    const RenderOutput r = render(room, f / 10.0, cam);
    apply_sensor_model(r, cam, SensorParams(), 1, uint64_t(10 + f), &depth, &color);
    seg.segment(color, depth, &label);
    s = score_segmentation(label, r.label);
  }
  EXPECT_GT(s.fg_iou, 0.6);
}

// With a pose trace each frame is warped for the trace's pose at its own
// running time, whatever pose events say and whenever it is processed.
// The background memory: the static room's camera noise is averaged away, a real change shows at once (no
// ghost), learners pass as they are and leave nothing behind.
TEST(BackgroundMemory, AveragesNoiseButShowsChangesAndLearnersAtOnce) {
  BackgroundMemory memory(BackgroundMemoryParams{8, 24});
  cv::RNG rng(5);
  const cv::Mat room(20, 30, CV_8UC3, cv::Scalar(100, 120, 140));
  cv::Mat label = cv::Mat::zeros(room.size(), CV_8UC1);
  label(cv::Rect(0, 0, 5, 20)).setTo(1);  // a learner on the left
  cv::Mat out, prev_in, prev_out;
  double in_change = 0, out_change = 0;
  for (int i = 0; i < 40; ++i) {
    cv::Mat noise(room.size(), CV_16SC3), frame;
    rng.fill(noise, cv::RNG::NORMAL, 0, 4);
    room.convertTo(frame, CV_16SC3);
    frame += noise;
    frame.convertTo(frame, CV_8UC3);
    memory.update(frame, label, &out);
    const cv::Rect still(5, 0, 25, 20);
    if (i >= 10) {
      in_change += cv::norm(frame(still), prev_in(still), cv::NORM_L1);
      out_change += cv::norm(out(still), prev_out(still), cv::NORM_L1);
    }
    EXPECT_TRUE(vctest::same_image(out(cv::Rect(0, 0, 5, 20)), frame(cv::Rect(0, 0, 5, 20)))) << "the learner changed";
    prev_in = frame.clone();
    prev_out = out.clone();
  }
  EXPECT_LT(out_change, in_change * 0.5) << "the noise was not averaged: " << out_change << " vs " << in_change;
  // A chair moved: a change far above the noise is shown as it is, at once.
  cv::Mat moved = room.clone();
  moved(cv::Rect(10, 5, 6, 6)).setTo(cv::Scalar(30, 30, 30));
  memory.update(moved, label, &out);
  EXPECT_EQ(out.at<cv::Vec3b>(7, 12), cv::Vec3b(30, 30, 30));
  // The learner leaves: what was behind them is shown as seen now, nothing of the learner remembered.
  label.setTo(0);
  memory.update(room, label, &out);
  EXPECT_EQ(out.at<cv::Vec3b>(10, 2), cv::Vec3b(100, 120, 140));
  EXPECT_THROW(memory.update(cv::Mat(4, 4, CV_8UC1), cv::Mat(), &out), Error);
  EXPECT_THROW(memory.update(room, cv::Mat::zeros(3, 3, CV_8UC1), &out), Error);
}

// A memory of one frame remembers nothing: every frame is shown as it comes, however far it is from the last
// (the mean's update once got a jump of 210 grey levels right only by a 32-bit product wrapping round).
TEST(BackgroundMemory, AMemoryOfOneFrameShowsEveryFrameAsItComes) {
  BackgroundMemory memory(BackgroundMemoryParams{1, 255});
  const cv::Mat label = cv::Mat::zeros(4, 6, CV_8UC1);
  cv::Mat out, remembered;
  for (const int level : {20, 230, 25, 128, 0, 255}) {
    const cv::Mat frame(label.size(), CV_8UC3, cv::Scalar(level, 255 - level, level / 2));
    memory.update(frame, label, &out, &remembered);
    EXPECT_TRUE(vctest::same_image(out, frame)) << "level " << level;
    EXPECT_TRUE(vctest::same_image(remembered, frame)) << "level " << level;
  }
}

// The room behind a learner: what the memory saw there before the learner
// came, or the empty room it was seeded with; nothing where it never saw the
// room. The layer covers the learner and a margin around it.
TEST(BackgroundMemory, RemembersTheRoomBehindALearner) {
  const cv::Size size(30, 20);
  const cv::Mat static_depth(size, CV_16UC1, cv::Scalar(3000));
  cv::Mat room(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) room.at<cv::Vec3b>(y, x) = ramp_color(3 * x, 3 * y);
  const cv::Rect learner(10, 5, 6, 8);
  cv::Mat with_learner = room.clone();
  with_learner(learner).setTo(cv::Scalar(250, 0, 250));
  cv::Mat label = cv::Mat::zeros(size, CV_8UC1), none = label.clone();
  label(learner).setTo(3);
  cv::Mat out, color, depth;
  // Seen empty for a while, then the learner sits down.
  BackgroundMemory seen;
  seen.update(room, none, &out);
  seen.room_behind_learners(label, static_depth, &color, &depth);
  EXPECT_EQ(cv::countNonZero(depth), 0) << "one frame is not yet the room: it may be a learner's edge";
  for (int i = 1; i < seen.stable_count(); ++i) seen.update(room, none, &out);
  seen.update(with_learner, label, &out);
  EXPECT_TRUE(vctest::same_image(out(learner), with_learner(learner))) << "the learner is shown as seen";
  seen.room_behind_learners(label, static_depth, &color, &depth);
  const int margin = BackgroundMemoryParams().room_margin;
  const cv::Rect layer(learner.x - margin, learner.y - margin, learner.width + 2 * margin,
                       learner.height + 2 * margin);
  EXPECT_EQ(cv::countNonZero(depth), layer.area());
  EXPECT_EQ(cv::countNonZero(depth(layer) != 3000), 0);
  EXPECT_TRUE(vctest::same_image(color(layer), room(layer))) << "the room behind the learner is remembered";
  // Never seen empty: nothing behind the learner is known...
  BackgroundMemory fresh;
  fresh.update(with_learner, label, &out);
  fresh.room_behind_learners(label, static_depth, &color, &depth);
  EXPECT_EQ(cv::countNonZero(depth(learner)), 0);
  // ... unless the memory started from the empty room.
  BackgroundMemory seeded;
  seeded.seed(room);
  seeded.update(with_learner, label, &out);
  seeded.room_behind_learners(label, static_depth, &color, &depth);
  EXPECT_EQ(cv::countNonZero(depth), layer.area());
  EXPECT_TRUE(vctest::same_image(color(learner), room(learner)));
  EXPECT_THROW(seeded.seed(cv::Mat(4, 4, CV_8UC1)), Error);
  EXPECT_THROW(seeded.room_behind_learners(label, cv::Mat(size, CV_8UC1), &color, &depth), Error);
}

// A learner in front of a textured wall, seen from a view moved sideways:
// the wall the learner uncovers shows the remembered wall where it is, not
// a hole, and the remembered wall never covers the learner.
TEST(ViewWarp, WhatALearnerUncoversShowsTheRememberedRoom) {
  const int w = 160, h = 100;
  const CameraCalib src = pinhole(w, h, 120);
  WarpSource in = fronto_plane(w, h, 3000);
  const cv::Mat wall = in.color.clone();
  const cv::Rect learner(60, 20, 30, 60);
  in.depth(learner).setTo(1500);
  in.color(learner).setTo(cv::Scalar(250, 0, 250));
  in.label = cv::Mat::zeros(h, w, CV_8UC1);
  in.label(learner).setTo(1);
  in.static_depth = cv::Mat(h, w, CV_16UC1, cv::Scalar(3000));
  CameraCalib virt = src;
  virt.cam_to_rig.translation() = Eigen::Vector3d(0.25, 0, 0);
  WarpParams p;
  p.boundary_px = 1;
  const WarpedView alone = warp_view(src, in, virt, p);
  BackgroundMemory memory;
  memory.seed(wall);
  memory.apply(&in);
  ASSERT_FALSE(in.room_depth.empty());
  const WarpedView layered = warp_view(src, in, virt, p);
  // The learner moves 20 px, the wall 10 px: 10 columns of wall uncovered
  // right of the learner (minus the edge band).
  int uncovered = 0;
  double max_err = 0;
  for (int y = learner.y + 2; y < learner.br().y - 2; ++y)
    for (int x = learner.br().x - 20 + 1; x < learner.br().x - 10 - 1; ++x) {
      if (alone.weight.at<uint8_t>(y, x) != 0) continue;  // only what the camera does not see now
      ++uncovered;
      ASSERT_GT(layered.weight.at<uint8_t>(y, x), 0) << x << "," << y;
      EXPECT_NEAR(layered.depth.at<uint16_t>(y, x), 3000, 1);
      const cv::Vec3b truth = wall.at<cv::Vec3b>(y, x + 10);  // the wall point seen there
      for (int ch = 0; ch < 3; ++ch)
        max_err = std::max(max_err, std::abs(double(truth[ch]) - layered.color.at<cv::Vec3b>(y, x)[ch]));
    }
  EXPECT_GT(uncovered, 6 * (learner.height - 4));
  EXPECT_LE(max_err, 12.0) << "the uncovered wall is not the remembered wall";
  // The learner stays in front, as without the layer.
  for (int y = learner.y; y < learner.br().y; ++y)
    for (int x = learner.x - 20 + 1; x < learner.br().x - 20 - 1; ++x)
      ASSERT_EQ(layered.depth.at<uint16_t>(y, x), 1500) << x << "," << y;
}

namespace {
constexpr int64_t kMs = 1'000'000;
// Until `n` cameras wait in the barrier (a state to wait for, not a time).
template <typename Waits>
void until_waiting(const Waits& b, int n) {
  while (b.waiting() < n) std::this_thread::yield();
}
}  // namespace

TEST(WarpStart, ACameraWaitsForTheOthersSeenLatelyAndAllGoTogether) {
  WarpStartBarrier b;
  b.set_params(WarpStartParams{60'000 * kMs});  // a wait that never runs out in this test
  int a = 0, c = 0;
  // The first frames: each camera goes as soon as every camera known then has come.
  EXPECT_EQ(b.arrive(&a, 0), WarpStartBarrier::Start::kTogether);
  EXPECT_EQ(b.arrive(&a, 33 * kMs), WarpStartBarrier::Start::kTogether);
  WarpStartBarrier::Start c_start = WarpStartBarrier::Start::kAlone;
  std::thread camera_c([&] { c_start = b.arrive(&c, 40 * kMs); });
  until_waiting(b, 1);  // camera c is known now and waits for camera a's next frame
  EXPECT_EQ(b.arrive(&a, 66 * kMs), WarpStartBarrier::Start::kTogether);
  camera_c.join();
  EXPECT_EQ(c_start, WarpStartBarrier::Start::kTogether);
  // From now on neither goes without the other.
  std::thread camera_a([&] { EXPECT_EQ(b.arrive(&a, 100 * kMs), WarpStartBarrier::Start::kTogether); });
  until_waiting(b, 1);
  EXPECT_EQ(b.arrive(&c, 101 * kMs), WarpStartBarrier::Start::kTogether);
  camera_a.join();
  EXPECT_EQ(b.waiting(), 0);
}

TEST(WarpStart, ACameraThatDoesNotComeHoldsTheOthersOnlyForTheWaitAndIsForgotten) {
  WarpStartBarrier b;
  b.set_params(WarpStartParams{1 * kMs});
  int a = 0, c = 0;
  EXPECT_EQ(b.arrive(&a, 0), WarpStartBarrier::Start::kTogether);
  EXPECT_EQ(b.arrive(&c, 1 * kMs), WarpStartBarrier::Start::kAlone) << "camera a's next frame never came";
  // Camera c stops: camera a waits out the wait, frame after frame...
  EXPECT_EQ(b.arrive(&a, 34 * kMs), WarpStartBarrier::Start::kAlone);
  EXPECT_EQ(b.arrive(&a, 67 * kMs), WarpStartBarrier::Start::kAlone);
  // ... until camera c is forgotten (500 ms without a frame): then it goes at once.
  EXPECT_EQ(b.arrive(&a, 502 * kMs), WarpStartBarrier::Start::kTogether);
  // A camera whose pad goes is forgotten at once.
  EXPECT_EQ(b.arrive(&c, 503 * kMs), WarpStartBarrier::Start::kAlone);
  b.forget(&c);
  EXPECT_EQ(b.arrive(&a, 504 * kMs), WarpStartBarrier::Start::kTogether);
}

TEST(WarpStart, ACameraWaitsTwoThirdsOfTheFrameIntervalAtMost) {
  WarpStartBarrier b;
  b.set_params(WarpStartParams{100 * kMs});
  EXPECT_EQ(b.wait_ns(), 100 * kMs) << "no frame interval known yet";
  int a = 0;
  for (int i = 0; i < 4; ++i) b.arrive(&a, i * 30 * kMs, i * 30 * kMs);
  EXPECT_EQ(b.wait_ns(), 20 * kMs) << "frames 30 ms apart";
  b.set_params(WarpStartParams{10 * kMs});
  EXPECT_EQ(b.wait_ns(), 10 * kMs) << "never more than the longest wait";
  b.forget(&a);
  b.set_params(WarpStartParams{100 * kMs});
  EXPECT_EQ(b.wait_ns(), 100 * kMs) << "a forgotten camera's interval no longer counts";
}

TEST(WarpStart, ForgettingTheLastMissingCameraOrStoppingLetsTheWaitingOnesGo) {
  WarpStartBarrier b;
  b.set_params(WarpStartParams{60'000 * kMs});
  int a = 0, c = 0;
  EXPECT_EQ(b.arrive(&a, 0), WarpStartBarrier::Start::kTogether);
  std::thread camera_c([&] { EXPECT_EQ(b.arrive(&c, 1 * kMs), WarpStartBarrier::Start::kTogether); });
  until_waiting(b, 1);
  b.forget(&a);  // camera a's pad is released: nobody is missing any more
  camera_c.join();
  // Stopping: a camera waiting for another goes, and so does every later one, until the element starts again.
  std::thread camera_a([&] { EXPECT_EQ(b.arrive(&a, 2 * kMs), WarpStartBarrier::Start::kAlone); });
  until_waiting(b, 1);
  b.release();
  camera_a.join();
  EXPECT_EQ(b.arrive(&c, 3 * kMs), WarpStartBarrier::Start::kAlone);
  EXPECT_EQ(b.arrive(&a, 4 * kMs), WarpStartBarrier::Start::kAlone);
  b.resume();  // knows no camera
  EXPECT_EQ(b.arrive(&a, 5 * kMs), WarpStartBarrier::Start::kTogether);
}

TEST(WarpStart, TheCamerasThatGoTogetherShareAGroupAndNoOtherCameraHasIt) {
  WarpStartBarrier b;
  b.set_params(WarpStartParams{60'000 * kMs});
  int a = 0, c = 0;
  uint64_t first = 0, a_group = 0, c_group = 0;
  b.arrive(&a, 0, -1, &first);  // camera a alone is every camera known: it goes
  std::thread camera_c([&] { b.arrive(&c, 1 * kMs, -1, &c_group); });  // waits for camera a's next frame
  until_waiting(b, 1);
  b.arrive(&a, 33 * kMs, -1, &a_group);
  camera_c.join();
  EXPECT_EQ(a_group, c_group) << "one round";
  EXPECT_NE(a_group, first);
  // Off, every camera goes alone, each in a group of its own.
  b.set_params(WarpStartParams{0});
  uint64_t alone1 = 0, alone2 = 0;
  b.arrive(&a, 66 * kMs, -1, &alone1);
  b.arrive(&c, 67 * kMs, -1, &alone2);
  EXPECT_NE(alone1, alone2);
  EXPECT_NE(alone1, a_group);
}

TEST(ViewTurns, AViewsCamerasWarpTogetherWhileAnotherViewWaitsBeforeReadingItsPose) {
  ViewTurns turns;
  turns.set_params(ViewTurnsParams{60'000 * kMs});  // no turn runs out in this test
  turns.begin(1, 10);  // view 1's round 10: camera a
  turns.begin(1, 10);  // camera b of the same round goes too
  EXPECT_EQ(turns.holder(), 1u);
  std::thread view2([&] { turns.begin(2, 20); });
  until_waiting(turns, 1);
  turns.end(1);
  EXPECT_EQ(turns.holder(), 1u) << "one of view 1's warps is still running";
  EXPECT_EQ(turns.waiting(), 1);
  turns.end(1);
  view2.join();
  EXPECT_EQ(turns.holder(), 2u);
  turns.end(2);
  EXPECT_EQ(turns.holder(), 0u);
}

TEST(ViewTurns, ViewsGetTheTurnInTheOrderTheyAskedAndAHolderDoesNotKeepItFromThem) {
  ViewTurns turns;
  turns.set_params(ViewTurnsParams{60'000 * kMs});
  turns.begin(1, 10);
  turns.begin(1, 11);  // view 1's next round while nobody waits: it keeps the turn
  EXPECT_EQ(turns.holder(), 1u);
  std::thread view2([&] { turns.begin(2, 20); });
  until_waiting(turns, 1);
  std::thread view3([&] { turns.begin(3, 30); });
  until_waiting(turns, 2);
  std::thread view1_next([&] { turns.begin(1, 12); });  // others wait: view 1's next round queues behind them
  until_waiting(turns, 3);
  turns.end(1);
  turns.end(1);
  view2.join();
  EXPECT_EQ(turns.holder(), 2u);
  turns.end(2);
  view3.join();
  EXPECT_EQ(turns.holder(), 3u);
  turns.end(3);
  view1_next.join();
  EXPECT_EQ(turns.holder(), 1u);
  EXPECT_EQ(turns.waiting(), 0);
}

TEST(ViewTurns, ATurnHeldTooLongIsTakenAndAGoneOrStoppedViewNeverWaits) {
  ViewTurns turns;
  turns.set_params(ViewTurnsParams{1 * kMs});
  turns.begin(1, 10);  // view 1's frame is lost in its warp: it never ends its turn
  turns.begin(2, 20);  // returns once view 1 held it for 1 ms
  EXPECT_EQ(turns.holder(), 2u);
  turns.end(1);  // view 1's late end does not end view 2's turn
  EXPECT_EQ(turns.holder(), 2u);
  turns.set_params(ViewTurnsParams{60'000 * kMs});
  // A view that leaves: its waiting camera goes at once, and so do its later ones.
  std::thread view3([&] { turns.begin(3, 30); });
  until_waiting(turns, 1);
  turns.forget(3);
  view3.join();
  EXPECT_EQ(turns.holder(), 2u);
  turns.begin(3, 31);
  // Stopping: a waiting camera goes, and so does every later one, until the element starts again.
  std::thread view4([&] { turns.begin(4, 40); });
  until_waiting(turns, 1);
  turns.release();
  view4.join();
  turns.begin(5, 50);
  EXPECT_EQ(turns.holder(), 2u);
  turns.resume();  // nobody holds the turn
  turns.begin(5, 51);
  EXPECT_EQ(turns.holder(), 5u);
  // Off: nobody waits.
  turns.set_params(ViewTurnsParams{0});
  turns.begin(6, 60);
  EXPECT_EQ(turns.holder(), 5u);
}

// viewfuse room-view: the room (the first view, the empty room's, behind the learners everywhere) and the
// warped learners. A learner within the depth tolerance of the room (on a chair, against the wall) keeps its
// own colour, untinted by the room's; a learner behind the room's surface is hidden by it; the room's own
// pixels warped forward (its edges) blend with the looked-up room as any two cameras' samples do.
TEST(ViewFuse, OverTheRoomALearnerNearItKeepsItsColourAndOneBehindItIsHidden) {
  const int W = 16, H = 2;
  WarpedView room{cv::Mat(H, W, CV_8UC3, cv::Scalar(200, 0, 0)), cv::Mat(H, W, CV_16UC1, cv::Scalar(3000)),
                  cv::Mat::zeros(H, W, CV_8UC1), cv::Mat(H, W, CV_8UC1, cv::Scalar(255)), SampleTiles()};
  WarpedView forward{cv::Mat::zeros(H, W, CV_8UC3), cv::Mat::zeros(H, W, CV_16UC1), cv::Mat::zeros(H, W, CV_8UC1),
                     cv::Mat::zeros(H, W, CV_8UC1), SampleTiles()};
  const cv::Range near_learner(0, 4), far_learner(4, 8), room_edge(8, 12);
  forward.color.colRange(near_learner).setTo(cv::Scalar(0, 0, 200));
  forward.depth.colRange(near_learner).setTo(3020);  // within 3 % of the room
  forward.label.colRange(near_learner).setTo(1);
  forward.color.colRange(far_learner).setTo(cv::Scalar(0, 0, 200));
  forward.depth.colRange(far_learner).setTo(3500);
  forward.label.colRange(far_learner).setTo(1);
  forward.color.colRange(room_edge).setTo(cv::Scalar(0, 200, 0));
  forward.depth.colRange(room_edge).setTo(3010);
  forward.weight.colRange(0, 12).setTo(200);
  FuseParams params;
  params.first_is_base = true;
  params.fill_holes = false;
  FusedView out;
  fuse_views({&room, &forward}, params, &out);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const cv::Vec3b c = out.color.at<cv::Vec3b>(y, x);
      if (x < 4) {
        EXPECT_EQ(c, cv::Vec3b(0, 0, 200)) << x;
      } else if (x < 8 || x >= 12) {
        EXPECT_EQ(c, cv::Vec3b(200, 0, 0)) << x;
      } else {
        EXPECT_GT(c[0], 50) << x;
        EXPECT_GT(c[1], 50) << x;
      }
    }
  // Without the room as the base (the blend of any views) the near learner takes some of the room's colour.
  params.first_is_base = false;
  fuse_views({&room, &forward}, params, &out);
  EXPECT_GT(out.color.at<cv::Vec3b>(0, 0)[0], 50);
}

// Over the room, the learners' samples are blended with it over their spans, short gaps between spans and a
// span's rounding to whole vectors with them (where the room alone has a sample its blend is the room), and the
// room is copied elsewhere, or left where it was drawn into the picture's own planes (share_room_planes, as
// viewfuse draws it): the same picture every way, holes filled and all, as the blend of every pixel.
TEST(ViewFuse, OverTheRoomTheSpansGapsAndRunsGiveThePictureOfABlendEverywhere) {
  const int W = 200, H = 3;
  cv::Mat noise(H, W, CV_8UC3);
  cv::randu(noise, 0, 255);
  WarpedView room{noise.clone(), cv::Mat(H, W, CV_16UC1, cv::Scalar(4000)), cv::Mat::zeros(H, W, CV_8UC1),
                  cv::Mat(H, W, CV_8UC1, cv::Scalar(255)), SampleTiles()};
  for (const cv::Range& hole : {cv::Range(100, 103), cv::Range(180, 184)}) {  // nothing seen there
    room.depth.colRange(hole).setTo(0), room.weight.colRange(hole).setTo(0), room.color.colRange(hole).setTo(0);
  }
  WarpedView forward{cv::Mat::zeros(H, W, CV_8UC3), cv::Mat::zeros(H, W, CV_16UC1), cv::Mat::zeros(H, W, CV_8UC1),
                     cv::Mat::zeros(H, W, CV_8UC1), SampleTiles()};
  // Learners' runs 10 px apart (joined) and 40 px apart (not), one of 3 px (rounded up), a long empty stretch.
  for (const cv::Range& run : {cv::Range(5, 20), cv::Range(30, 33), cv::Range(73, 90), cv::Range(150, 153)}) {
    forward.color.colRange(run).setTo(cv::Scalar(0, 0, 200));
    forward.depth.colRange(run).setTo(2000);
    forward.label.colRange(run).setTo(1);
    forward.weight.colRange(run).setTo(200);
  }
  FuseParams params;
  FusedView everywhere;  // every pixel blended: the views fused without the room as their base's copy
  params.first_is_base = true;
  params.fill_holes = true;
  FusedView copied, in_place;
  fuse_views({&room, &forward}, params, &copied);
  WarpedView shared;
  share_room_planes(room.color.size(), &in_place, &shared);
  room.color.copyTo(shared.color);
  room.depth.copyTo(shared.depth);
  room.label.copyTo(shared.label);
  shared.weight = room.weight;
  fuse_views({&shared, &forward}, params, &in_place);
  EXPECT_EQ(in_place.color.data, shared.color.data) << "fused in the room's planes";
  EXPECT_EQ(cv::norm(in_place.color, copied.color, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(in_place.depth, copied.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(in_place.label, copied.label, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(in_place.filled, copied.filled, cv::NORM_INF), 0);
  EXPECT_GT(cv::countNonZero(copied.filled), 0) << "the holes should be filled";
  // The blend of every pixel: a sample at every other pixel of a third view marks every column, far behind the
  // room (hidden: it changes no pixel; none where the room has a hole).
  WarpedView behind{cv::Mat::zeros(H, W, CV_8UC3), cv::Mat::zeros(H, W, CV_16UC1), cv::Mat::zeros(H, W, CV_8UC1),
                    cv::Mat::zeros(H, W, CV_8UC1), SampleTiles()};
  for (int x = 0; x < W; x += 2) {
    if (room.depth.at<uint16_t>(0, x) == 0) continue;
    behind.depth.col(x).setTo(60000), behind.weight.col(x).setTo(1), behind.label.col(x).setTo(3);
  }
  fuse_views({&room, &forward, &behind}, params, &everywhere);
  EXPECT_EQ(cv::norm(everywhere.color, copied.color, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(everywhere.depth, copied.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(everywhere.label, copied.label, cv::NORM_INF), 0);
}
