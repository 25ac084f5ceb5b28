// vclassroom-eval-depth: depth RMSE / MAE (mm) and completeness of each V-DA
// stage, its ablations and two baselines against ground truth (docs/vda.md):
//  (a) the synthetic classroom with the sensor model on, against its clean depth
//      (the static model is built from learners=0 frames first);
//  (b) Middlebury 2005/2006 ground truth (view 1) with pixels knocked out the
//      way real sensors lose them, against the original.
// With --bench it only measures the per-frame time of depthcomplete +
// planerefine on 960x540 synthetic frames on one core.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vda/depth_completion.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/datasets/middlebury.h>
#include <gst/vclassroom/vda/plane_refine.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/core/visualize.h>

#include "cpu_clock.h"
#include "tool_options.h"

using namespace vclassroom;


namespace {

struct Args {
  std::string shared = "../shared/data";
  std::string images;  // folder for before/after pictures; none when empty
  int model_frames = 8;
  int eval_times = 4;
  int learners = 6;
  uint64_t seed = 1;
  uint64_t knockout_seed = 7;
  int bench = 0;  // frames to time; 0 = evaluate
  bool synthetic = true, middlebury = true;
  DepthCompleteOptions vda;  // the V-DA settings evaluated (the elements' defaults unless changed)
  // --dataset: any dataset folder with ground-truth depth.
  std::string dataset;
  std::string model;  // V-DA's static model of that room (vclassroom-build-model), optional
  int camera = -1;     // -1: every camera
  int frames = 0;      // 0: every frame
};

// Times are the CPU time of this thread: the figure for one core, and less
// disturbed by other processes on a shared machine than wall time.
struct CpuClock {
  using time_point = double;
  static double now() { return vclassroom_tools::thread_cpu_ms(); }
};

double ms_since(double t0) { return CpuClock::now() - t0; }

// Pixels within `radius` px of a ground-truth depth discontinuity: a
// 4-neighbour differing by more than `ratio` of the nearer depth.
cv::Mat edge_band(const cv::Mat& gt, int radius, double ratio = 0.05) {
  cv::Mat edges(gt.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      const int a = gt.at<uint16_t>(y, x);
      if (!a) continue;
      const int nb[2][2] = {{x + 1, y}, {x, y + 1}};
      for (const auto& n : nb) {
        if (n[0] >= gt.cols || n[1] >= gt.rows) continue;
        const int b = gt.at<uint16_t>(n[1], n[0]);
        if (b && std::abs(a - b) > ratio * std::min(a, b)) {
          edges.at<uint8_t>(y, x) = 255;
          edges.at<uint8_t>(n[1], n[0]) = 255;
        }
      }
    }
  if (radius <= 0) return edges;
  cv::Mat inv = edges == 0, dist;
  cv::distanceTransform(inv, dist, cv::DIST_L2, cv::DIST_MASK_5);
  return dist <= radius;
}

struct Score {
  double sse = 0, sae = 0;
  long n = 0, filled = 0, total = 0;
  void add(int est, int gt) {
    if (!gt) return;
    ++total;
    if (!est) return;
    ++filled;
    const double e = est - gt;
    sse += e * e;
    sae += std::abs(e);
    ++n;
  }
  double rmse() const { return n ? std::sqrt(sse / n) : 0; }
  double mae() const { return n ? sae / n : 0; }
  double fill() const { return total ? 100.0 * filled / total : 0; }
};

struct Row {
  std::string name;
  Score all, band, holes, learners;
  double ms = 0;
  int frames = 0;
  bool na = false;
};

void score(Row& r, const cv::Mat& est, const cv::Mat& gt, const cv::Mat& band, const cv::Mat& holes,
           const cv::Mat& label) {
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      const int e = est.at<uint16_t>(y, x), g = gt.at<uint16_t>(y, x);
      r.all.add(e, g);
      if (band.at<uint8_t>(y, x)) r.band.add(e, g);
      if (holes.at<uint8_t>(y, x)) r.holes.add(e, g);
      if (!label.empty() && label.at<uint8_t>(y, x)) r.learners.add(e, g);
    }
}

void print_table(const std::string& title, const std::vector<Row>& rows, bool with_learners) {
  std::printf("\n%s\n", title.c_str());
  std::printf("| %-34s | RMSE all | MAE all | filled %% | RMSE edge band | MAE edge band | RMSE holes |%s ms/frame |\n",
              "method", with_learners ? " RMSE learners |" : "");
  std::printf("|%s|---:|---:|---:|---:|---:|---:|%s---:|\n", std::string(36, '-').c_str(),
              with_learners ? "---:|" : "");
  for (const Row& r : rows) {
    if (r.na) {
      std::printf("| %-34s | n/a (no multi-view prior model for a single Middlebury view) |\n", r.name.c_str());
      continue;
    }
    std::printf("| %-34s | %8.1f | %7.1f | %8.2f | %14.1f | %13.1f | %10.1f |", r.name.c_str(), r.all.rmse(),
                r.all.mae(), r.all.fill(), r.band.rmse(), r.band.mae(), r.holes.rmse());
    if (with_learners) std::printf(" %13.1f |", r.learners.rmse());
    std::printf(" %8.2f |\n", r.frames ? r.ms / r.frames : 0.0);
  }
}

