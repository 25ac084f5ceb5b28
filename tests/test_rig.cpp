// Rig files: good ones load, each kind of bad one fails naming file, camera and
// field; projection helpers agree with the geometry.
#include <gtest/gtest.h>

#include <random>

#include <gst/vclassroom/core/rig.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

const char* kGoodRig = R"(# two cameras, hand-written (no %YAML header)
name: lab
cameras:
  - id: 0
    width: 640
    height: 480
    fx: 500
    fy: 500
    cx: 319.5
    cy: 239.5
    rotation: [1, 0, 0, 0, -1, 0, 0, 0, -1]
    translation: [0, 0, 0]
  - id: 1
    width: 640
    height: 480
    fx: 510.5
    fy: 509.25
    cx: 320
    cy: 240
    distortion: [0.1, -0.05, 0.001, 0.002, 0.01]
    depth_scale: 0.2
    rotation: [1, 0, 0, 0, -1, 0, 0, 0, -1]
    translation: [0.8, 0, 0]
    depth_to_color:
      rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1]
      translation: [-0.032, 0, 0]
)";

std::string replace_once(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

// Loads `text` as a rig file and returns the error message ("" if it loaded).
std::string load_error(const vctest::TempDir& dir, const std::string& text) {
  const std::string path = dir / "rig.yaml";
  vctest::write_text(path, text);
  try {
    load_rig(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Rig, HandWrittenRigLoads) {
  vctest::TempDir dir;
  vctest::write_text(dir / "rig.yaml", kGoodRig);
  Rig rig = load_rig(dir / "rig.yaml");
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.name, "lab");
  const CameraCalib& c1 = rig.camera(1);
  EXPECT_DOUBLE_EQ(c1.fx, 510.5);
  EXPECT_DOUBLE_EQ(c1.fy, 509.25);
  EXPECT_DOUBLE_EQ(c1.distortion[4], 0.01);
  EXPECT_DOUBLE_EQ(c1.depth_scale, 0.2);
  EXPECT_DOUBLE_EQ(rig.camera(0).depth_scale, 1.0);  // default
  EXPECT_DOUBLE_EQ(c1.center_in_rig().x(), 0.8);
  ASSERT_TRUE(c1.depth_to_color.has_value());
  EXPECT_DOUBLE_EQ(c1.depth_to_color->translation().x(), -0.032);
  EXPECT_FALSE(rig.camera(0).depth_to_color.has_value());
}

TEST(Rig, SaveLoadRoundTripIsExact) {
  vctest::TempDir dir;
  Rig rig = vctest::make_rig(4, 960, 540);
  rig.cameras[2].cam_to_rig.linear() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  rig.cameras[2].distortion = {0.11, -0.021, 0.0013, -0.0007, 0.004};
  rig.cameras[3].fx = 1234.5678901234567;
  rig.cameras[1].depth_to_color = Eigen::Isometry3d(Eigen::Translation3d(0.03, 0.001, -0.002));
  rig.cameras[1].depth_lens = CameraCalib::DepthLens{640, 480, 385.25, 386.5, 319.5, 241.125};
  save_rig(rig, dir / "rig.yaml");
  Rig back = load_rig(dir / "rig.yaml");
  ASSERT_EQ(back.cameras.size(), rig.cameras.size());
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto &a = rig.cameras[i], &b = back.cameras[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.fx, b.fx);
    EXPECT_EQ(a.cy, b.cy);
    EXPECT_EQ(a.distortion, b.distortion);
    EXPECT_TRUE(a.cam_to_rig.matrix() == b.cam_to_rig.matrix()) << "camera " << i;
    EXPECT_EQ(a.depth_to_color.has_value(), b.depth_to_color.has_value());
    ASSERT_EQ(a.depth_lens.has_value(), b.depth_lens.has_value()) << "camera " << i;
    if (a.depth_lens) {
      EXPECT_EQ(a.depth_lens->width, b.depth_lens->width);
      EXPECT_EQ(a.depth_lens->fy, b.depth_lens->fy);
      EXPECT_EQ(a.depth_lens->cy, b.depth_lens->cy);
    }
  }
  // The depth lens as a camera of its own: its intrinsics, posed at cam_to_rig * depth_to_color.
  const CameraCalib depth = depth_sensor_of(back.cameras[1]);
  EXPECT_EQ(depth.width, 640);
  EXPECT_EQ(depth.fx, 385.25);
  EXPECT_TRUE(depth.center_in_rig().isApprox(back.cameras[1].cam_to_rig * Eigen::Vector3d(0.03, 0.001, -0.002)));
  EXPECT_FALSE(depth.depth_to_color.has_value());
}

struct BadRigCase {
  const char* what;
  std::string from, to;
  std::vector<std::string> message_parts;
};

TEST(Rig, EachKindOfBadRigFailsWithItsMessage) {
  vctest::TempDir dir;
  const std::string file = dir / "rig.yaml";
  const std::vector<BadRigCase> cases = {
      {"missing field", "    fy: 509.25\n", "", {file, "camera 1", "'fy'", "missing"}},
      {"zero focal", "    fx: 500\n", "    fx: 0\n", {file, "camera 0", "'fx'", "> 0"}},
      {"negative focal", "    fy: 509.25\n", "    fy: -3\n", {file, "camera 1", "'fy'"}},
      {"not a number", "    cx: 320\n", "    cx: left\n", {file, "camera 1", "'cx'", "number"}},
      {"non-orthonormal rotation", "    rotation: [1, 0, 0, 0, -1, 0, 0, 0, -1]\n    translation: [0.8",
       "    rotation: [1, 0.2, 0, 0, -1, 0, 0, 0, -1]\n    translation: [0.8",
       {file, "camera 1", "'rotation'", "orthonormal"}},
      {"reflection", "    rotation: [1, 0, 0, 0, -1, 0, 0, 0, -1]\n    translation: [0, 0, 0]",
       "    rotation: [1, 0, 0, 0, 1, 0, 0, 0, -1]\n    translation: [0, 0, 0]", {file, "camera 0", "'rotation'"}},
      {"short translation", "translation: [0.8, 0, 0]", "translation: [0.8, 0]",
       {file, "camera 1", "'translation'", "3 numbers"}},
      {"zero width", "    width: 640\n    height: 480\n    fx: 500", "    width: 0\n    height: 480\n    fx: 500",
       {file, "camera 0", "'width'"}},
      {"duplicate id", "  - id: 1\n", "  - id: 0\n", {file, "camera 1", "'id'", "duplicate"}},
      {"bad depth scale", "depth_scale: 0.2", "depth_scale: 0", {file, "camera 1", "'depth_scale'"}},
      {"bad distortion", "distortion: [0.1, -0.05, 0.001, 0.002, 0.01]", "distortion: [0.1, -0.05]",
       {file, "camera 1", "'distortion'", "5 numbers"}},
      {"bad depth_to_color", "      rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1]", "      rotation: [2, 0, 0, 0, 1, 0, 0, 0, 1]",
       {file, "camera 1", "depth_to_color", "'rotation'"}},
      {"depth lens without its focal length", "      translation: [-0.032, 0, 0]\n",
       "      translation: [-0.032, 0, 0]\n      width: 640\n      height: 480\n      fy: 385\n      cx: 319.5\n"
       "      cy: 239.5\n",
       {file, "camera 1", "depth_to_color", "'fx'", "missing"}},
      {"depth lens of no width", "      translation: [-0.032, 0, 0]\n",
       "      translation: [-0.032, 0, 0]\n      width: 0\n      height: 480\n      fx: 385\n      fy: 385\n"
       "      cx: 319.5\n      cy: 239.5\n",
       {file, "camera 1", "depth_to_color", "'width'"}},
  };
  for (const auto& c : cases) {
    const std::string msg = load_error(dir, replace_once(kGoodRig, c.from, c.to));
    ASSERT_FALSE(msg.empty()) << c.what << ": a bad rig loaded";
    for (const auto& part : c.message_parts)
      EXPECT_NE(msg.find(part), std::string::npos) << c.what << ": '" << msg << "' lacks '" << part << "'";
  }
}

TEST(Rig, CameraCountMustBeOneToEight) {
  vctest::TempDir dir;
  std::string msg = load_error(dir, "name: empty\ncameras: []\n");
  EXPECT_NE(msg.find("no cameras"), std::string::npos) << msg;
  EXPECT_NE(msg.find(dir / "rig.yaml"), std::string::npos) << msg;
  msg = load_error(dir, "name: none\n");
  EXPECT_NE(msg.find("'cameras'"), std::string::npos) << msg;

  EXPECT_THROW(save_rig(vctest::make_rig(9), dir / "nine.yaml"), Error);
  std::string nine = "cameras:\n";
  for (int i = 0; i < 9; ++i)
    nine += "  - {id: " + std::to_string(i) +
            ", width: 64, height: 48, fx: 50, fy: 50, cx: 32, cy: 24, rotation: [1,0,0,0,1,0,0,0,1], "
            "translation: [0,0,0]}\n";
  msg = load_error(dir, nine);
  EXPECT_NE(msg.find("9 cameras (expected 1 to 8)"), std::string::npos) << msg;
  save_rig(vctest::make_rig(8), dir / "eight.yaml");
  EXPECT_EQ(load_rig(dir / "eight.yaml").cameras.size(), 8u);
}

TEST(Rig, MissingAndMalformedFilesFailClearly) {
  vctest::TempDir dir;
  try {
    load_rig(dir / "nope.yaml");
    FAIL() << "a missing rig loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nope.yaml"), std::string::npos);
  }
  const std::string msg = load_error(dir, "cameras: [ {id: 0, width: 3\n");
  EXPECT_NE(msg.find("not a valid rig YAML"), std::string::npos) << msg;
}

