// Recorded datasets: rgbdfilesrc/rgbdfilesink, the Middlebury importer (whose
// rig must predict where real pixels land) and bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <fstream>

#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/datasets/middlebury.h>
#include <gst/vclassroom/datasets/posed_sequence.h>
#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>
#include <gst/vclassroom/core/rgbd.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_util.h"

namespace fs = std::filesystem;
using namespace vclassroom;

namespace {

// Plays one camera of a dataset and returns its frames (caps of the first in *info).
std::vector<RgbdImages> play(const std::string& folder, int camera, RgbdInfo* info, vctest::RunResult* result,
                             const std::string& extra = "") {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(("rgbdfilesrc name=src location=\"" + folder + "\" camera-id=" +
                                    std::to_string(camera) + " " + extra + " ! appsink name=out sync=false")
                                       .c_str(),
                                   &err);
  EXPECT_EQ(err, nullptr);
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  std::vector<RgbdImages> frames;
  {
    vctest::SampleCollector got(out);
    *result = vctest::run_pipeline(p);
    for (size_t i = 0; i < got.size(); ++i) {
      RgbdInfo in;
      std::string e;
      EXPECT_TRUE(rgbd_info_from_caps(got.caps(i), &in, &e)) << e;
      if (i == 0 && info) *info = in;
      RgbdFrame f;
      EXPECT_TRUE(f.map(got.buffer(i), in, GST_MAP_READ, &e)) << e;
      frames.push_back({f.color().clone(), f.depth().clone(), f.label().clone(), f.plane(Plane::DepthGT).clone()});
    }
  }
  gst_object_unref(out);
  gst_object_unref(p);
  return frames;
}

void write_small_dataset(const std::string& folder, int frames) {
  Rig rig = vctest::make_rig(2, 40, 30);
  save_rig(rig, folder + "/rig.yaml");
  for (int cam = 0; cam < 2; ++cam)
    for (int i = 0; i < frames; ++i) {
      RgbdImages im;
      im.color = cv::Mat(30, 40, CV_8UC3, cv::Scalar(10 * i, 20 * cam, 30));
      im.depth = cv::Mat(30, 40, CV_16UC1, cv::Scalar(1000 + 100 * i + cam));
      dataset_write_frame(folder, cam, i, im);
    }
}

// Sub-pixel horizontal offset between a patch of `a` at (x, y) and `b` near
// (bx, y): the residual that moves the prediction onto the best match.
// Returns false where the patch is untextured or the match is ambiguous.
bool match_offset(const cv::Mat& a, const cv::Mat& b, int x, int y, double bx, double* offset) {
  const int r = 4, search = 3;
  const int ibx = static_cast<int>(std::lround(bx));
  if (x - r < 0 || x + r >= a.cols || y - r < 0 || y + r >= a.rows) return false;
  if (ibx - r - search - 1 < 0 || ibx + r + search + 1 >= b.cols) return false;
  const cv::Mat pa = a(cv::Rect(x - r, y - r, 2 * r + 1, 2 * r + 1));
  cv::Scalar mean, sd;
  cv::meanStdDev(pa, mean, sd);
  if (sd[0] < 12) return false;
  double cost[2 * search + 3];
  for (int k = -search - 1; k <= search + 1; ++k) {
    const cv::Mat pb = b(cv::Rect(ibx + k - r, y - r, 2 * r + 1, 2 * r + 1));
    cost[k + search + 1] = cv::norm(pa, pb, cv::NORM_L2SQR);
  }
  int best = 1;
  for (int k = 1; k <= 2 * search + 1; ++k)
    if (cost[k] < cost[best]) best = k;
  if (best == 0 || best == 2 * search + 2) return false;
  // Occluded or changed patches match badly everywhere.
  if (cost[best] > 0.25 * pa.total() * sd[0] * sd[0]) return false;
  const double c0 = cost[best - 1], c1 = cost[best], c2 = cost[best + 1];
  const double denom = c0 - 2 * c1 + c2;
  const double sub = denom > 0 ? 0.5 * (c0 - c2) / denom : 0.0;
  *offset = (ibx + best - search - 1 + sub) - bx;
  return true;
}

}  // namespace