void write_picture(const std::string& dir, const std::string& name, const cv::Mat& depth, double lo, double hi,
                   int width = 320) {
  if (dir.empty()) return;
  cv::Mat rgb, small, bgr;
  colorize_depth(depth, rgb, lo, hi);
  cv::resize(rgb, small, cv::Size(width, depth.rows * width / depth.cols), 0, 0, cv::INTER_AREA);
  cv::cvtColor(small, bgr, cv::COLOR_RGB2BGR);
  const std::string path = dir + "/vda-" + name + ".png";
  if (!cv::imwrite(path, bgr)) throw Error(path + ": cannot write");
}

// Sensor-style losses on clean ground truth, fixed seed: bands along depth
// edges (varying width, wider on the far side), random blobs, dark surfaces.
cv::Mat knock_out_mask(const cv::Mat& gt, const cv::Mat& color, uint64_t seed) {
  cv::RNG rng(seed);
  const cv::Mat edges = edge_band(gt, 0);
  cv::Mat not_edge = edges == 0, dist;
  cv::distanceTransform(not_edge, dist, cv::DIST_L2, cv::DIST_MASK_5);
  // Smooth random width field in [1, 7] px.
  cv::Mat coarse(gt.rows / 32 + 2, gt.cols / 32 + 2, CV_32F), width;
  rng.fill(coarse, cv::RNG::UNIFORM, 1.0, 7.0);
  cv::resize(coarse, width, gt.size(), 0, 0, cv::INTER_LINEAR);
  // Far side: deeper than the nearest surface within 9 px.
  cv::Mat gt_inv(gt.size(), CV_16UC1), near_inv;
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      const int v = gt.at<uint16_t>(y, x);
      gt_inv.at<uint16_t>(y, x) = v ? static_cast<uint16_t>(65535 - v) : 0;
    }
  cv::dilate(gt_inv, near_inv, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(19, 19)));
  cv::Mat mask(gt.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      const int v = gt.at<uint16_t>(y, x);
      if (!v) continue;
      const int nearest = 65535 - near_inv.at<uint16_t>(y, x);
      const bool far_side = v > nearest * 1.05;
      const float w = width.at<float>(y, x) * (far_side ? 1.6f : 0.6f);
      if (dist.at<float>(y, x) <= w) mask.at<uint8_t>(y, x) = 255;
    }
  // Random blobs (specular spots, absorbing materials): about 5% of the image.
  const int blobs = gt.rows * gt.cols / 7000;
  for (int i = 0; i < blobs; ++i) {
    const cv::Point c(rng.uniform(0, gt.cols), rng.uniform(0, gt.rows));
    const cv::Size axes(rng.uniform(3, 22), rng.uniform(3, 22));
    cv::ellipse(mask, c, axes, rng.uniform(0.0, 180.0), 0, 360, cv::Scalar(255), cv::FILLED);
  }
  // Dark surfaces return too little signal.
  cv::Mat gray, dark;
  cv::cvtColor(color, gray, cv::COLOR_RGB2GRAY);
  cv::GaussianBlur(gray, gray, cv::Size(5, 5), 0);
  dark = gray < 40;
  cv::morphologyEx(dark, dark, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  mask |= dark;
  return mask;
}

using Method = std::function<void(const cv::Mat& depth, const cv::Mat& color, cv::Mat& out)>;