TEST(Rig, UnknownCameraIdNamesTheIds) {
  Rig rig = vctest::make_rig(3);
  try {
    rig.camera(7);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no camera with id 7 (ids: 0 1 2)"), std::string::npos) << e.what();
  }
}

// A point seen by camera i at (u, v) with depth z, unprojected and carried into
// camera j, must land where camera j sees that point directly.
TEST(Rig, UnprojectInOneCameraProjectsWhereTheOtherSeesThePoint) {
  Rig rig = vctest::make_rig(2, 640, 480);
  rig.cameras[0].cam_to_rig.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  rig.cameras[1].cam_to_rig.linear() = Eigen::AngleAxisd(-0.25, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                                       Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()).toRotationMatrix();
  rig.cameras[1].cam_to_rig.translation() = Eigen::Vector3d(0.8, 0.02, -0.1);
  rig.cameras[1].distortion = {0.08, -0.02, 0.001, -0.0015, 0.003};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> X(-1.5, 1.5), Y(-1, 1), Z(1.5, 6);
  int checked = 0;
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d p_rig(X(rng), Y(rng), Z(rng));
    const Eigen::Vector3d p0 = rig.cameras[0].cam_to_rig.inverse() * p_rig;
    const Eigen::Vector3d p1 = rig.cameras[1].cam_to_rig.inverse() * p_rig;
    auto uv0 = rig.cameras[0].project(p0);
    auto uv1 = rig.cameras[1].project(p1);
    if (!uv0 || !uv1) continue;
    const Eigen::Vector3d back = rig.cameras[0].unproject(uv0->x(), uv0->y(), p0.z());
    EXPECT_LT((back - p0).norm(), 1e-9);
    auto uv01 = rig.cameras[1].project(rig.transform(0, 1) * back);
    ASSERT_TRUE(uv01.has_value());
    EXPECT_LT((*uv01 - *uv1).norm(), 1e-6);
    // And back again, through the distorted camera.
    const Eigen::Vector3d back1 = rig.cameras[1].unproject(uv1->x(), uv1->y(), p1.z());
    EXPECT_LT((back1 - p1).norm(), 1e-6);
    ++checked;
  }
  EXPECT_GT(checked, 1000);
  // Behind the camera projects nowhere.
  EXPECT_FALSE(rig.cameras[0].project(Eigen::Vector3d(0, 0, -1)).has_value());
}

