// Calibrating a classroom's rig (issue 12): the checkerboard found and
// numbered alike by every camera, the rig from the board carried through the
// synthetic classroom against the true rig, and the refusals that tell a
// school what to do. The tool itself runs in test_docs (Tools.*).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/calibration_board.h>
#include <gst/vclassroom/capture/rig_calibration.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/synthetic/board_trace.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

// The board's corners where `cam` sees them when the board is at `pose`.
std::vector<cv::Point2f> projected_corners(const CalibrationBoard& board, const Eigen::Isometry3d& pose,
                                           const CameraCalib& cam) {
  std::vector<cv::Point2f> out;
  for (const auto& p : board.corners()) {
    const auto px = cam.project(cam.cam_to_rig.inverse() * (pose * Eigen::Vector3d(p.x, p.y, p.z)));
    out.emplace_back(float(px->x()), float(px->y()));
  }
  return out;
}

cv::Mat gray_of(const cv::Mat& rgb) {
  cv::Mat g;
  cv::cvtColor(rgb, g, cv::COLOR_RGB2GRAY);
  return g;
}

// What vclassroom-calibrate collects, made here from the library directly:
// the three default cameras at `stops` stops of the board trace, sensor model on.
struct SyntheticCapture {
  CalibrationCapture capture;
  Rig truth = default_classroom_rig();
};

SyntheticCapture capture_trace(int stops, int learners) {
  SyntheticCapture s;
  ClassroomConfig cfg;
  cfg.learners = learners;
  const Classroom room(cfg);
  s.capture.board = trace_board();
  s.capture.cameras = s.truth.cameras;
  ClassroomRenderer renderer;
  RenderOutput frame;
  const SensorParams sensor;
  for (int k = 0; k < stops; ++k) {
    const double t = k * kBoardStopSeconds + 0.5;
    std::vector<std::optional<BoardSighting>> view(3);
    for (int c = 0; c < 3; ++c) {
      const CameraCalib& cam = s.truth.cameras[size_t(c)];
      renderer.render(room, t, cam, &frame);
      draw_board(s.capture.board, board_pose_on_trace(room, t), cam, &frame);
      cv::Mat depth, color;
      apply_sensor_model(frame, cam, sensor, cfg.seed, uint64_t(k), &depth, &color);
      if (k == 0) s.capture.room_depth.push_back(depth.clone());
      if (auto corners = detect_board(gray_of(color), s.capture.board)) {
        BoardSighting sighting;
        sighting.corners = *corners;
        sighting.depth_samples = board_depth_samples(s.capture.board, sighting.corners, depth);
        view[size_t(c)] = std::move(sighting);
      }
    }
    s.capture.views.push_back(std::move(view));
  }
  return s;
}

const SyntheticCapture& trace_capture() {
  static const SyntheticCapture s = capture_trace(14, 3);
  return s;
}

}  // namespace

TEST(CalibrationBoard, FoundToATenthOfAPixelAndNumberedByItsBlackCornerWhicheverWayItIsTurned) {
  const Classroom room(ClassroomConfig{1, 0, 2.0});
  const CameraCalib cam = default_classroom_rig().cameras[0];
  const CalibrationBoard board = trace_board();
  const Eigen::Isometry3d upright = board_pose_on_trace(room, 0.0);
  // The same board turned half a turn about its middle: corner 0 goes to the other end.
  const Eigen::Vector3d middle((board.inner_cols - 1) * board.square_m / 2, (board.inner_rows - 1) * board.square_m / 2, 0);
  const Eigen::Isometry3d turned =
      upright * Eigen::Translation3d(middle) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(-middle);
  for (const auto& pose : {upright, turned}) {
    RenderOutput frame = render(room, 0.0, cam);
    draw_board(board, pose, cam, &frame);
    const auto found = detect_board(gray_of(frame.color), board);
    ASSERT_TRUE(found.has_value());
    const std::vector<cv::Point2f> truth = projected_corners(board, pose, cam);
    double sum = 0, worst = 0;
    for (size_t i = 0; i < truth.size(); ++i) {
      const double e = cv::norm((*found)[i] - truth[i]);
      sum += e;
      worst = std::max(worst, e);
    }
    EXPECT_LT(sum / double(truth.size()), 0.1);
    EXPECT_LT(worst, 0.3);
  }
  // Nothing found where there is no board.
  EXPECT_FALSE(detect_board(gray_of(render(room, 0.0, cam).color), board).has_value());
}