void eval_middlebury(const Args& a) {
  const std::vector<std::string> scenes = {"art", "aloe"};
  for (const std::string& scene : scenes) {
    std::fprintf(stderr, "vclassroom-eval-depth: Middlebury %s\n", scene.c_str());
    const std::string dir = a.shared + "/middlebury-2005-2006-multiview/" + scene;
    cv::Mat bgr = cv::imread(dir + "/view1.png", cv::IMREAD_COLOR);
    cv::Mat disp = cv::imread(dir + "/disp1.png", cv::IMREAD_GRAYSCALE);
    if (bgr.empty() || disp.empty()) {
      std::printf("\nMiddlebury %s: %s/view1.png or disp1.png missing, skipped\n", scene.c_str(), dir.c_str());
      continue;
    }
    cv::Mat color;
    cv::cvtColor(bgr, color, cv::COLOR_BGR2RGB);
    const MiddleburyMultiviewGeometry g;
    cv::Mat gt(disp.size(), CV_16UC1);
    for (int y = 0; y < disp.rows; ++y)
      for (int x = 0; x < disp.cols; ++x) {
        const int d = disp.at<uint8_t>(y, x);
        gt.at<uint16_t>(y, x) = d ? disparity_to_depth_mm(d, g.focal_px, 4 * g.view_spacing_m) : 0;
      }
    // Picture range: the 2nd and 98th percentiles of the ground truth.
    std::vector<uint16_t> vals;
    for (int y = 0; y < gt.rows; y += 4)
      for (int x = 0; x < gt.cols; x += 4)
        if (gt.at<uint16_t>(y, x)) vals.push_back(gt.at<uint16_t>(y, x));
    std::sort(vals.begin(), vals.end());
    const double lo = vals.empty() ? 0 : vals[vals.size() * 2 / 100], hi = vals.empty() ? 1 : vals[vals.size() * 98 / 100];
    const cv::Mat knocked = knock_out_mask(gt, color, a.knockout_seed);
    cv::Mat input = gt.clone();
    input.setTo(0, knocked);
    const cv::Mat band = edge_band(gt, 5);
    cv::Mat holes = knocked & (gt > 0);
    const double holes_share = 100.0 * cv::countNonZero(holes) / cv::countNonZero(gt);

    DepthCompleteOptions full = a.vda;
    full.use_prior = false;
    auto vda = [](DepthCompleteOptions o) -> Method {
      return [o](const cv::Mat& d, const cv::Mat& c, cv::Mat& out) { depth_complete(d, c, StaticPrior(), cv::Mat(), o, out); };
    };
    DepthCompleteOptions guided_only = full;
    guided_only.colorization = false;
    DepthCompleteOptions colorize_only = full;
    colorize_only.image_guided = false;
    DepthCompleteOptions no_morph = full;
    no_morph.guided.morphology = false;
    DepthCompleteOptions no_holefill = full;
    no_holefill.guided.hole_fill = false;
    DepthCompleteOptions no_median = full;
    no_median.guided.median = false;
    KuFastParams ku_plain;
    ku_plain.extrapolate = false;
    const std::vector<std::pair<std::string, Method>> methods = {
        {"raw (knocked out)", [](const cv::Mat& d, const cv::Mat&, cv::Mat& out) { d.copyTo(out); }},
        {"baseline: nearest valid pixel", [](const cv::Mat& d, const cv::Mat&, cv::Mat& out) { nearest_fill(d, out); }},
        {"baseline: Ku fast (extrapolate)",
         [](const cv::Mat& d, const cv::Mat&, cv::Mat& out) { ku_fast_fill(d, KuFastParams(), out); }},
        {"baseline: Ku fast (no extrapolate)",
         [ku_plain](const cv::Mat& d, const cv::Mat&, cv::Mat& out) { ku_fast_fill(d, ku_plain, out); }},
        {"+prior", nullptr},
        {"+completion (image-guided)", vda(guided_only)},
        {"+colorization = full V-DA", vda(full)},
        {"+planes", nullptr},
        {"ablation: no image-guided", vda(colorize_only)},
        {"ablation: image-guided w/o morphology", vda(no_morph)},
        {"ablation: image-guided w/o hole fill", vda(no_holefill)},
        {"ablation: image-guided w/o median", vda(no_median)},
    };
    std::vector<Row> rows;
    cv::Mat out;
    for (const auto& [name, m] : methods) {
      Row r;
      r.name = name;
      if (!m) {
        r.na = true;
        rows.push_back(r);
        continue;
      }
      const auto t0 = CpuClock::now();
      m(input, color, out);
      r.ms = ms_since(t0);
      r.frames = 1;
      score(r, out, gt, band, holes, cv::Mat());
      rows.push_back(r);
      if (!a.images.empty() && scene == "art") {
        std::string pic;
        if (name.rfind("raw", 0) == 0) pic = "art-knocked";
        if (name.rfind("baseline: nearest", 0) == 0) pic = "art-nearest";
        if (name == "baseline: Ku fast (extrapolate)") pic = "art-kufast";
        if (name.rfind("+colorization", 0) == 0) pic = "art-vda";
        if (!pic.empty()) write_picture(a.images, pic, out, lo, hi);
      }
    }
    if (!a.images.empty() && scene == "art") write_picture(a.images, "art-gt", gt, lo, hi);
    char title[512];
    std::snprintf(title, sizeof title,
                  "Middlebury %s view 1 (%dx%d), GT depth from disp1.png (f = 3740 px, B = 160 mm); %.1f%% of GT "
                  "pixels knocked out (seed %llu); edge band = GT pixels within 5 px of a >5%% depth step (%d px)",
                  scene.c_str(), gt.cols, gt.rows, holes_share, static_cast<unsigned long long>(a.knockout_seed),
                  cv::countNonZero(band & (gt > 0)));
    print_table(title, rows, false);
  }
}