// Two rectified cameras 0.1 m apart: a point at depth z shifts by f*B/z pixels.
TEST(Rig, SidewaysCamerasShiftByTheDisparity) {
  Rig rig = vctest::make_rig(2, 640, 480);
  const CameraCalib& c0 = rig.camera(0);
  const double z = 2.5;
  auto uv = rig.camera(1).project(rig.transform(0, 1) * c0.unproject(300, 200, z));
  ASSERT_TRUE(uv.has_value());
  EXPECT_NEAR(uv->x(), 300 - c0.fx * 0.1 / z, 1e-9);
  EXPECT_NEAR(uv->y(), 200, 1e-9);
}

// Issue 14/17: hostile rig files are refused with the project's error (never an
// abort, a hang or a silently truncated number), and syntax errors name the line.
TEST(Rig, HostileFilesFailWithAnErrorNotAnAbort) {
  vctest::TempDir dir;
  // Each aborted the process through OpenCV's reader (a cv::Exception escaped).
  for (const std::string text : {"-\n", " i:0\n :\n", "\xff\xfe\x00x", "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]",
                                 "a: &x [1]\nb: *x\n", "cameras: [*a]\n", "name: x\nname: y\n"}) {
    std::string msg;
    EXPECT_NO_THROW(msg = load_error(dir, text)) << text;
    EXPECT_FALSE(msg.empty()) << "loaded: " << text;
    EXPECT_NE(msg.find(dir / "rig.yaml"), std::string::npos) << msg;
  }
  EXPECT_NE(load_error(dir, "-\n").find("expected a mapping"), std::string::npos);
  EXPECT_NE(load_error(dir, "a: &x [1]\nb: *x\n").find("not supported"), std::string::npos);
  // Far larger than any rig: refused before parsing.
  EXPECT_NE(load_error(dir, std::string(2 << 20, '#')).find("larger than"), std::string::npos);
}