TEST(Datasets, FileSinkRecordsWhatFileSrcPlays) {
  vctest::TempDir in, out;
  write_small_dataset(in.path(), 3);
  auto r = vctest::run_launch("rgbdfilesrc location=" + in.path() + " camera-id=1 ! rgbdfilesink location=" +
                              out.path() + " rig-name=copy");
  ASSERT_EQ(r.error, "");
  r = vctest::run_launch("rgbdfilesrc location=" + in.path() + " camera-id=0 ! rgbdfilesink location=" + out.path());
  ASSERT_EQ(r.error, "");
  const Rig rig = load_rig(out / "rig.yaml");
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.name, "copy");
  EXPECT_EQ(rig.camera(1).center_in_rig().x(), 0.1);
  RgbdInfo info;
  const auto a = play(in.path(), 1, &info, &r);
  const auto b = play(out.path(), 1, nullptr, &r);
  ASSERT_EQ(a.size(), 3u);
  ASSERT_EQ(b.size(), 3u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(vctest::same_image(a[i].color, b[i].color));
    EXPECT_TRUE(vctest::same_image(a[i].depth, b[i].depth));
  }
  EXPECT_EQ(a[2].depth.at<uint16_t>(0, 0), 1201);
}

TEST(Datasets, FileSrcTimestampsAndLoops) {
  vctest::TempDir dir;
  write_small_dataset(dir.path(), 3);
  vctest::RunResult r;
  RgbdInfo info;
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(("rgbdfilesrc location=" + dir.path() +
                                    " loop=true framerate=10/1 num-buffers=7 ! appsink name=out sync=false")
                                       .c_str(),
                                   &err);
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  vctest::SampleCollector got(out);
  r = vctest::run_pipeline(p);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(got.size(), 7u);
  ASSERT_TRUE(rgbd_info_from_caps(got.caps(0), &info, nullptr));
  EXPECT_EQ(info.fps_n, 10);
  for (size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(GST_BUFFER_PTS(got.buffer(i)), i * GST_SECOND / 10);
    RgbdFrame f;
    ASSERT_TRUE(f.map(got.buffer(i), info, GST_MAP_READ, nullptr));
    EXPECT_EQ(f.depth().at<uint16_t>(5, 5), 1000 + 100 * (i % 3)) << "frame " << i;
  }
  gst_object_unref(out);
  gst_object_unref(p);
}