// Any dataset with ground-truth depth (cam<ID>/depth-gt/): V-DA on each
// frame's sensor depth (with the room's static model when one is given: the
// prior and the planes, as live; else without a prior) and the baselines,
// against the ground truth. Ends with the line "RMSE N.N mm (edge band N.N mm)".
void eval_any_dataset(const Args& a) {
  const Dataset ds = Dataset::open(a.dataset);
  std::vector<int> cameras;
  for (const CameraCalib& c : ds.rig().cameras)
    if (a.camera < 0 || c.id == a.camera) cameras.push_back(c.id);
  if (cameras.empty()) ds.rig().camera(a.camera);  // throws, naming the camera
  std::unique_ptr<StaticModel> model;
  std::map<int, PlaneMaps> maps;
  if (!a.model.empty()) {
    model = std::make_unique<StaticModel>(load_static_model(a.model));
    for (int id : cameras) {
      const CameraCalib& cam = ds.rig().camera(id);
      if (model->prior(id).size() != cv::Size(cam.width, cam.height))
        throw Error(a.model + ": camera " + std::to_string(id) + " is not the dataset's size");
      const CameraCalib* mc = model->rig.find(id);
      maps[id] = plane_maps_for_camera(model->planes, mc ? *mc : cam, model->prior(id));
    }
  }
  std::vector<Row> rows(4);
  rows[0].name = "raw sensor depth";
  rows[1].name = model ? "full V-DA (model prior + planes)" : "V-DA without a static model";
  rows[2].name = "baseline: nearest valid pixel";
  rows[3].name = "baseline: Ku fast (extrapolate)";
  DepthCompleteOptions o = a.vda;
  o.use_prior = bool(model);
  size_t evaluated = 0;
  for (int id : cameras) {
    if (!ds.has_depth_gt(id)) throw Error(a.dataset + ": camera " + std::to_string(id) + " has no ground-truth depth "
                                          "(cam" + std::to_string(id) + "/depth-gt/)");
    size_t count = ds.frame_count(id);
    if (a.frames > 0) count = std::min(count, size_t(a.frames));
    vclassroom_tools::Progress progress("camera " + std::to_string(id) + " frames", long(count));
    for (size_t f = 0; f < count; ++f) {
      progress.step(long(f + 1));
      const RgbdImages im = ds.load(id, f);
      const cv::Mat band = edge_band(im.depth_gt, 5);
      const cv::Mat holes = (im.depth == 0) & (im.depth_gt > 0);
      cv::Mat out;
      auto timed = [&](Row& r, const std::function<void()>& run) {
        const auto t0 = CpuClock::now();
        run();
        r.ms += ms_since(t0);
        ++r.frames;
        score(r, out, im.depth_gt, band, holes, im.label);
      };
      timed(rows[0], [&] { im.depth.copyTo(out); });
      timed(rows[1], [&] {
        depth_complete(im.depth, im.color, model ? model->prior_for(id) : StaticPrior(), cv::Mat(), o, out);
        if (model) plane_refine(out, maps.at(id), cv::Mat(), PlaneTolerance(), out);
      });
      timed(rows[2], [&] { nearest_fill(im.depth, out); });
      timed(rows[3], [&] { ku_fast_fill(im.depth, KuFastParams(), out); });
      ++evaluated;
    }
  }
  if (evaluated == 0) throw Error(a.dataset + ": no frames to evaluate");
  const bool labels = ds.has_label(cameras.front());
  print_table(a.dataset + ": " + std::to_string(evaluated) + " frames of camera(s) " +
                  [&] {
                    std::string s;
                    for (int id : cameras) s += (s.empty() ? "" : ",") + std::to_string(id);
                    return s;
                  }() +
                  " against their ground-truth depth; edge band = within 5 px of a >5% depth step; holes = pixels "
                  "the sensor lost",
              rows, labels);
  std::printf("RMSE %.1f mm (edge band %.1f mm)\n", rows[1].all.rmse(), rows[1].band.rmse());
}

struct SyntheticSetup {
  Rig rig;
  StaticModel model;            // the full V-DA's: prior snapped to the planes
  StaticModel model_no_planes;  // the same capture, prior left off the planes (the "without planes" rows)
  std::map<int, PlaneMaps> maps;
};

SyntheticSetup build_synthetic_model(const Args& a, double* build_s, bool without_planes = false) {
  SyntheticSetup s;
  s.rig = default_classroom_rig();
  ClassroomConfig empty_cfg;
  empty_cfg.seed = a.seed;
  empty_cfg.learners = 0;
  const Classroom empty(empty_cfg);
  std::vector<CameraCapture> caps;
  for (const CameraCalib& cam : s.rig.cameras) {
    const RenderOutput clean = render(empty, 0.0, cam);
    CameraCapture c;
    c.camera_id = cam.id;
    for (int f = 0; f < a.model_frames; ++f) {
      cv::Mat depth, color;
      apply_sensor_model(clean, cam, SensorParams(), a.seed, static_cast<uint64_t>(f), &depth, &color);
      c.depth.push_back(depth);
      if (f == 0) c.color = color;
    }
    caps.push_back(c);
  }
  const double t0 = CpuClock::now();
  s.model = build_static_model(s.rig, caps);
  *build_s = ms_since(t0) / 1000.0;
  if (without_planes) {
    // V-DA without its planar refinement: neither the model's prior nor the
    // frames are snapped to the planes.
    StaticModelOptions no_snap;
    no_snap.snap_planes = false;
    s.model_no_planes = build_static_model(s.rig, caps, no_snap);
  }
  for (const CameraCalib& cam : s.model.rig.cameras)
    s.maps[cam.id] = plane_maps_for_camera(s.model.planes, cam, s.model.prior(cam.id));
  return s;
}