TEST(CalibrationBoard, SizesThatCouldBeNumberedTwoWaysOrMakeNoSenseAreRefused) {
  const CalibrationBoard b = parse_board_size("9x6", 0.08, "--board");
  EXPECT_EQ(b.corner_count(), 54);
  for (const char* bad : {"8x6", "9x", "x6", "9x6x2", "2x3", "65x4", "nine"}) {
    try {
      parse_board_size(bad, 0.08, "--board");
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("board"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parse_board_size("9x6", 0.001, "--board"), Error);
  try {
    parse_board_size("8x6", 0.08, "--board");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("half a turn"), std::string::npos) << e.what();
  }
}

TEST(RigCalibration, TheBoardCarriedThroughTheSyntheticClassroomGivesTheTrueRig) {
  const SyntheticCapture& s = trace_capture();
  const RigCalibrationReport r = calibrate_rig(s.capture, RigCalibrationOptions{});
  ASSERT_EQ(r.rig.cameras.size(), 3u);
  const RigError e = compare_rigs(r.rig, s.truth, 0);
  EXPECT_LE(e.max_position_cm, 1.0);
  EXPECT_LE(e.max_rotation_deg, 0.3);
  EXPECT_LE(e.floor_deg, 0.5);
  EXPECT_NEAR(r.camera_height_m, 2.0, 0.05);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GE(r.views[size_t(c)], 10) << c;
    EXPECT_LT(r.reprojection_px[size_t(c)], 0.3) << c;
    EXPECT_GT(r.depth_plane_mm[size_t(c)], 0) << c;
  }
  for (const auto& p : r.pairs) EXPECT_LT(p.agreement_mm, 5) << p.a << "-" << p.b;
  // The rig file round-trips.
  vctest::TempDir dir;
  save_rig(r.rig, dir / "rig.yaml");
  EXPECT_EQ(load_rig(dir / "rig.yaml").cameras.size(), 3u);
}

TEST(RigCalibration, IntrinsicsFromTheBoardWhereTheDeviceGivesNone) {
  SyntheticCapture s = trace_capture();
  for (auto& c : s.capture.cameras) c.fx = c.fy = c.cx = c.cy = 0;
  const RigCalibrationReport r = calibrate_rig(s.capture, RigCalibrationOptions{});
  for (int c = 0; c < 3; ++c) {
    const CameraCalib& cam = r.rig.cameras[size_t(c)];
    EXPECT_TRUE(r.intrinsics_from_board[size_t(c)]);
    EXPECT_NEAR(cam.fx, 480, 480 * 0.01) << c;
    EXPECT_NEAR(cam.fy, 480, 480 * 0.01) << c;
    EXPECT_NEAR(cam.cx, 479.5, 3) << c;
    EXPECT_NEAR(cam.cy, 269.5, 3) << c;
  }
  const RigError e = compare_rigs(r.rig, s.truth, 0);
  EXPECT_LE(e.max_position_cm, 1.0);
  EXPECT_LE(e.max_rotation_deg, 0.3);
}