TEST(Datasets, BadInputPostsClearErrors) {
  vctest::TempDir dir;
  write_small_dataset(dir.path(), 2);
  vctest::RunResult r;

  // A truncated PNG: the error names the file.
  const std::string color1 = dataset_camera_dir(dir.path(), 0) + "/color/000001.png";
  {
    std::ifstream in(color1, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream out(color1, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), bytes.size() / 2);
  }
  auto frames = play(dir.path(), 0, nullptr, &r);
  EXPECT_EQ(frames.size(), 1u);  // frame 0 still plays
  EXPECT_NE(r.error.find("000001.png"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("cannot decode"), std::string::npos) << r.error;

  // A depth image of the wrong size.
  const std::string depth0 = dataset_camera_dir(dir.path(), 1) + "/depth/000000.png";
  cv::imwrite(depth0, cv::Mat(10, 12, CV_16UC1, cv::Scalar(5)));
  frames = play(dir.path(), 1, nullptr, &r);
  EXPECT_TRUE(frames.empty());
  EXPECT_NE(r.error.find("depth image is 12x10, but rig camera 1 is 40x30"), std::string::npos) << r.error;

  // An 8-bit depth image.
  cv::imwrite(depth0, cv::Mat(30, 40, CV_8UC1, cv::Scalar(5)));
  play(dir.path(), 1, nullptr, &r);
  EXPECT_NE(r.error.find("16-bit"), std::string::npos) << r.error;

  // A missing dataset folder, a missing rig file.
  play(dir / "nowhere", 0, nullptr, &r);
  EXPECT_NE(r.error.find("nowhere"), std::string::npos) << r.error;
  fs::remove(dir / "rig.yaml");
  play(dir.path(), 0, nullptr, &r);
  EXPECT_NE(r.error.find("rig.yaml"), std::string::npos) << r.error;

  // A rig with 0 cameras.
  vctest::write_text(dir / "rig.yaml", "name: empty\ncameras: []\n");
  play(dir.path(), 0, nullptr, &r);
  EXPECT_NE(r.error.find("no cameras"), std::string::npos) << r.error;
  EXPECT_EQ(r.error_source, "src");

  // Frame counts that disagree between colour and depth: the colour frame without a partner is named.
  write_small_dataset(dir.path(), 2);
  fs::remove(dataset_camera_dir(dir.path(), 0) + "/depth/000001.png");
  play(dir.path(), 0, nullptr, &r);
  EXPECT_NE(r.error.find("color/000001.png has no depth image of the same name"), std::string::npos) << r.error;
}

// Issue 29: a 16-bit grey PNG in color/ was read as colour without a word
// (OpenCV converts it). Colour images must be 8-bit with three channels; any
// other is an Error naming the file and what it is.
TEST(Datasets, ColourImagesMustBe8BitRgb) {
  vctest::TempDir dir;
  write_small_dataset(dir.path(), 2);
  const std::string color0 = dataset_camera_dir(dir.path(), 0) + "/color/000000.png";
  const Dataset ds = Dataset::open(dir.path());
  EXPECT_NO_THROW(ds.load(0, 0));
  const std::pair<cv::Mat, std::string> cases[] = {{cv::Mat(30, 40, CV_16UC1, cv::Scalar(4000)), "16-bit grey"},
                                                   {cv::Mat(30, 40, CV_8UC1, cv::Scalar(40)), "8-bit grey"},
                                                   {cv::Mat(30, 40, CV_16UC3, cv::Scalar(9, 99, 999)), "16-bit colour"},
                                                   {cv::Mat(30, 40, CV_8UC4, cv::Scalar(1, 2, 3, 4)), "RGBA"}};
  for (const auto& [image, kind] : cases) {
    ASSERT_TRUE(cv::imwrite(color0, image));
    try {
      ds.load(0, 0);
      ADD_FAILURE() << kind << " colour image accepted";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(color0), std::string::npos) << msg;
      EXPECT_NE(msg.find(kind), std::string::npos) << msg;
      EXPECT_NE(msg.find("expected 8-bit RGB"), std::string::npos) << msg;
    }
  }
  // The other camera's frames and this camera's next frame still load.
  EXPECT_NO_THROW(ds.load(1, 0));
  EXPECT_NO_THROW(ds.load(0, 1));
}

TEST(Datasets, ColourAndDepthPairByNameNotByPosition) {
  // Issue 17: a renamed depth file silently shifted the pairing (frames paired
  // by sorted position). Now a name without a partner is an error naming both files.
  vctest::TempDir dir;
  write_small_dataset(dir.path(), 3);
  const std::string cam = dataset_camera_dir(dir.path(), 1);
  fs::rename(cam + "/depth/000001.png", cam + "/depth/000005.png");
  vctest::RunResult r;
  auto frames = play(dir.path(), 1, nullptr, &r);
  EXPECT_TRUE(frames.empty());
  EXPECT_NE(r.error.find(cam + "/color/000001.png"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find(cam + "/depth/000005.png"), std::string::npos) << r.error;
  EXPECT_EQ(r.error_source, "src");
  try {
    Dataset::open(dir.path());
    FAIL() << "a dataset with a renamed depth file opened";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("000005.png"), std::string::npos) << e.what();
  }

  // Pairing follows names whatever their sort order or extension: frame "10"
  // sorts before "2" and its colour is a JPEG.
  const std::vector<std::string> color = {"c/color/1.png", "c/color/10.jpg", "c/color/2.png"};
  const std::vector<std::string> depth = {"c/depth/2.png", "c/depth/10.png", "c/depth/1.pgm"};
  EXPECT_EQ(pair_by_name(color, depth, "depth"),
            (std::vector<std::string>{"c/depth/1.pgm", "c/depth/10.png", "c/depth/2.png"}));
  EXPECT_TRUE(pair_by_name(color, {}, "label").empty());
  EXPECT_THROW(pair_by_name(color, {"c/depth/1.png", "c/depth/1.pgm", "c/depth/2.png"}, "depth"), Error);
  EXPECT_THROW(pair_by_name(color, {"c/depth/1.png", "c/depth/2.png", "c/depth/10.png", "c/depth/11.png"}, "depth"),
               Error);
}

