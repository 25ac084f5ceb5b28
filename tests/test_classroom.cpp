// The synthetic classroom: determinism, exact geometry across cameras, labels,
// the sensor model's claims, and the rgbdtestsrc element.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/synthetic/synthetic_camera.h>
#include <gst/vclassroom/core/rgbd.h>

#include "test_util.h"

using namespace vclassroom;

namespace {

// Building a scene takes a few hundred ms: share the common ones.
const Classroom& room(uint64_t seed, int learners) {
  static std::map<std::pair<uint64_t, int>, std::unique_ptr<Classroom>> cache;
  auto& r = cache[{seed, learners}];
  if (!r) {
    ClassroomConfig c;
    c.seed = seed;
    c.learners = learners;
    r = std::make_unique<Classroom>(c);
  }
  return *r;
}

bool same(const cv::Mat& a, const cv::Mat& b) { return vctest::same_image(a, b); }

// Depth (mm) at a sub-pixel position by bilinear interpolation, when the four
// neighbours are all valid and on one smooth surface.
bool depth_at(const cv::Mat& d, double u, double v, double* z, double* slope) {
  const int x = int(std::floor(u)), y = int(std::floor(v));
  if (x < 1 || y < 1 || x + 2 >= d.cols || y + 2 >= d.rows) return false;
  double q[4][4];
  for (int j = -1; j < 3; ++j)
    for (int i = -1; i < 3; ++i) {
      q[j + 1][i + 1] = d.at<uint16_t>(y + j, x + i);
      if (q[j + 1][i + 1] == 0) return false;
    }
  // Smooth: second differences small compared with the depth.
  double gmax = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 3; ++i) gmax = std::max(gmax, std::abs(q[j][i + 1] - q[j][i]));
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) gmax = std::max(gmax, std::abs(q[j + 1][i] - q[j][i]));
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 2; ++i)
      if (std::abs(q[j][i + 2] - 2 * q[j][i + 1] + q[j][i]) > 3 + 0.2 * gmax) return false;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 4; ++i)
      if (std::abs(q[j + 2][i] - 2 * q[j + 1][i] + q[j][i]) > 3 + 0.2 * gmax) return false;
  const double fx = u - x, fy = v - y;
  *z = (q[1][1] * (1 - fx) + q[1][2] * fx) * (1 - fy) + (q[2][1] * (1 - fx) + q[2][2] * fx) * fy;
  *slope = gmax;
  return true;
}

}  // namespace

TEST(Classroom, SameSeedAndTimeGiveSameBytes) {
  ClassroomConfig c;
  c.seed = 42;
  const Classroom a(c), b(c);
  const CameraCalib cam = default_classroom_rig().camera(1);
  const RenderOutput ra = render(a, 3.3, cam), rb = render(b, 3.3, cam);
  EXPECT_TRUE(same(ra.color, rb.color));
  EXPECT_TRUE(same(ra.depth, rb.depth));
  EXPECT_TRUE(same(ra.label, rb.label));
  SensorParams sp;
  cv::Mat da, ca, db, cb;
  apply_sensor_model(ra, cam, sp, 42, 99, &da, &ca);
  apply_sensor_model(rb, cam, sp, 42, 99, &db, &cb);
  EXPECT_TRUE(same(da, db));
  EXPECT_TRUE(same(ca, cb));
  // Another frame draws other noise; another seed builds another room.
  apply_sensor_model(rb, cam, sp, 42, 100, &db, &cb);
  EXPECT_FALSE(same(da, db));
  EXPECT_FALSE(same(ca, cb));
  const RenderOutput rc = render(room(43, 3), 3.3, cam);
  EXPECT_FALSE(same(ra.color, rc.color));
}

TEST(Classroom, LearnersMoveOverTime) {
  const Classroom& r = room(1, 3);
  const CameraCalib cam = default_classroom_rig().camera(0);
  const RenderOutput a = render(r, 1.0, cam), b = render(r, 6.0, cam);
  EXPECT_FALSE(same(a.label, b.label));
  // The static room does not move.
  const Classroom& empty = room(1, 0);
  EXPECT_TRUE(same(render(empty, 1.0, cam).color, render(empty, 6.0, cam).color));
  // Over a minute every learner does more than one thing.
  for (int k = 1; k <= 3; ++k) {
    std::set<std::string> actions;
    for (double t = 0; t < 120; t += 2) actions.insert(r.learner(k, t).action);
    EXPECT_GE(actions.size(), 2u) << "learner " << k;
  }
}