void eval_synthetic(const Args& a) {
  double build_s = 0;
  const SyntheticSetup s = build_synthetic_model(a, &build_s, true);
  std::printf("\nStatic model of the empty synthetic classroom (seed %llu, %d sensor frames per camera, 3 cameras "
              "960x540): built in %.1f s, %zu fused points, %zu planes\n",
              static_cast<unsigned long long>(a.seed), a.model_frames, build_s, s.model.points.size(),
              s.model.planes.size());
  for (const ExtrinsicsChange& c : s.model.refinement)
    std::printf("  ICP camera %d: moved %.2f mm / %.3f deg, point-to-plane RMS %.2f -> %.2f mm (%d pairs)\n",
                c.camera_id, c.translation_mm, c.rotation_deg, c.rms_before_mm, c.rms_after_mm, c.pairs);
  for (const RoomPlane& p : s.model.planes)
    std::printf("  plane %-7s n = (%+.3f %+.3f %+.3f) offset %+.3f m, %d points\n", p.name.c_str(), p.normal.x(),
                p.normal.y(), p.normal.z(), p.offset, p.inliers);

  ClassroomConfig cfg;
  cfg.seed = a.seed;
  cfg.learners = a.learners;
  const Classroom room(cfg);
  const PlaneTolerance tol;
  const DepthCompleteOptions full = a.vda;
  // `planes` is V-DA's planar refinement as a whole: the prior snapped to the
  // planes when the model is built, and planerefine per frame. Rows without it
  // use the model built without snapping.
  struct Variant {
    std::string name;
    bool prior, guided, colorize, planes;
    int sub = 0;  // 1: image-guided without morphology, 2: without hole fill, 3: without median
  };
  const std::vector<Variant> variants = {
      {"raw sensor depth", false, false, false, false},
      {"raw sensor depth + planerefine", false, false, false, true},
      {"+prior", true, false, false, false},
      {"+completion (image-guided)", true, true, false, false},
      {"+colorization", true, true, true, false},
      {"+planes = full V-DA", true, true, true, true},
      {"ablation: no prior", false, true, true, true},
      {"ablation: no image-guided", true, false, true, true},
      {"ablation: no colorization", true, true, false, true},
      {"ablation: no planes", true, true, true, false},
      {"ablation: image-guided w/o morphology", true, true, true, true, 1},
      {"ablation: image-guided w/o hole fill", true, true, true, true, 2},
      {"ablation: image-guided w/o median", true, true, true, true, 3},
  };
  std::vector<Row> rows(variants.size() + 2);
  for (size_t i = 0; i < variants.size(); ++i) rows[i].name = variants[i].name;
  rows[variants.size()].name = "baseline: nearest valid pixel";
  rows[variants.size() + 1].name = "baseline: Ku fast (extrapolate)";
  double ms_complete = 0, ms_planes = 0;
  int timed = 0;
  for (int ti = 0; ti < a.eval_times; ++ti) {
    std::fprintf(stderr, "vclassroom-eval-depth: synthetic classroom, scene time %d of %d\n", ti + 1, a.eval_times);
    const double t = 2.0 + 7.5 * ti;
    for (const CameraCalib& cam0 : s.rig.cameras) {
      const CameraCalib& cam = s.model.rig.camera(cam0.id);
      const RenderOutput clean = render(room, t, cam0);
      cv::Mat depth, color;
      apply_sensor_model(clean, cam0, SensorParams(), a.seed + 100, static_cast<uint64_t>(1000 + ti), &depth, &color);
      const cv::Mat band = edge_band(clean.depth, 5);
      const cv::Mat holes = (depth == 0) & (clean.depth > 0);
      const cv::Mat& prior = s.model.prior(cam.id);
      const PlaneMaps& maps = s.maps.at(cam.id);
      cv::Mat out;
      for (size_t i = 0; i < variants.size(); ++i) {
        const Variant& v = variants[i];
        DepthCompleteOptions o = full;
        o.use_prior = v.prior;
        o.image_guided = v.guided;
        o.colorization = v.colorize;
        o.guided.morphology = v.sub != 1;
        o.guided.hole_fill = v.sub != 2;
        o.guided.median = v.sub != 3;
        // The label plane is not used: the elements must work without it.
        const auto t0 = CpuClock::now();
        const StaticModel& model = v.planes ? s.model : s.model_no_planes;
        depth_complete(depth, color, model.prior_for(cam.id), cv::Mat(), o, out);
        const double t_complete = ms_since(t0);
        const auto t1 = CpuClock::now();
        if (v.planes) plane_refine(out, maps, cv::Mat(), tol, out);
        const double t_planes = ms_since(t1);
        rows[i].ms += t_complete + t_planes;
        ++rows[i].frames;
        if (v.name.rfind("+planes", 0) == 0) {
          ms_complete += t_complete;
          ms_planes += t_planes;
          ++timed;
        }
        score(rows[i], out, clean.depth, band, holes, clean.label);
        if (!a.images.empty() && ti == 1 && cam.id == 0) {
          if (i == 0) write_picture(a.images, "synthetic-raw", out, 1000, 7000);
          if (v.name.rfind("+planes", 0) == 0) write_picture(a.images, "synthetic-vda", out, 1000, 7000);
        }
      }
      if (!a.images.empty() && ti == 1 && cam.id == 0) {
        write_picture(a.images, "synthetic-gt", clean.depth, 1000, 7000);
        write_picture(a.images, "synthetic-prior", prior, 1000, 7000);
      }
      Row& rn = rows[variants.size()];
      auto t0 = CpuClock::now();
      nearest_fill(depth, out);
      rn.ms += ms_since(t0);
      ++rn.frames;
      score(rn, out, clean.depth, band, holes, clean.label);
      Row& rk = rows[variants.size() + 1];
      t0 = CpuClock::now();
      ku_fast_fill(depth, KuFastParams(), out);
      rk.ms += ms_since(t0);
      ++rk.frames;
      score(rk, out, clean.depth, band, holes, clean.label);
    }
  }
  char title[512];
  std::snprintf(title, sizeof title,
                "Synthetic classroom (seed %llu, %d learners, sensor model on), %d frames = %d instants x 3 cameras "
                "960x540, against the clean depth; edge band = within 5 px of a >5%% depth step; holes = pixels the "
                "sensor lost",
                static_cast<unsigned long long>(a.seed), a.learners, a.eval_times * 3, a.eval_times);
  print_table(title, rows, true);
  std::printf("per element (full V-DA, mean over %d frames, thread CPU time): depthcomplete %.2f ms, planerefine %.2f ms\n",
              timed, ms_complete / timed, ms_planes / timed);
}