TEST(Datasets, ImageDeclaringAHugeSizeIsRefusedFromItsHeader) {
  // A PNG's header declaring another size than the rig camera's is refused
  // before OpenCV decodes (and allocates for) it; OpenCV's exceptions never escape.
  std::vector<uchar> png;
  cv::imencode(".png", cv::Mat(30, 40, CV_16UC1, cv::Scalar(5)), png);
  std::vector<uchar> huge = png;
  for (int i = 16; i < 24; i += 4) huge[i] = 0, huge[i + 1] = 0, huge[i + 2] = 0x40, huge[i + 3] = 0;  // 16384
  try {
    decode_image(huge.data(), huge.size(), cv::IMREAD_UNCHANGED, "depth", "d.png", cv::Size(40, 30), "rig camera 1");
    FAIL() << "a PNG declaring 16384x16384 decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("d.png: depth image is 16384x16384, but rig camera 1 is 40x30"),
              std::string::npos) << e.what();
  }
  for (int i = 16; i < 24; i += 4) huge[i] = 0x7f, huge[i + 1] = 0xff;  // beyond any side
  EXPECT_THROW(decode_image(huge.data(), huge.size(), cv::IMREAD_UNCHANGED, "depth", "d.png"), Error);
  const uchar garbage[] = {'P', '5', '\n', '9', '9', '9', '9', '9', '9', '9', '9', '9', '9', ' ', '1', '\n', '2', '5', '5'};
  EXPECT_THROW(decode_image(garbage, sizeof garbage, cv::IMREAD_UNCHANGED, "depth", "g.pgm"), Error);
  EXPECT_EQ(decode_image(png.data(), png.size(), cv::IMREAD_UNCHANGED, "depth", "ok.png", cv::Size(40, 30)).size(),
            cv::Size(40, 30));
}

TEST(Middlebury, DisparityToDepth) {
  EXPECT_EQ(disparity_to_depth_mm(200, 3740, 0.16), 2992);  // 3740 * 160 / 200
  EXPECT_EQ(disparity_to_depth_mm(0, 3740, 0.16), 0);
  EXPECT_EQ(disparity_to_depth_mm(5, 3740, 0.16), 0);  // 119.7 m does not fit 16 bits
}

// The importer's rig must say where real pixels go: play the imported Art
// scene, move every textured pixel of view 1 with its depth through the rig
// into view 2 and check the real view 2 has that pixel there (block matching).
TEST(Middlebury, ImportedRigLandsView1PixelsOnView2) {
  const std::string scene = vctest::shared_path("middlebury-2005-2006-multiview/art");
  SKIP_WITHOUT_SHARED_DATA(scene);
  vctest::TempDir dir;
  const ImportSummary sum = import_middlebury_multiview(scene, dir.path());
  EXPECT_EQ(sum.rig.cameras.size(), 6u);
  EXPECT_GT(sum.depth_pixels, 1390 * 1110 * 9 / 10);

  vctest::RunResult r;
  RgbdInfo info1, info2;
  const auto v1 = play(dir.path(), 1, &info1, &r);
  ASSERT_EQ(r.error, "");
  const auto v2 = play(dir.path(), 2, &info2, &r);
  ASSERT_EQ(r.error, "");
  ASSERT_EQ(v1.size(), 1u);
  ASSERT_EQ(v2.size(), 1u);
  EXPECT_EQ(info1.width(), 1390);
  EXPECT_EQ(info1.height(), 1110);
  EXPECT_EQ(info1.camera.fx, 3740);
  EXPECT_NEAR(info2.camera.center_in_rig().x() - info1.camera.center_in_rig().x(), 0.040, 1e-12);
  EXPECT_EQ(cv::countNonZero(v2[0].depth), 0);  // only view 1 has ground truth

  // Rebuild the rig from the caps alone: the calibration must travel with the stream.
  Rig rig;
  rig.cameras = {info1.camera, info2.camera};
  cv::Mat g1, g2;
  cv::cvtColor(v1[0].color, g1, cv::COLOR_RGB2GRAY);
  cv::cvtColor(v2[0].color, g2, cv::COLOR_RGB2GRAY);
  g1.convertTo(g1, CV_32F);
  g2.convertTo(g2, CV_32F);
  double sum_abs = 0;
  int n = 0;
  for (int y = 8; y < g1.rows - 8; y += 6)
    for (int x = 8; x < g1.cols - 8; x += 6) {
      const uint16_t z = v1[0].depth.at<uint16_t>(y, x);
      if (!z) continue;
      auto uv = rig.camera(2).project(rig.transform(1, 2) * rig.camera(1).unproject(x, y, z / 1000.0));
      if (!uv) continue;
      EXPECT_NEAR(uv->y(), y, 1e-6);
      double off;
      if (!match_offset(g1, g2, x, y, uv->x(), &off)) continue;
      sum_abs += std::abs(off);
      ++n;
    }
  ASSERT_GT(n, 5000) << "too few textured, unoccluded pixels to judge";
  const double mean = sum_abs / n;
  RecordProperty("mean_abs_px", std::to_string(mean));
  EXPECT_LT(mean, 0.5) << "over " << n << " pixels";
}