TEST(Classroom, DefaultRigMatchesTheDesign) {
  const Rig rig = default_classroom_rig();
  ASSERT_EQ(rig.cameras.size(), 3u);
  validate_rig(rig, "default rig");
  const CameraCalib& c0 = rig.camera(0);
  EXPECT_TRUE(c0.cam_to_rig.translation().isZero(1e-12));  // origin at the centre camera
  EXPECT_NEAR(rig.camera(1).center_in_rig().x(), -0.8, 1e-12);
  EXPECT_NEAR(rig.camera(2).center_in_rig().x(), 0.8, 1e-12);
  for (const auto& c : rig.cameras) {
    EXPECT_EQ(c.width, 960);
    EXPECT_EQ(c.height, 540);
    // Camera x along the rig's X (the blackboard), looking at the class (-Z), downward.
    const Eigen::Vector3d x = c.cam_to_rig.linear().col(0), z = c.cam_to_rig.linear().col(2);
    EXPECT_NEAR(x.x(), 1.0, 1e-9);
    EXPECT_LT(z.z(), -0.9);
    EXPECT_LT(z.y(), 0);
  }
  // The floor is Y = -h: the default room's camera height.
  EXPECT_DOUBLE_EQ(room(1, 0).floor_y(), -ClassroomConfig{}.camera_height);
}

// A surface point seen by camera i, moved into camera j, lands where camera j
// sees that very point: j's clean depth at the reprojected (sub-pixel) position
// equals the point's z within what a 0.5 px shift and 1 mm rounding allow.
TEST(Classroom, CleanDepthIsConsistentAcrossCameras) {
  const Classroom& r = room(5, 3);
  const Rig rig = default_classroom_rig();
  std::vector<RenderOutput> out;
  for (const auto& c : rig.cameras) out.push_back(render(r, 2.0, c));
  std::mt19937 gen(7);
  int checked = 0, matched = 0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    const CameraCalib& ci = rig.cameras[i];
    const CameraCalib& cj = rig.cameras[j];
    const Eigen::Isometry3d T = rig.transform(ci.id, cj.id);
    for (int s = 0; s < 4000; ++s) {
      const int u = std::uniform_int_distribution<int>(2, ci.width - 3)(gen);
      const int v = std::uniform_int_distribution<int>(2, ci.height - 3)(gen);
      double zi, slope_i;
      if (!depth_at(out[i].depth, u, v, &zi, &slope_i)) continue;
      const uint16_t zmm = out[i].depth.at<uint16_t>(v, u);
      const Eigen::Vector3d pj = T * ci.unproject(u, v, zmm / 1000.0);
      const auto pix = cj.project(pj);
      if (!pix) continue;
      double zj, slope_j;
      if (!depth_at(out[j].depth, pix->x(), pix->y(), &zj, &slope_j)) continue;
      const double expect = pj.z() * 1000.0;
      // Error budget: i's rounding (0.5 mm, scaled by the view change),
      // j's rounding, and half a pixel of j's depth slope.
      const double tol = 2.0 + 0.5 * slope_j + 0.5 * slope_i;
      if (zj < expect - tol) continue;  // occluded in camera j
      ++checked;
      if (std::abs(zj - expect) <= tol) ++matched;
      else
        ADD_FAILURE() << "camera " << i << " pixel (" << u << "," << v << ") z=" << zmm << " -> camera " << j
                      << " (" << pix->x() << "," << pix->y() << "): expected " << expect << " mm, rendered " << zj;
      if (checked - matched > 10) return;
    }
  }
  EXPECT_GT(checked, 1500);
  EXPECT_EQ(matched, checked);
}