TEST(Rig, IntegersAreRangeCheckedBeforeConversion) {
  vctest::TempDir dir;
  const std::string msg = load_error(dir, replace_once(kGoodRig, "    width: 640\n    height: 480\n    fx: 500",
                                                         "    width: 4294967552\n    height: 480\n    fx: 500"));
  // 4294967552 is 2^32 + 256: it must never become a 256-pixel-wide camera.
  EXPECT_NE(msg.find("'width'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("out of range"), std::string::npos) << msg;
  EXPECT_NE(msg.find("camera 0"), std::string::npos) << msg;
  EXPECT_NE(load_error(dir, replace_once(kGoodRig, "  - id: 1\n", "  - id: 1.5\n")).find("expected an integer"),
            std::string::npos);
}

TEST(Rig, ErrorsNameTheLine) {
  vctest::TempDir dir;
  const std::string file = dir / "rig.yaml";
  // fx of camera 1 is on line 16 of kGoodRig (the comment is line 1).
  std::string msg = load_error(dir, replace_once(kGoodRig, "    fx: 510.5\n", "    fx: -1\n"));
  EXPECT_NE(msg.find(file + ":16: camera 1 (id 1): field 'fx'"), std::string::npos) << msg;
  // A syntax error: line and column, not an OpenCV function.
  msg = load_error(dir, "name: lab\ncameras:\n  - id: 0\n   width: [3\n");
  EXPECT_NE(msg.find(file + ":"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not a valid rig YAML"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("cv::"), std::string::npos) << msg;
  // A missing field names the line where its camera starts.
  msg = load_error(dir, replace_once(kGoodRig, "    cy: 240\n", ""));
  EXPECT_NE(msg.find(file + ":13: camera 1 (id 1): field 'cy': missing"), std::string::npos) << msg;
}

TEST(Rig, ReadsFilesOpenCvWrote) {
  // Rig files written by earlier versions (OpenCV's FileStorage) keep loading.
  vctest::TempDir dir;
  const char* opencv_written = "%YAML:1.0\n---\n# gst-vclassroom rig\nrig_version: 1\nname: \"lab\"\ncameras:\n"
                               "   -\n      id: 0\n      name: \"\"\n      width: 64\n      height: 48\n"
                               "      fx: 5.0000000000000000e+01\n      fy: 50.\n      cx: 3.1500000000000000e+01\n"
                               "      cy: 2.3500000000000000e+01\n      distortion: [ 0., 0., 0., 0., 0. ]\n"
                               "      depth_scale: 1.\n      rotation: [ 1., 0., 0., 0., -1., 0., 0., 0., -1. ]\n"
                               "      translation: [ 0., 0., 0. ]\n";
  vctest::write_text(dir / "rig.yaml", opencv_written);
  Rig rig = load_rig(dir / "rig.yaml");
  ASSERT_EQ(rig.cameras.size(), 1u);
  EXPECT_EQ(rig.name, "lab");
  EXPECT_EQ(rig.cameras[0].width, 64);
  EXPECT_EQ(rig.cameras[0].fy, 50.0);
  EXPECT_EQ(rig.cameras[0].cx, 31.5);
}

TEST(Rig, SavedTextRoundTripsOddNamesAndNumbers) {
  Rig rig = vctest::make_rig(2, 64, 48);
  rig.name = "room \"7\": a\\b\n#x";
  rig.cameras[0].name = "- [weird] {name}";
  rig.cameras[0].cx = -0.0;
  rig.cameras[1].fx = 100.0 / 3.0;
  rig.cameras[1].cy = 0.1 + 0.2;
  Rig back = parse_rig_text(rig_to_text(rig), "mem");
  EXPECT_EQ(back.name, rig.name);
  EXPECT_EQ(back.cameras[0].name, rig.cameras[0].name);
  EXPECT_TRUE(std::signbit(back.cameras[0].cx));
  EXPECT_EQ(back.cameras[1].fx, rig.cameras[1].fx);
  EXPECT_EQ(back.cameras[1].cy, rig.cameras[1].cy);
}

// Issue 14: a valid rig made rgbdtestsrc spin at full CPU for minutes — a
// 16384x16384 camera costs about 4 GB and tens of seconds per synthetic frame.
// The element now stops at once with a bus error naming the camera's size.
TEST(RigThroughElements, HugeCameraStopsRgbdTestSrcWithAnError) {
  vctest::TempDir dir;
  Rig rig = vctest::make_rig(1, 64, 48);
  rig.cameras[0] = scale_camera(rig.cameras[0], 16384, 16384);
  save_rig(rig, dir / "huge.yaml");
  // 30 s: far beyond what the refusal takes, far below the minutes the old code spun.
  const vctest::RunResult r = vctest::run_launch(
      "rgbdtestsrc rig=" + (dir / "huge.yaml") + " camera-id=0 num-buffers=3 ! fakesink", 30 * GST_SECOND);
  EXPECT_NE(r.error, "timeout");
  EXPECT_NE(r.error.find("16384x16384"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("at most"), std::string::npos) << r.error;
}

TEST(RigThroughElements, ExtremeIntrinsicsRenderWithoutError) {
  // Focal lengths and principal points at the edges of the plausible ranges
  // (docs/rig-format.md) render without error instead of overflowing.
  vctest::TempDir dir;
  Rig rig = vctest::make_rig(2, 64, 48);
  rig.cameras[0].fx = rig.cameras[0].fy = kMinFocalPerSide * 64;
  rig.cameras[1].fx = rig.cameras[1].fy = kMaxFocalPerSide * 64;
  rig.cameras[1].cx = -0.5;
  rig.cameras[1].cy = 47.5;
  save_rig(rig, dir / "extreme.yaml");
  for (int id : {0, 1}) {
    const vctest::RunResult r = vctest::run_launch("rgbdtestsrc rig=" + (dir / "extreme.yaml") + " camera-id=" +
                                                   std::to_string(id) + " num-buffers=2 ! fakesink", 30 * GST_SECOND);
    EXPECT_EQ(r.error, "") << "camera " << id;
  }
}

// Issue 29: a focal length of 1e-300 px was accepted (finite and > 0) and
// sent every projection to infinity. Intrinsics outside the plausible ranges
// are an Error naming the file, the camera, the field and the range.
TEST(Rig, ImplausibleIntrinsicsAreErrorsNamingTheFieldAndTheRange) {
  vctest::TempDir dir;
  const std::string file = dir / "rig.yaml";
  const std::vector<BadRigCase> cases = {
      {"vanishing focal", "    fx: 500\n", "    fx: 1e-300\n", {file, "camera 0", "'fx'", "1e-300", "implausible", "32..64000"}},
      {"huge focal", "    fy: 509.25\n", "    fy: 1e300\n", {file, "camera 1", "'fy'", "implausible"}},
      {"centre left of the image", "    cx: 320\n", "    cx: -40\n", {file, "camera 1", "'cx'", "outside the image"}},
      {"centre below the image", "    cy: 240\n", "    cy: 480\n", {file, "camera 1", "'cy'", "-0.5..479.5"}},
      {"depth lens of a vanishing focal", "      translation: [-0.032, 0, 0]\n",
       "      translation: [-0.032, 0, 0]\n      width: 640\n      height: 480\n      fx: 1e-300\n      fy: 385\n"
       "      cx: 319.5\n      cy: 239.5\n",
       {file, "camera 1", "depth_to_color", "'fx'", "implausible"}},
  };
  for (const auto& c : cases) {
    const std::string msg = load_error(dir, replace_once(kGoodRig, c.from, c.to));
    ASSERT_FALSE(msg.empty()) << c.what << ": an implausible rig loaded";
    for (const auto& part : c.message_parts)
      EXPECT_NE(msg.find(part), std::string::npos) << c.what << ": '" << msg << "' lacks '" << part << "'";
  }
  // The edges of the ranges are plausible.
  EXPECT_EQ(load_error(dir, replace_once(replace_once(kGoodRig, "    fx: 500\n", "    fx: 32\n"), "    cx: 320\n",
                                         "    cx: 639.5\n")),
            "");
}