namespace {

// A posed sequence of two frames of the synthetic classroom (cameras 1 and
// 2 of the default rig at 160x90), as Redwood ships one.
void write_sequence(const std::string& dir, const std::vector<CameraCalib>& cams, const std::string& log_tail = "") {
  std::ofstream match(dir + "/rgbd.match"), log(dir + "/trajectory.log");
  const Classroom room(ClassroomConfig{1, 2, 2.0});
  for (size_t f = 0; f < cams.size(); ++f) {
    const RenderOutput r = render(room, 0.0, cams[f]);
    const std::string n = std::to_string(f);
    cv::Mat bgr;
    cv::cvtColor(r.color, bgr, cv::COLOR_RGB2BGR);
    fs::create_directories(dir + "/color");
    fs::create_directories(dir + "/depth");
    ASSERT_TRUE(cv::imwrite(dir + "/color/" + n + ".png", bgr));
    ASSERT_TRUE(cv::imwrite(dir + "/depth/" + n + ".png", r.depth));
    match << "depth/" << n << ".png color/" << n << ".png\n";
    log << f << " " << f << " " << f + 1 << "\n";
    const Eigen::Matrix4d m = cams[f].cam_to_rig.matrix();
    for (int row = 0; row < 4; ++row)
      log << m(row, 0) << " " << m(row, 1) << " " << m(row, 2) << " " << m(row, 3) << "\n";
  }
  log << log_tail;
}

}  // namespace

// Each frame becomes a camera at its pose with its images as written; a
// frame synthesised from the other (the leave-one-out eval-views runs)
// matches it.
TEST(PosedSequence, EveryFrameIsACameraAtItsPose) {
  vctest::TempDir in, out;
  const Rig rig = default_classroom_rig();
  std::vector<CameraCalib> cams;
  for (int id : {1, 2}) cams.push_back(scale_camera(rig.camera(id), 160, 90));
  write_sequence(in.path(), cams);
  PosedSequenceIntrinsics k;  // the scaled cameras' own, not the importer's default 640x480 ones
  k.fx = cams[0].fx;
  k.fy = cams[0].fy;
  k.cx = cams[0].cx;
  k.cy = cams[0].cy;
  const ImportSummary sum = import_posed_sequence(in.path(), out.path(), k);
  ASSERT_EQ(sum.rig.cameras.size(), 2u);
  const Dataset ds = Dataset::open(out.path());
  for (int f = 0; f < 2; ++f) {
    const CameraCalib& c = ds.rig().camera(f);
    EXPECT_TRUE(c.cam_to_rig.isApprox(cams[f].cam_to_rig, 1e-6)) << "frame " << f;
    EXPECT_EQ(c.fx, cams[f].fx);
    EXPECT_EQ(c.width, 160);
    const RgbdImages img = ds.load(f, 0);
    const RenderOutput r = render(Classroom(ClassroomConfig{1, 2, 2.0}), 0.0, cams[f]);
    EXPECT_TRUE(vctest::same_image(img.color, r.color)) << "frame " << f;
    EXPECT_TRUE(vctest::same_image(img.depth, r.depth)) << "frame " << f;
  }
  // Frame 0 from frame 1 at the imported poses: the same as from the renderer's own cameras.
  const RgbdImages a = ds.load(1, 0);
  const WarpedView imported = warp_view(ds.rig().camera(1), WarpSource{a.color, a.depth, {}, {}}, ds.rig().camera(0));
  const WarpedView direct = warp_view(cams[1], WarpSource{a.color, a.depth, {}, {}}, cams[0]);
  EXPECT_TRUE(vctest::same_image(imported.color, direct.color));
}