// A virtual camera at a rig camera's pose with its intrinsics is that camera.
TEST(Classroom, NovelViewAtCameraPoseEqualsCamera) {
  const Classroom& r = room(1, 3);
  const CameraCalib cam = default_classroom_rig().camera(2);
  const RenderOutput a = render(r, 1.5, cam);
  CameraCalib v = look_at_camera(cam.center_in_rig(), cam.center_in_rig() + cam.cam_to_rig.linear().col(2), 960, 540);
  v.fx = cam.fx;
  v.fy = cam.fy;
  v.cx = cam.cx;
  v.cy = cam.cy;
  v.id = 77;
  ASSERT_TRUE(v.cam_to_rig.isApprox(cam.cam_to_rig, 1e-12));
  v.cam_to_rig = cam.cam_to_rig;
  const RenderOutput b = render(r, 1.5, v);
  EXPECT_TRUE(same(a.color, b.color));
  EXPECT_TRUE(same(a.depth, b.depth));
  EXPECT_TRUE(same(a.label, b.label));
  // A smaller image of the same camera sees the same depth at the same rays.
  const CameraCalib half = scale_camera(cam, 480, 270);
  const RenderOutput h = render(r, 1.5, half);
  int agree = 0, n = 0;
  for (int y = 5; y < 265; y += 7)
    for (int x = 5; x < 475; x += 7) {
      double z, sl;
      if (!depth_at(a.depth, 2 * x + 0.5, 2 * y + 0.5, &z, &sl)) continue;
      ++n;
      agree += std::abs(h.depth.at<uint16_t>(y, x) - z) <= 2 + sl;
    }
  EXPECT_GT(n, 1000);
  EXPECT_GE(agree, n * 99 / 100);
}

// Labels mark exactly the learners: everything that changes when learners
// enter the room is labelled, labelled pixels are nearer than the empty room,
// and the empty room has no labels.
TEST(Classroom, LabelsMarkExactlyTheLearners) {
  const Classroom& with = room(3, 3);
  const Classroom& empty = room(3, 0);
  int labelled = 0;
  const Rig rig = default_classroom_rig();
  for (const auto& cam : rig.cameras) {
    for (double t : {0.5, 4.0, 9.0}) {
      const RenderOutput a = render(with, t, cam), e = render(empty, t, cam);
      EXPECT_EQ(cv::countNonZero(e.label), 0);
      int strictly_nearer = 0, n = 0;
      for (int y = 0; y < a.depth.rows; ++y)
        for (int x = 0; x < a.depth.cols; ++x) {
          const int l = a.label.at<uint8_t>(y, x);
          const int za = a.depth.at<uint16_t>(y, x), ze = e.depth.at<uint16_t>(y, x);
          const bool differs = za != ze || a.color.at<cv::Vec3b>(y, x) != e.color.at<cv::Vec3b>(y, x);
          if (l == 0) {
            ASSERT_FALSE(differs) << "unlabelled pixel changed by the learners at (" << x << "," << y << ")";
          } else {
            ASSERT_LE(l, 3);
            ASSERT_GT(za, 0);
            ASSERT_TRUE(ze == 0 || za <= ze) << "learner behind the room at (" << x << "," << y << ")";
            ++n;
            strictly_nearer += ze == 0 || za < ze;
          }
        }
      labelled += n;
      EXPECT_GE(strictly_nearer, n * 99 / 100);
    }
  }
  EXPECT_GT(labelled, 1000);
}