// A chain function that drops what the elements give.
GstFlowReturn drop_buffer(GstPad*, GstObject*, GstBuffer* buf) {
  gst_buffer_unref(buf);
  return GST_FLOW_OK;
}

gboolean accept_event(GstPad*, GstObject*, GstEvent* event) {
  gst_event_unref(event);
  return TRUE;
}

gboolean accept_any_caps(GstPad* pad, GstObject* parent, GstQuery* query) {
  switch (GST_QUERY_TYPE(query)) {
    case GST_QUERY_ACCEPT_CAPS:
      gst_query_set_accept_caps_result(query, TRUE);
      return TRUE;
    case GST_QUERY_CAPS: {
      GstCaps* any = gst_caps_new_any();
      gst_query_set_caps_result(query, any);
      gst_caps_unref(any);
      return TRUE;
    }
    default:
      return gst_pad_query_default(pad, parent, query);
  }
}

// The same frames through the depthcomplete and planerefine elements, pushed
// from this thread so that thread CPU time covers all of their per-frame work
// (output plane allocation, mapping, buffer assembly) and nothing else.
template <typename Input>
void bench_elements(const Args& a, const SyntheticSetup& s, const std::vector<Input>& inputs, const std::string& argv0) {
  gst_init(nullptr, nullptr);
  if (!gst_registry_find_feature(gst_registry_get(), "depthcomplete", GST_TYPE_ELEMENT_FACTORY)) {
    // Run from the build tree: the plugin is built beside the tools.
    const std::filesystem::path dir = std::filesystem::path(argv0).parent_path() / ".." / "plugins" / "vda";
    gst_registry_scan_path(gst_registry_get(), dir.string().c_str());
  }
  GstElement* dc = gst_element_factory_make("depthcomplete", nullptr);
  GstElement* pr = gst_element_factory_make("planerefine", nullptr);
  if (!dc || !pr) {
    std::printf("  elements: depthcomplete / planerefine not found (set GST_PLUGIN_PATH), not timed\n");
    if (dc) gst_object_unref(dc);
    if (pr) gst_object_unref(pr);
    return;
  }
  char* tmp = g_dir_make_tmp("vda-bench-XXXXXX", nullptr);
  const std::string folder = std::string(tmp) + "/model";
  g_free(tmp);
  save_static_model(s.model, folder);
  g_object_set(dc, "model", folder.c_str(), nullptr);
  g_object_set(pr, "model", folder.c_str(), nullptr);
  GstElement* bin = gst_pipeline_new(nullptr);
  gst_bin_add_many(GST_BIN(bin), dc, pr, nullptr);
  gst_element_link(dc, pr);
  GstPad* src = gst_pad_new("src", GST_PAD_SRC);
  GstPad* sink = gst_pad_new("sink", GST_PAD_SINK);
  gst_pad_set_chain_function(sink, drop_buffer);
  gst_pad_set_event_function(sink, accept_event);
  gst_pad_set_query_function(sink, accept_any_caps);
  GstPad* dc_sink = gst_element_get_static_pad(dc, "sink");
  GstPad* pr_src = gst_element_get_static_pad(pr, "src");
  gst_pad_link(src, dc_sink);
  gst_pad_link(pr_src, sink);
  gst_pad_set_active(src, TRUE);
  gst_pad_set_active(sink, TRUE);
  gst_element_set_state(bin, GST_STATE_PLAYING);
  // The cameras one after the other (caps, and with them the elements' camera,
  // change twice); the first frame of each is not timed, as the elements read
  // the model and build the plane maps on caps.
  std::vector<size_t> order;
  std::vector<bool> first;
  for (const CameraCalib& c : s.model.rig.cameras) {
    std::vector<size_t> mine;
    for (size_t i = 0; i < inputs.size(); ++i)
      if (inputs[i].cam == c.id) mine.push_back(i);
    for (int k = 0; k < 1 + a.bench / 3 && !mine.empty(); ++k) {
      order.push_back(mine[k % mine.size()]);
      first.push_back(k == 0);
    }
  }
  std::vector<double> ms;
  int cam = -1;
  for (size_t f = 0; f < order.size(); ++f) {
    const Input& in = inputs[order[f]];
    RgbdInfo info;
    info.camera = s.model.rig.camera(in.cam);
    if (in.cam != cam) {
      if (cam < 0) gst_pad_push_event(src, gst_event_new_stream_start("vda-bench"));
      gst_pad_push_event(src, gst_event_new_caps(rgbd_caps_new(info)));
      if (cam < 0) {
        GstSegment seg;
        gst_segment_init(&seg, GST_FORMAT_TIME);
        gst_pad_push_event(src, gst_event_new_segment(&seg));
      }
      cam = in.cam;
    }
    GstBuffer* buf = rgbd_buffer_new(info);
    RgbdFrame fr;
    std::string err;
    if (!fr.map(buf, info, GST_MAP_WRITE, &err)) throw Error("bench: " + err);
    in.color.copyTo(fr.color());
    in.depth.copyTo(fr.depth());
    fr.unmap();
    GST_BUFFER_PTS(buf) = static_cast<GstClockTime>(f) * GST_SECOND / 30;
    GST_BUFFER_DURATION(buf) = GST_SECOND / 30;
    const double t0 = CpuClock::now();
    const GstFlowReturn r = gst_pad_push(src, buf);
    if (!first[f]) ms.push_back(ms_since(t0));
    if (r != GST_FLOW_OK) throw Error(std::string("bench: elements returned ") + gst_flow_get_name(r));
  }
  gst_element_set_state(bin, GST_STATE_NULL);
  gst_object_unref(dc_sink);
  gst_object_unref(pr_src);
  gst_object_unref(src);
  gst_object_unref(sink);
  gst_object_unref(bin);
  std::filesystem::remove_all(std::filesystem::path(folder).parent_path());
  std::vector<double> steady = ms;
  std::sort(steady.begin(), steady.end());
  double sum = 0;
  for (double x : steady) sum += x;
  std::printf("  through the elements (depthcomplete ! planerefine, GstBuffers in and out, after the first frame of "
              "each camera, %zu frames): mean %.2f ms  median %.2f ms  (budget 8 ms)\n",
              steady.size(), steady.empty() ? 0.0 : sum / steady.size(), steady.empty() ? 0.0 : steady[steady.size() / 2]);
}