TEST(RigCalibration, TheXAxisCanBeGivenWhereNoWallIsSeen) {
  const SyntheticCapture& s = trace_capture();
  RigCalibrationOptions by_camera;
  by_camera.x_axis = XAxisFrom::Camera;
  EXPECT_LE(compare_rigs(calibrate_rig(s.capture, by_camera).rig, s.truth, 0).max_rotation_deg, 0.3);
  // Two points along the front wall, in the reference camera's frame: the
  // default rig's X is the centre camera's x.
  RigCalibrationOptions by_points;
  by_points.x_axis = XAxisFrom::Points;
  by_points.x_from = Eigen::Vector3d(-1, 0, 2);
  by_points.x_to = Eigen::Vector3d(1, 0, 2);
  EXPECT_LE(compare_rigs(calibrate_rig(s.capture, by_points).rig, s.truth, 0).max_rotation_deg, 0.3);
  // Given backwards, X turns round: the rig says what it was told.
  std::swap(by_points.x_from, by_points.x_to);
  EXPECT_GT(compare_rigs(calibrate_rig(s.capture, by_points).rig, s.truth, 0).max_rotation_deg, 170);
  // No depth at all: no floor, and the message says what the cameras must see.
  SyntheticCapture blind = s;
  for (auto& d : blind.capture.room_depth) d.setTo(0);
  try {
    calibrate_rig(blind.capture, RigCalibrationOptions{});
    ADD_FAILURE() << "calibrated without a floor";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("floor"), std::string::npos) << e.what();
  }
}

TEST(RigCalibration, TooFewOrUnsharedViewsAreRefusedNamingTheCamera) {
  SyntheticCapture s = trace_capture();
  // Camera 2 sees the board only where nobody else does.
  SyntheticCapture lonely = s;
  for (const auto& v : s.capture.views) {
    if (!v[2]) continue;
    lonely.capture.views.push_back({std::nullopt, std::nullopt, v[2]});
  }
  for (size_t i = 0; i < s.capture.views.size(); ++i) lonely.capture.views[i][2].reset();
  try {
    calibrate_rig(lonely.capture, RigCalibrationOptions{});
    ADD_FAILURE() << "calibrated a camera that shares no view";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no view"), std::string::npos) << e.what();
  }
  // Camera 1 shares only three.
  int kept = 0;
  for (auto& v : s.capture.views)
    if (v[1] && ++kept > 3) v[1].reset();
  try {
    calibrate_rig(s.capture, RigCalibrationOptions{});
    ADD_FAILURE() << "calibrated from three views";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("only 3 views"), std::string::npos) << e.what();
  }
}

TEST(RigCalibration, RgbdTestSrcCarriesTheBoardThroughTheElement) {
  // The board rgbdtestsrc draws is the one the trace says, at the same instant, through GStreamer.
  GstElement* p = gst_parse_launch(
      "rgbdtestsrc camera-id=1 calibration-board=true learners=0 framerate=5/1 num-buffers=1 ! appsink name=out",
      nullptr);
  ASSERT_NE(p, nullptr);
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  cv::Mat color;
  {
    vctest::SampleCollector collected(out);
    ASSERT_EQ(vctest::run_pipeline(p).error, "");
    ASSERT_EQ(collected.size(), 1u);
    RgbdInfo info;
    std::string err;
    ASSERT_TRUE(rgbd_info_from_caps(collected.caps(0), &info, &err)) << err;
    RgbdFrame frame;
    ASSERT_TRUE(frame.map(collected.buffer(0), info, GST_MAP_READ, &err)) << err;
    color = frame.color().clone();
  }
  gst_object_unref(out);
  gst_object_unref(p);
  const CameraCalib cam = default_classroom_rig().cameras[1];
  const auto found = detect_board(gray_of(color), trace_board());
  ASSERT_TRUE(found.has_value());
  const std::vector<cv::Point2f> truth =
      projected_corners(trace_board(), board_pose_on_trace(Classroom(ClassroomConfig{1, 0, 2.0}), 0.0), cam);
  EXPECT_LT(cv::norm((*found)[0] - truth[0]), 0.5);
  EXPECT_LT(cv::norm(found->back() - truth.back()), 0.5);
}