// The sensor model: holes and noise only where and as much as it claims.
TEST(SensorModel, ChangesDepthOnlyAsDocumented) {
  const Classroom& r = room(1, 3);
  SensorParams sp;
  long valid_clean = 0, holes = 0;
  const Rig rig = default_classroom_rig();
  for (const auto& cam : rig.cameras) {
    const RenderOutput clean = render(r, 2.0, cam);
    cv::Mat depth, color;
    apply_sensor_model(clean, cam, sp, 1, 60, &depth, &color);
    const cv::Mat edges = sensor_edge_mask(clean.depth, sp);
    for (int y = 0; y < depth.rows; ++y)
      for (int x = 0; x < depth.cols; ++x) {
        const int zc = clean.depth.at<uint16_t>(y, x), zn = depth.at<uint16_t>(y, x);
        if (zc == 0) {
          ASSERT_EQ(zn, 0) << "depth invented at (" << x << "," << y << ")";
          continue;
        }
        ++valid_clean;
        if (zn == 0) {
          ++holes;
          continue;
        }
        if (edges.at<uint8_t>(y, x)) {
          // Flying pixels lie between the surfaces meeting there.
          int lo = zc, hi = zc;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int xx = std::clamp(x + dx, 0, depth.cols - 1), yy = std::clamp(y + dy, 0, depth.rows - 1);
              const int zz = clean.depth.at<uint16_t>(yy, xx);
              if (zz) lo = std::min(lo, zz), hi = std::max(hi, zz);
            }
          const double s = sensor_depth_sigma_mm(sp, hi / 1000.0);
          ASSERT_GE(zn, lo - 3.5 * s - 1);
          ASSERT_LE(zn, hi + 3.5 * s + 1);
        } else {
          const double s = sensor_depth_sigma_mm(sp, zc / 1000.0);
          ASSERT_LE(std::abs(zn - zc), 3.47 * s + 1) << "at (" << x << "," << y << ") clean " << zc;
        }
      }
    // Colour noise is mild.
    cv::Mat diff;
    cv::absdiff(color, clean.color, diff);
    EXPECT_LT(cv::mean(diff)[0], 4.0);
    EXPECT_GT(cv::mean(diff)[0], 0.5);
  }
  // docs/synthetic-classroom.md: 15-35 % of the pixels with clean depth are
  // missing in the default views.
  const double frac = double(holes) / valid_clean;
  EXPECT_GE(frac, 0.15);
  EXPECT_LE(frac, 0.35);
}

// Measured noise at 1, 3 and 5 m on the back wall follows sigma = a z^2.
TEST(SensorModel, NoiseGrowsWithDepthSquared) {
  const Classroom& r = room(1, 0);
  SensorParams sp;
  for (double d : {1.0, 3.0, 4.9}) {
    const double y = r.floor_y() + 1.5;
    CameraCalib cam = look_at_camera({0.3, y, r.back_z() + d}, {0.3, y, r.back_z()}, 320, 240);
    const RenderOutput clean = render(r, 0, cam);
    const cv::Mat edges = sensor_edge_mask(clean.depth, sp);
    double sum = 0, sum2 = 0;
    long n = 0, holes = 0, valid = 0;
    for (uint64_t f = 0; f < 4; ++f) {
      cv::Mat depth, color;
      apply_sensor_model(clean, cam, sp, 9, f, &depth, &color);
      for (int yy = 60; yy < 180; ++yy)
        for (int x = 80; x < 240; ++x) {
          const int zc = clean.depth.at<uint16_t>(yy, x), zn = depth.at<uint16_t>(yy, x);
          // The wall only: desks and chairs below it are nearer.
          if (!zc || edges.at<uint8_t>(yy, x) || std::abs(zc - 1000 * d) > 100 * d) continue;
          ++valid;
          if (!zn) {
            ++holes;
            continue;
          }
          const double e = double(zn - zc);
          sum += e;
          sum2 += e * e;
          ++n;
        }
    }
    ASSERT_GT(n, 5000) << "at " << d << " m";
    const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
    const double expect = std::sqrt(std::pow(sensor_depth_sigma_mm(sp, d), 2) + 1.0 / 12);  // + rounding
    EXPECT_NEAR(sd / expect, 1.0, 0.12) << "at " << d << " m: measured " << sd << " mm";
    EXPECT_LT(std::abs(mean), 0.1 * expect + 0.1);
    // A matte wall facing the camera is measured nearly everywhere.
    EXPECT_LT(double(holes) / valid, 0.1) << "at " << d << " m";
  }
}