void bench(const Args& a, const std::string& argv0) {
  double build_s = 0;
  const SyntheticSetup s = build_synthetic_model(a, &build_s);
  ClassroomConfig cfg;
  cfg.seed = a.seed;
  cfg.learners = a.learners;
  const Classroom room(cfg);
  // Inputs first, so only the elements' work is timed.
  struct Input {
    int cam;
    cv::Mat depth, color;
  };
  std::vector<Input> inputs;
  for (int i = 0; i < 12; ++i) {
    const CameraCalib& cam = s.rig.cameras[i % 3];
    const RenderOutput clean = render(room, 0.5 * i, cam);
    Input in;
    in.cam = cam.id;
    apply_sensor_model(clean, cam, SensorParams(), a.seed + 100, static_cast<uint64_t>(i), &in.depth, &in.color);
    inputs.push_back(in);
  }
  const DepthCompleteOptions full = a.vda;
  const PlaneTolerance tol;
  // Where the time goes: each stage added in turn (same frames, same order).
  auto stage_ms = [&](bool guided, bool colorize) {
    DepthCompleteOptions o = full;
    o.image_guided = guided;
    o.colorization = colorize;
    cv::Mat tmp;
    const double t0 = CpuClock::now();
    for (int f = 0; f < a.bench; ++f) {
      const Input& in = inputs[f % inputs.size()];
      depth_complete(in.depth, in.color, s.model.prior_for(in.cam), cv::Mat(), o, tmp);
    }
    return ms_since(t0) / a.bench;
  };
  const double ms_prior = stage_ms(false, false), ms_guided = stage_ms(true, false);
  std::vector<double> tc, tp;
  cv::Mat out;
  for (int f = 0; f < a.bench; ++f) {
    const Input& in = inputs[f % inputs.size()];
    const auto t0 = CpuClock::now();
    depth_complete(in.depth, in.color, s.model.prior_for(in.cam), cv::Mat(), full, out);
    const auto t1 = CpuClock::now();
    plane_refine(out, s.maps.at(in.cam), cv::Mat(), tol, out);
    tc.push_back(t1 - t0);
    tp.push_back(ms_since(t1));
  }
  auto stats = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (double x : v) sum += x;
    return std::make_pair(sum / v.size(), v[v.size() / 2]);
  };
  std::vector<double> tt(tc.size());
  for (size_t i = 0; i < tc.size(); ++i) tt[i] = tc[i] + tp[i];
  const auto [mc, medc] = stats(tc);
  const auto [mp, medp] = stats(tp);
  const auto [mt, medt] = stats(tt);
  std::printf("bench: %d frames 960x540 (synthetic classroom, %d learners, sensor model), one thread, thread CPU time\n", a.bench,
              a.learners);
  std::printf("  depthcomplete  mean %.2f ms  median %.2f ms\n", mc, medc);
  std::printf("  planerefine    mean %.2f ms  median %.2f ms\n", mp, medp);
  std::printf("  together       mean %.2f ms  median %.2f ms  (budget 8 ms)\n", mt, medt);
  std::printf("  stages (mean, each added in turn): prior fill %.2f, image-guided (with its median) %.2f, colorization %.2f, "
              "planes %.2f ms\n",
              ms_prior, ms_guided - ms_prior, mc - ms_guided, mp);
  bench_elements(a, s, inputs, argv0);
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  g_autofree gchar *shared = nullptr, *images = nullptr, *only = nullptr, *dataset = nullptr, *model = nullptr;
  gint64 seed = 1, knockout_seed = 7;
  gboolean measured_only = FALSE;
  const GOptionEntry entries[] = {
      {"shared", 0, 0, G_OPTION_ARG_FILENAME, &shared,
       "the shared data folder (default ../shared/data, relative to the repo root)", "DIR"},
      {"images", 0, 0, G_OPTION_ARG_FILENAME, &images, "write before/after pictures there (made if missing)", "DIR"},
      {"only", 0, 0, G_OPTION_ARG_STRING, &only, "one evaluation: synthetic or middlebury (default both)", "NAME"},
      {"model-frames", 0, 0, G_OPTION_ARG_INT, &a.model_frames, "frames per camera for the static model (default 8)",
       "N"},
      {"eval-times", 0, 0, G_OPTION_ARG_INT, &a.eval_times, "scene times evaluated (default 4)", "N"},
      {"learners", 0, 0, G_OPTION_ARG_INT, &a.learners, "learners in the synthetic classroom (default 6)", "N"},
      {"seed", 0, 0, G_OPTION_ARG_INT64, &seed, "synthetic classroom seed (default 1)", "N"},
      {"knockout-seed", 0, 0, G_OPTION_ARG_INT64, &knockout_seed, "seed of the Middlebury knock-outs (default 7)", "N"},
      {"dataset", 0, 0, G_OPTION_ARG_FILENAME, &dataset,
       "evaluate on this dataset folder with ground-truth depth (cam<ID>/depth-gt/, docs/dataset-format.md) "
       "instead of the built-in evaluations; ends with the line 'RMSE N.N mm (edge band N.N mm)'",
       "DIR"},
      {"camera", 0, 0, G_OPTION_ARG_INT, &a.camera, "with --dataset: only this camera (default all)", "K"},
      {"frames", 0, 0, G_OPTION_ARG_INT, &a.frames, "with --dataset: at most this many frames per camera", "N"},
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model,
       "with --dataset: the room's static model (vclassroom-build-model) for V-DA's prior and planes", "DIR"},
      {"bench", 0, 0, G_OPTION_ARG_INT, &a.bench, "time V-DA on this many frames instead of evaluating", "FRAMES"},
      {"colorize-iterations", 0, 0, G_OPTION_ARG_INT, &a.vda.colorize.iterations,
       "colorization iterations per frame (default 10)", "N"},
      {"median-size", 0, 0, G_OPTION_ARG_INT, &a.vda.guided.median_size, "median filter size, 3 or 5 (default 3)",
       "N"},
      {"color-sigma", 0, 0, G_OPTION_ARG_DOUBLE, &a.vda.colorize.color_sigma,
       "colorization colour distance (8-bit RGB, default 12)", "X"},
      {"prior-measured-only", 0, 0, G_OPTION_ARG_NONE, &measured_only,
       "use only the prior depth that some camera measured", nullptr},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Quality and speed of the depth algorithm (V-DA): on any dataset with ground-truth depth (--dataset), or "
      "the built-in evaluations on the synthetic classroom and Middlebury.",
      entries);
  if (shared) a.shared = shared;
  a.images = vclassroom_tools::text_of(images);
  a.seed = static_cast<uint64_t>(seed);
  a.knockout_seed = static_cast<uint64_t>(knockout_seed);
  a.vda.prior.measured_only = measured_only;
  a.dataset = vclassroom_tools::text_of(dataset);
  a.model = vclassroom_tools::text_of(model);
  if (a.dataset.empty() && (a.camera >= 0 || a.frames || !a.model.empty()))
    vclassroom_tools::usage_error("--camera, --frames and --model go with --dataset");
  if (a.frames < 0) vclassroom_tools::usage_error("--frames must be at least 1");
  if (only) {
    const std::string w = only;
    if (w != "synthetic" && w != "middlebury")
      vclassroom_tools::usage_error("--only must be synthetic or middlebury (got '" + w + "')");
    a.synthetic = w == "synthetic";
    a.middlebury = w == "middlebury";
  }
  if (a.model_frames < 1 || a.eval_times < 1 || a.learners < 0 || a.bench < 0 || seed < 0 || knockout_seed < 0 ||
      a.vda.colorize.iterations < 0 || (a.vda.guided.median_size != 3 && a.vda.guided.median_size != 5))
    vclassroom_tools::usage_error("a value is out of range (see --help)");
  if (!a.images.empty() && !vclassroom_tools::make_folder(a.images)) return 1;
  cv::setNumThreads(0);  // one core: the per-frame budget is per core
  try {
    if (a.bench > 0) {
      bench(a, argv[0]);
      return 0;
    }
    if (!a.dataset.empty()) {
      eval_any_dataset(a);
      return 0;
    }
    if (a.middlebury) eval_middlebury(a);
    if (a.synthetic) eval_synthetic(a);
  } catch (const Error& e) {
    std::cerr << "vclassroom-eval-depth: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