TEST(PosedSequence, MalformedListsAndPosesAreErrorsNamingTheFile) {
  const CameraCalib cam = scale_camera(default_classroom_rig().camera(1), 160, 90);
  auto import_error = [&](const std::function<void(const std::string&)>& spoil) {
    vctest::TempDir in, out;
    write_sequence(in.path(), {cam});
    spoil(in.path());
    try {
      import_posed_sequence(in.path(), out.path());
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // A matrix that is not a rotation.
  EXPECT_NE(import_error([](const std::string& d) {
              vctest::write_text(d + "/trajectory.log", "0 0 1\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
            }).find("trajectory.log: frame 0's matrix is not a rotation"),
            std::string::npos);
  // A row cut short, and a log not in groups of five lines.
  EXPECT_NE(import_error([](const std::string& d) {
              vctest::write_text(d + "/trajectory.log", "0 0 1\n1 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
            }).find("trajectory.log:2: expected 4 numbers"),
            std::string::npos);
  EXPECT_NE(import_error([](const std::string& d) { vctest::write_text(d + "/trajectory.log", "0 0 1\n"); })
                .find("5 lines per frame"),
            std::string::npos);
  // More frames than poses, a missing image, an empty list.
  EXPECT_NE(import_error([](const std::string& d) {
              vctest::write_text(d + "/rgbd.match", "depth/0.png color/0.png\ndepth/0.png color/0.png\n");
            }).find("1 poses for 2 frames"),
            std::string::npos);
  EXPECT_NE(import_error([](const std::string& d) { fs::remove(d + "/color/0.png"); }).find("color/0.png"),
            std::string::npos);
  EXPECT_NE(import_error([](const std::string& d) { vctest::write_text(d + "/rgbd.match", ""); }).find("no frames"),
            std::string::npos);
}

// The Redwood living room (Augmented ICL-NUIM with a Kinect noise model):
// frame 0 synthesised from frame 1 at the imported poses looks like frame
// 0 (a wrong pose convention gives about 12 dB).
TEST(PosedSequence, RedwoodLivingRoomFramesSynthesiseEachOther) {
  const std::string scene = vctest::shared_path("rgbd-sensor-samples/redwood_livingroom1_synthetic");
  SKIP_WITHOUT_SHARED_DATA(scene);
  vctest::TempDir out;
  const ImportSummary sum = import_posed_sequence(scene, out.path());
  ASSERT_EQ(sum.rig.cameras.size(), 5u);
  const Dataset ds = Dataset::open(out.path());
  const RgbdImages src = ds.load(1, 0), target = ds.load(0, 0);
  const WarpedView w = warp_view(ds.rig().camera(1), WarpSource{src.color, src.depth, {}, {}}, ds.rig().camera(0));
  FusedView f;
  fuse_views({&w}, FuseParams(), &f);
  EXPECT_GT(psnr_rgb(f.color, target.color), 22.0);
}

TEST(Middlebury, Teddy2003ImportsBothViewsWithDepth) {
  const std::string scene = vctest::shared_path("middlebury-2003-teddy/teddy");
  SKIP_WITHOUT_SHARED_DATA(scene);
  vctest::TempDir dir;
  const ImportSummary sum = import_middlebury_2003(scene, dir.path());
  ASSERT_EQ(sum.rig.cameras.size(), 2u);
  vctest::RunResult r;
  RgbdInfo i2, i6;
  const auto a = play(dir.path(), 2, &i2, &r);
  ASSERT_EQ(r.error, "");
  const auto b = play(dir.path(), 6, &i6, &r);
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(i2.width(), 450);
  EXPECT_EQ(i2.height(), 375);
  // disp2 stores 4x the 2->6 disparity: a pixel with disp2 = v moves v/4 px.
  const cv::Mat disp2 = cv::imread(scene + "/disp2.pgm", cv::IMREAD_GRAYSCALE);
  Rig rig;
  rig.cameras = {i2.camera, i6.camera};
  int checked = 0;
  for (int y = 0; y < disp2.rows; y += 7)
    for (int x = 0; x < disp2.cols; x += 7) {
      const int v = disp2.at<uint8_t>(y, x);
      const uint16_t z = a[0].depth.at<uint16_t>(y, x);
      ASSERT_EQ(v == 0, z == 0);
      if (!v) continue;
      auto uv = rig.camera(6).project(rig.transform(2, 6) * rig.camera(2).unproject(x, y, z / 1000.0));
      ASSERT_TRUE(uv.has_value());
      EXPECT_NEAR(uv->x(), x - v / 4.0, 0.02);
      ++checked;
    }
  EXPECT_GT(checked, 2000);
  EXPECT_GT(cv::countNonZero(b[0].depth), 450 * 375 * 9 / 10);
}

// Live recordings: coded frames with their running times (rgbdenc ! rgbdfilesink).
namespace {

struct Played {
  std::vector<cv::Mat> color, depth;
  std::vector<GstClockTime> pts;
};

Played collect(const std::string& launch, vctest::RunResult* result) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch((launch + " ! appsink name=out sync=false").c_str(), &err);
  EXPECT_EQ(err, nullptr);
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  Played played;
  {
    vctest::SampleCollector got(out);
    *result = vctest::run_pipeline(p);
    for (size_t i = 0; i < got.size(); ++i) {
      RgbdInfo in;
      std::string e;
      EXPECT_TRUE(rgbd_info_from_caps(got.caps(i), &in, &e)) << e;
      RgbdFrame f;
      EXPECT_TRUE(f.map(got.buffer(i), in, GST_MAP_READ, &e)) << e;
      played.color.push_back(f.color().clone());
      played.depth.push_back(f.depth().clone());
      played.pts.push_back(GST_BUFFER_PTS(got.buffer(i)));
    }
  }
  gst_object_unref(out);
  gst_object_unref(p);
  return played;
}

std::vector<uint8_t> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

}  // namespace

TEST(Recordings, StreamIndexKeepsWholeRecordsAndStopsAtDamage) {
  vctest::TempDir dir;
  const std::string path = dir / "stream.vcrs";
  const std::vector<uint8_t> a(100, 1), b(50, 2), c(70, 3);
  {
    CodedStreamWriter w(path, kCodedStreamHasLabel);
    w.write(0, a.data(), a.size());
    w.write(33000000, b.data(), b.size());
    w.write(66000000, c.data(), c.size());
  }
  CodedStreamIndex index = index_coded_stream_file(path, 100);
  ASSERT_EQ(index.frames.size(), 3u);
  EXPECT_EQ(index.flags, kCodedStreamHasLabel);
  EXPECT_EQ(index.tail_problem, "");
  EXPECT_EQ(index.frames[1].time_ns, 33000000u);
  EXPECT_EQ(read_coded_frame(path, index.frames[2]), c);
  EXPECT_THROW(index_coded_stream_file(path, 2), Error);  // more frames than allowed

  // A recorder killed in the middle of the last frame: the whole ones stay.
  const std::vector<uint8_t> whole = read_file(path);
  std::vector<uint8_t> bytes(whole.begin(), whole.end() - 5);
  write_file(path, bytes);
  index = index_coded_stream_file(path, 100);
  EXPECT_EQ(index.frames.size(), 2u);
  EXPECT_NE(index.tail_problem.find("record 2 at byte 194 is cut off"), std::string::npos) << index.tail_problem;

  // A damaged record header ends the stream there; nothing after it is guessed at.
  bytes = whole;
  bytes[12 + 16 + 100 + 3] ^= 0x40;  // the length field of record 1
  write_file(path, bytes);
  index = index_coded_stream_file(path, 100);
  EXPECT_EQ(index.frames.size(), 1u);
  EXPECT_NE(index.tail_problem.find("damaged"), std::string::npos) << index.tail_problem;

  // Not a recording, or one of a version this reader does not know: an error naming the file.
  bytes = whole;
  bytes[0] = 'X';
  write_file(path, bytes);
  EXPECT_THROW(index_coded_stream_file(path, 100), Error);
  bytes = whole;
  bytes[4] = 9;
  write_file(path, bytes);
  try {
    index_coded_stream_file(path, 100);
    ADD_FAILURE() << "version 9 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("version 9"), std::string::npos) << e.what();
  }
}

TEST(Recordings, CamerasRecordedLivePlayBackBitExactAtTheirTiming) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(3, 64, 48), rig);
  const std::string rec = dir / "rec";
  // Camera 1 starts 50 ms after the others: the recording keeps that.
  const GstClockTime offset = 50 * GST_MSECOND;
  std::string launch;
  for (int cam = 0; cam < 3; ++cam)
    launch += "rgbdtestsrc rig=" + rig + " camera-id=" + std::to_string(cam) + " num-buffers=12 ! rgbdenc name=enc" +
              std::to_string(cam) + " ! rgbdfilesink location=" + rec + "  ";
  GstElement* recorder = gst_parse_launch(launch.c_str(), nullptr);
  ASSERT_NE(recorder, nullptr);
  GstElement* enc1 = gst_bin_get_by_name(GST_BIN(recorder), "enc1");
  GstPad* late = gst_element_get_static_pad(enc1, "src");
  gst_pad_set_offset(late, static_cast<gint64>(offset));
  gst_object_unref(late);
  gst_object_unref(enc1);
  vctest::RunResult r = vctest::run_pipeline(recorder);
  gst_object_unref(recorder);
  ASSERT_EQ(r.error, "");
  for (int cam = 0; cam < 3; ++cam) {
    SCOPED_TRACE("camera " + std::to_string(cam));
    EXPECT_TRUE(fs::exists(dataset_camera_dir(rec, cam) + "/stream.vcrs"));
    const Played sent =
        collect("rgbdtestsrc rig=" + rig + " camera-id=" + std::to_string(cam) + " num-buffers=12", &r);
    ASSERT_EQ(r.error, "");
    const Played played = collect("rgbdfilesrc location=" + rec + " camera-id=" + std::to_string(cam), &r);
    ASSERT_EQ(r.error, "");
    EXPECT_TRUE(r.warnings.empty());
    ASSERT_EQ(played.depth.size(), 12u);
    for (size_t i = 0; i < 12; ++i) {
      EXPECT_TRUE(vctest::same_image(played.depth[i], sent.depth[i])) << "frame " << i;
      EXPECT_GT(cv::PSNR(played.color[i], sent.color[i]), 35) << "frame " << i;  // JPEG colour
      EXPECT_EQ(played.pts[i], sent.pts[i] + (cam == 1 ? offset : 0)) << "frame " << i;
    }
  }
  // Looping: a recording of 12 frames at 30 fps spans 400 ms (to the ns of
  // its rounded timestamps), and each loop is shifted by that.
  const Played looped = collect("rgbdfilesrc location=" + rec + " camera-id=0 loop=true num-buffers=25", &r);
  ASSERT_EQ(looped.pts.size(), 25u);
  EXPECT_NEAR(double(looped.pts[12]), double(looped.pts[0] + 12 * GST_SECOND / 30), 1);
  EXPECT_NEAR(double(looped.pts[24]), double(looped.pts[0] + 24 * GST_SECOND / 30), 2);
  EXPECT_TRUE(vctest::same_image(looped.depth[13], looped.depth[1]));
}

TEST(Recordings, RecordingCutShortPlaysItsWholeFramesWithAWarning) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  save_rig(vctest::make_rig(1, 64, 48), rig);
  const std::string rec = dir / "rec";
  vctest::RunResult r =
      vctest::run_launch("rgbdtestsrc rig=" + rig + " num-buffers=5 ! rgbdenc ! rgbdfilesink location=" + rec);
  ASSERT_EQ(r.error, "");
  const std::string stream = dataset_camera_dir(rec, 0) + "/stream.vcrs";
  std::vector<uint8_t> bytes = read_file(stream);
  bytes.resize(bytes.size() - 100);
  write_file(stream, bytes);
  const Played played = collect("rgbdfilesrc location=" + rec, &r);
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(played.depth.size(), 4u);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("the recording ends early: record 4 at byte"), std::string::npos) << r.warnings[0];

  // A frame damaged inside (its checksums) stops playback with an error naming the file and the frame.
  const CodedStreamIndex::Frame last_whole = index_coded_stream_file(stream, 100).frames.at(3);
  bytes = read_file(stream);
  bytes[last_whole.offset + last_whole.size / 2] ^= 0xFF;
  write_file(stream, bytes);
  collect("rgbdfilesrc location=" + rec, &r);
  EXPECT_NE(r.error.find("stream.vcrs: frame 3:"), std::string::npos) << r.error;
}