// rgbdtestsrc's frames without GStreamer: the library's render, sensor model and ground truth composed.
TEST(SyntheticCamera, NoiseAsAskedForAndTheCleanPlanesAsGroundTruth) {
  SyntheticCamera camera;
  const CameraCalib cam = default_classroom_rig().camera(2);
  EXPECT_THROW(camera.frame(cam, 0, 0), Error);  // before configure
  SyntheticCameraConfig cfg;
  cfg.room.seed = 11;
  camera.configure(cfg);
  const SyntheticCamera::Planes noisy = camera.frame(cam, 2.0 / 30.0, 2);
  const RenderOutput clean = render(Classroom(cfg.room), 2.0 / 30.0, cam);
  EXPECT_TRUE(same(noisy.depth_gt, clean.depth));
  EXPECT_TRUE(same(noisy.label, clean.label));
  cv::Mat depth, color;
  apply_sensor_model(clean, cam, SensorParams{}, 11, 2, &depth, &color);
  EXPECT_TRUE(same(noisy.depth, depth));
  EXPECT_TRUE(same(noisy.color, color));
  cfg.sensor_noise = false;
  camera.configure(cfg);
  const SyntheticCamera::Planes plain = camera.frame(cam, 2.0 / 30.0, 2);
  EXPECT_TRUE(same(plain.color, clean.color));
  EXPECT_TRUE(same(plain.depth, clean.depth));
}

// ------------------------------------------------------------ the element

namespace {

struct Got {
  vctest::RunResult result;
  std::vector<GstSample*> samples;
  ~Got() {
    for (auto* s : samples) gst_sample_unref(s);
  }
};

std::unique_ptr<Got> run_src(const std::string& props, int buffers) {
  auto got = std::make_unique<Got>();
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(("rgbdtestsrc " + props + " num-buffers=" + std::to_string(buffers) +
                                    " ! appsink name=out sync=false")
                                       .c_str(),
                                   &err);
  EXPECT_TRUE(p && !err) << (err ? err->message : "");
  g_clear_error(&err);
  if (!p) return got;
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  {
    vctest::SampleCollector c(out);
    got->result = vctest::run_pipeline(p);
    for (auto* s : c.samples()) got->samples.push_back(gst_sample_ref(s));
  }
  gst_object_unref(out);
  gst_object_unref(p);
  return got;
}

struct Frame {
  RgbdInfo info;
  cv::Mat color, depth, label, depth_gt;
};

Frame read_frame(GstSample* s) {
  Frame f;
  std::string err;
  EXPECT_TRUE(rgbd_info_from_caps(gst_sample_get_caps(s), &f.info, &err)) << err;
  RgbdFrame m;
  EXPECT_TRUE(m.map(gst_sample_get_buffer(s), f.info, GST_MAP_READ, &err)) << err;
  f.color = m.color().clone();
  f.depth = m.depth().clone();
  if (f.info.has(Plane::Label)) f.label = m.label().clone();
  if (f.info.has(Plane::DepthGT)) f.depth_gt = m.plane(Plane::DepthGT).clone();
  return f;
}

}  // namespace

TEST(RgbdTestSrc, CapsCarryTheCameraAndPlanes) {
  auto got = run_src("camera-id=1 seed=3", 3);
  ASSERT_EQ(got->result.error, "");
  ASSERT_EQ(got->samples.size(), 3u);
  const Frame f = read_frame(got->samples[0]);
  const CameraCalib c1 = default_classroom_rig().camera(1);
  EXPECT_EQ(f.info.camera.id, 1);
  EXPECT_EQ(f.info.width(), 960);
  EXPECT_EQ(f.info.height(), 540);
  EXPECT_DOUBLE_EQ(f.info.camera.fx, c1.fx);
  EXPECT_DOUBLE_EQ(f.info.camera.cy, c1.cy);
  EXPECT_TRUE(f.info.camera.cam_to_rig.isApprox(c1.cam_to_rig, 1e-12));
  EXPECT_EQ(f.info.planes_string(), "color,depth,label,depth-gt");
  EXPECT_EQ(f.info.fps_n, 30);
  EXPECT_EQ(f.info.fps_d, 1);
  for (size_t i = 0; i < got->samples.size(); ++i) {
    GstBuffer* b = gst_sample_get_buffer(got->samples[i]);
    EXPECT_EQ(GST_BUFFER_PTS(b), gst_util_uint64_scale(i, GST_SECOND, 30));
    EXPECT_EQ(GST_BUFFER_DURATION(b), gst_util_uint64_scale(i + 1, GST_SECOND, 30) - GST_BUFFER_PTS(b));
  }

  auto plain = run_src("ground-truth=false framerate=15/1", 2);
  ASSERT_EQ(plain->result.error, "");
  const Frame g = read_frame(plain->samples[1]);
  EXPECT_EQ(g.info.planes_string(), "color,depth");
  EXPECT_EQ(g.info.camera.id, 0);
  EXPECT_EQ(GST_BUFFER_PTS(gst_sample_get_buffer(plain->samples[1])), GST_SECOND / 15);
}

TEST(RgbdTestSrc, SameSeedSameFramesAndEqualsTheLibrary) {
  auto a = run_src("camera-id=2 seed=11", 3);
  auto b = run_src("camera-id=2 seed=11", 3);
  ASSERT_EQ(a->samples.size(), 3u);
  ASSERT_EQ(b->samples.size(), 3u);
  const Frame fa = read_frame(a->samples[2]), fb = read_frame(b->samples[2]);
  EXPECT_TRUE(same(fa.color, fb.color));
  EXPECT_TRUE(same(fa.depth, fb.depth));
  EXPECT_TRUE(same(fa.label, fb.label));
  // Frame 2 shows scene time 2/30 s: the clean planes are the library's render
  // at the camera given by the caps; the noisy depth is the sensor model's.
  ClassroomConfig cfg;
  cfg.seed = 11;
  const Classroom r(cfg);
  const RenderOutput clean = render(r, 2.0 / 30.0, fa.info.camera);
  EXPECT_TRUE(same(fa.depth_gt, clean.depth));
  EXPECT_TRUE(same(fa.label, clean.label));
  cv::Mat depth, color;
  apply_sensor_model(clean, fa.info.camera, SensorParams{}, 11, 2, &depth, &color);
  EXPECT_TRUE(same(fa.depth, depth));
  EXPECT_TRUE(same(fa.color, color));

  auto c = run_src("camera-id=2 seed=11 sensor-noise=false", 3);
  ASSERT_EQ(c->samples.size(), 3u);
  const Frame fc = read_frame(c->samples[2]);
  EXPECT_TRUE(same(fc.color, clean.color));
  EXPECT_TRUE(same(fc.depth, clean.depth));
  EXPECT_TRUE(same(fc.depth_gt, clean.depth));
}

TEST(RgbdTestSrc, ReadsARigFile) {
  vctest::TempDir dir;
  Rig rig = default_classroom_rig();
  rig.cameras[1] = scale_camera(rig.cameras[1], 320, 180);
  rig.cameras[1].id = 5;
  save_rig(rig, dir / "rig.yaml");
  auto got = run_src("rig=" + (dir / "rig.yaml") + " camera-id=5 learners=0", 1);
  ASSERT_EQ(got->result.error, "");
  ASSERT_EQ(got->samples.size(), 1u);
  const Frame f = read_frame(got->samples[0]);
  EXPECT_EQ(f.info.camera.id, 5);
  EXPECT_EQ(f.info.width(), 320);
  EXPECT_EQ(cv::countNonZero(f.label), 0);
}

TEST(RgbdTestSrc, BadRigOrCameraPostsAnError) {
  vctest::TempDir dir;
  auto r = vctest::run_launch("rgbdtestsrc rig=" + (dir / "missing.yaml") + " num-buffers=1 ! fakesink");
  EXPECT_NE(r.error.find("missing.yaml"), std::string::npos) << r.error;
  vctest::write_text(dir / "bad.yaml", "%YAML:1.0\n---\ncameras:\n  - { id: 0, width: 64 }\n");
  r = vctest::run_launch("rgbdtestsrc rig=" + (dir / "bad.yaml") + " num-buffers=1 ! fakesink");
  EXPECT_NE(r.error.find("bad.yaml"), std::string::npos) << r.error;
  r = vctest::run_launch("rgbdtestsrc camera-id=9 num-buffers=1 ! fakesink");
  EXPECT_NE(r.error.find("9"), std::string::npos) << r.error;
}
