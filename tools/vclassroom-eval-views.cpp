// Leave-one-out evaluation of V-VA (docs/vva.md): synthesise a camera from
// the others and compare it with that camera's real image (PSNR/SSIM as
// DESIGN.md §5), in the layout of the paper's Table I.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <cstdlib>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/vda/depth_completion.h>
#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/vva/background_memory.h>
#include <gst/vclassroom/vva/learner_seg.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/datasets/middlebury.h>
#include <gst/vclassroom/vda/plane_refine.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "tool_options.h"

using namespace vclassroom;

namespace {

struct Options {
  std::string shared = "../shared/data";
  std::string images;  // folder for side-by-side PNGs, "" = none
  std::string only;    // "classroom", "middlebury", "teddy" or "" = all
  int frames = 20;
  int width = 960, height = 540;
  int boundary_px = 0;
  bool mesh = false;
  // classroom: each source camera's colour through a background memory of this many frames (0: off), on by
  // default as pipelines/server.sh runs it.
  int memory = 8;
  double fill_texture = 0;  // viewfuse fill-texture
  HoleFillMethod fill_method = FuseParams().fill_method;  // viewfuse fill-method
  int fill_smooth_px = FuseParams().fill_smooth_px;
  std::string write_priors;  // folder: write the empty room's depth per camera and exit
  std::string model;         // V-DA model folder: the full system runs V-DA on the sensor depth
  // --dataset: leave-one-out on any dataset folder of the project's format.
  std::string dataset;
  std::string rig;  // calibration to warp with instead of the dataset's (e.g. vclassroom-calibrate's)
  int target = -1;
  std::vector<int> sources;
  int crop_right = 0;
  int dataset_frames = 0;  // 0: every frame
  std::string out;
  // classroom: also score the view as viewfuse room-view=true makes it (synthesize_room_view).
  bool room_view = false;
};

FuseParams fuse_params(const Options& opt) {
  FuseParams p;
  p.fill_texture = opt.fill_texture;
  p.fill_method = opt.fill_method;
  p.fill_smooth_px = opt.fill_smooth_px;
  return p;
}

struct Stats {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double avg() const {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? NAN : s / v.size();
  }
  double max() const { return v.empty() ? NAN : *std::max_element(v.begin(), v.end()); }
  double min() const { return v.empty() ? NAN : *std::min_element(v.begin(), v.end()); }
};

// What the hole filling made, scored alone: PSNR over the filled pixels inside `roi` (pooled over the
// frames: their squared errors summed) and their share of the pixels scored.
struct HoleScore {
  double se = 0, values = 0, pixels = 0;
  void add(const cv::Mat& synth, const cv::Mat& real, const cv::Mat& filled, const cv::Rect& roi) {
    const cv::Mat m = filled(roi);
    const int n = cv::countNonZero(m);
    pixels += double(roi.area());
    if (n == 0) return;
    se += cv::norm(synth(roi), real(roi), cv::NORM_L2SQR, m);
    values += 3.0 * n;
  }
  double psnr() const { return values == 0 ? NAN : se == 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 * values / se); }
  double share() const { return pixels == 0 ? 0 : values / 3.0 / pixels; }
  std::string line() const {
    char buf[96];
    std::snprintf(buf, sizeof buf, "holes: PSNR %.2f dB over %.1f %% of pixels", psnr(), 100 * share());
    return buf;
  }
};

void write_side_by_side(const std::string& path, const cv::Mat& synth, const cv::Mat& real, const cv::Rect& roi,
                        int max_width = 900) {
  const cv::Mat a = synth(roi), b = real(roi);
  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{a, b, error_image(a, b)}, row);
  if (row.cols > max_width) cv::resize(row, row, cv::Size(), double(max_width) / row.cols, double(max_width) / row.cols, cv::INTER_AREA);
  cv::Mat bgr;
  cv::cvtColor(row, bgr, cv::COLOR_RGB2BGR);
  cv::imwrite(path, bgr, {cv::IMWRITE_PNG_COMPRESSION, 9});
  std::printf("  wrote %s\n", path.c_str());
}

std::string make_temp_dir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "vclassroom-eval-XXXXXX").string();
  const char* d = mkdtemp(tmpl.data());
  if (!d) throw Error("cannot create a temporary folder");
  return d;
}

// Leave-one-out on any dataset: the target camera synthesised from the
// sources, frame by frame, against the target's real image (right
// `crop_right` columns left out, as FW-DIBR's protocol does for what no
// source sees). Writes synthesised | real | error PNGs of the first and last
// frame (of the one frame: <name>.png) and a plot of PSNR per frame when
// `out` is set.
struct DatasetScore {
  Stats psnr, ssim;
  HoleScore holes;
};

// A line chart of `values` (one per frame) as a PNG a reader can look at.
void write_plot(const std::string& path, const std::vector<double>& values, const std::string& title) {
  const int w = 640, h = 320, left = 56, right = 16, top = 36, bottom = 40;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double lo = *std::min_element(values.begin(), values.end()), hi = *std::max_element(values.begin(), values.end());
  lo = std::floor(lo - 0.5);
  hi = std::ceil(hi + 0.5);
  auto x_of = [&](size_t i) {
    return left + (values.size() < 2 ? (w - left - right) / 2 : int(i * (w - left - right) / (values.size() - 1)));
  };
  auto y_of = [&](double v) { return top + int((hi - v) / (hi - lo) * (h - top - bottom)); };
  const cv::Scalar axis(80, 80, 80), line(200, 90, 30);
  cv::rectangle(img, {left, top}, {w - right, h - bottom}, axis);
  for (double v : {lo, (lo + hi) / 2, hi}) {
    char label[32];
    std::snprintf(label, sizeof label, "%.1f", v);
    cv::putText(img, label, {4, y_of(v) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, axis);
  }
  cv::putText(img, "frame", {w / 2 - 20, h - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, axis);
  cv::putText(img, "0", {left - 4, h - bottom + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4, axis);
  cv::putText(img, std::to_string(values.size() - 1), {w - right - 16, h - bottom + 16}, cv::FONT_HERSHEY_SIMPLEX,
              0.4, axis);
  cv::putText(img, title, {left, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) cv::line(img, {x_of(i - 1), y_of(values[i - 1])}, {x_of(i), y_of(values[i])}, line, 2, cv::LINE_AA);
    cv::circle(img, {x_of(i), y_of(values[i])}, 3, line, cv::FILLED, cv::LINE_AA);
  }
  if (!cv::imwrite(path, img)) throw Error("cannot write " + path);
  std::printf("  wrote %s\n", path.c_str());
}

DatasetScore eval_dataset(const Dataset& ds, const Rig& rig, int target, const std::vector<int>& sources,
                          int crop_right, int frames, const WarpParams& wp, const FuseParams& fp,
                          const std::string& out,
                          const std::string& name) {
  size_t count = ds.frame_count(target);
  for (int s : sources) count = std::min(count, ds.frame_count(s));
  if (frames > 0) count = std::min(count, size_t(frames));
  const CameraCalib& target_cam = rig.camera(target);
  if (crop_right < 0 || crop_right >= target_cam.width)
    throw Error("--crop-right " + std::to_string(crop_right) + " leaves nothing of camera " + std::to_string(target) +
                " (" + std::to_string(target_cam.width) + " columns)");
  const cv::Rect roi(0, 0, target_cam.width - crop_right, target_cam.height);
  std::vector<ViewWarper> warpers(sources.size());
  DatasetScore score;
  vclassroom_tools::Progress progress(name + " frames", long(count));
  for (size_t f = 0; f < count; ++f) {
    if (count > 1) progress.step(long(f + 1));
    std::vector<WarpedView> warped(sources.size());
    std::vector<const WarpedView*> views;
    for (size_t i = 0; i < sources.size(); ++i) {
      const RgbdImages in = ds.load(sources[i], f);
      warpers[i].warp(rig.camera(sources[i]), WarpSource{in.color, in.depth, cv::Mat(), cv::Mat()}, target_cam, wp,
                      &warped[i]);
      views.push_back(&warped[i]);
    }
    FusedView fused;
    fuse_views(views, fp, &fused);
    const RgbdImages real = ds.load(target, f);
    score.psnr.add(psnr_rgb(fused.color, real.color, roi));
    score.ssim.add(ssim_luma(fused.color, real.color, roi));
    score.holes.add(fused.color, real.color, fused.filled, roi);
    if (!out.empty() && (f == 0 || f + 1 == count))
      write_side_by_side(out + "/" + name + (count > 1 ? "-frame" + std::to_string(f) : std::string()) + ".png",
                         fused.color, real.color, roi);
  }
  if (!out.empty() && count > 1)
    write_plot(out + "/" + name + "-psnr.png", score.psnr.v, name + ": PSNR (dB) per frame");
  return score;
}

std::string camera_list(const std::vector<int>& ids) {
  std::string s;
  for (int id : ids) s += (s.empty() ? "" : ",") + std::to_string(id);
  return s;
}

void eval_any_dataset(const Options& opt) {
  const Dataset ds = Dataset::open(opt.dataset);
  const Rig rig = opt.rig.empty() ? ds.rig() : load_rig(opt.rig);
  for (int id : opt.sources) ds.rig().camera(id), rig.camera(id);  // each names a camera of both, or throws
  ds.rig().camera(opt.target);
  const CameraCalib& t = rig.camera(opt.target);
  if (ds.rig().camera(opt.target).width != t.width || ds.rig().camera(opt.target).height != t.height)
    throw Error(opt.rig + ": camera " + std::to_string(opt.target) + " is not the dataset's size");
  WarpParams wp;
  wp.boundary_px = opt.boundary_px;
  wp.mesh = opt.mesh;
  const std::string name = "cam" + std::to_string(opt.target) + "-from-" + camera_list(opt.sources);
  std::printf("== %s: camera %d from camera(s) %s%s, right %d columns cropped ==\n", opt.dataset.c_str(), opt.target,
              camera_list(opt.sources).c_str(), opt.rig.empty() ? "" : (" with the rig " + opt.rig).c_str(),
              opt.crop_right);
  const DatasetScore s =
      eval_dataset(ds, rig, opt.target, opt.sources, opt.crop_right, opt.dataset_frames, wp, fuse_params(opt),
                   opt.out, name);
  if (s.psnr.v.empty()) throw Error(opt.dataset + ": no frames to evaluate");
  std::printf("frames %zu, PSNR min %.2f max %.2f dB\n", s.psnr.v.size(), s.psnr.min(), s.psnr.max());
  std::printf("%s\n", s.holes.line().c_str());
  std::printf("PSNR %.2f dB SSIM %.2f\n", s.psnr.avg(), 100 * s.ssim.avg());
}

// Single reference: view 1 + depth -> view k, crop right 50*(k-1) columns (FW-DIBR protocol).
void eval_middlebury(const Options& opt) {
  const std::string base = opt.shared + "/middlebury-2005-2006-multiview";
  const std::map<std::string, std::vector<double>> best = {
      {"art", {32.681, 29.637, 26.941, 25.072, 24.182}},     // Layered Simple
      {"aloe", {31.886, 29.396, 27.710, 26.702, 25.766}}};   // Layered Simple
  std::printf("\n== Middlebury 2005/2006, view 1 + disp1_noholes -> views 2..6 (FW-DIBR protocol: right 50*(k-1) "
              "columns cropped) ==\n");
  for (const std::string scene : {"art", "aloe"}) {
    const std::string tmp = make_temp_dir();
    import_middlebury_multiview(base + "/" + scene, tmp, true);
    const Dataset ds = Dataset::open(tmp);
    WarpParams wp;
    wp.boundary_px = opt.boundary_px;
    wp.mesh = opt.mesh;
    std::printf("%-5s offset |  PSNR dB  SSIMx100 | best published PSNR (Layered Simple) | ours - best\n",
                scene.c_str());
    for (int k = 2; k <= 6; ++k) {
      // The same evaluation as --dataset DIR --target k --sources 1 --crop-right 50*(k-1).
      const DatasetScore s = eval_dataset(ds, ds.rig(), k, {1}, 50 * (k - 1), 1, wp, fuse_params(opt),
                                          k == 2 || k == 6 ? opt.images : "", "vva-" + scene + "-view1-to-" +
                                                                                  std::to_string(k));
      const double b = best.at(scene)[k - 2];
      std::printf("%-5s   %d    |  %6.2f   %6.2f   |  %6.2f                              | %+5.3f | %s\n",
                  scene.c_str(), k - 1, s.psnr.avg(), 100 * s.ssim.avg(), b, s.psnr.avg() - b,
                  s.holes.line().c_str());
    }
    std::string cmd = "rm -rf '" + tmp + "'";
    if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "could not remove %s\n", tmp.c_str());
  }
}

// Teddy's ground truth leaves 2 % of each view's disparity unknown (0). Art and Aloe are warped from the
// FW-DIBR authors' hole-free maps (disp1_noholes); Teddy has none, so its view is warped as the live system
// warps a camera, after V-DA's completion (depthcomplete, without a room model), and also as before
// 2026-11-28 with the unknown pixels left out, whose colour the source has but the warp then drops: they
// came back as 2 % more holes for the fill to make.
void eval_teddy(const Options& opt) {
  const std::string tmp = make_temp_dir();
  import_middlebury_2003(opt.shared + "/middlebury-2003-teddy/teddy", tmp);
  const Dataset ds = Dataset::open(tmp);
  std::printf("\n== Middlebury 2003 Teddy (quarter size), one reference -> the other ==\n");
  for (auto [from, to] : {std::pair<int, int>{2, 6}, {6, 2}}) {
    const RgbdImages ref = ds.load(from, 0), real = ds.load(to, 0);
    cv::Mat completed;
    depth_complete(ref.depth, ref.color, StaticPrior(), cv::Mat(), DepthCompleteOptions(), completed);
    WarpParams wp;
    wp.boundary_px = opt.boundary_px;
    wp.mesh = opt.mesh;
    // The border the other view cannot see: 4 x 16 px of disparity range; crop it like FW-DIBR's 50 px.
    const int crop = 64;
    const cv::Rect roi = to > from ? cv::Rect(0, 0, real.color.cols - crop, real.color.rows)
                                   : cv::Rect(crop, 0, real.color.cols - crop, real.color.rows);
    for (const bool complete : {true, false}) {
      const WarpedView w = warp_view(ds.rig().camera(from), WarpSource{ref.color, complete ? completed : ref.depth, {}, {}},
                                     ds.rig().camera(to), wp);
      FusedView f;
      fuse_views({&w}, fuse_params(opt), &f);
      HoleScore holes;
      holes.add(f.color, real.color, f.filled, roi);
      std::printf("teddy %d -> %d%s: PSNR %.2f dB, SSIMx100 %.2f (%d border columns cropped); %s\n", from, to,
                  complete ? "" : ", unknown disparity left out", psnr_rgb(f.color, real.color, roi),
                  100 * ssim_luma(f.color, real.color, roi), crop, holes.line().c_str());
      if (!opt.images.empty() && from == 2 && complete)
        write_side_by_side(opt.images + "/vva-teddy-2-to-6.png", f.color, real.color, roi);
    }
  }
  std::string cmd = "rm -rf '" + tmp + "'";
  if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "could not remove %s\n", tmp.c_str());
}



// The synthetic classroom: cameras 1 and 2 -> camera 0 (leave-one-out, the
// paper's Table I), and -> novel lecturer poses against the exact renderer.
struct Config {
  const char* name;
  bool static_prior;   // static layer from the empty room's depth (V-DA stand-in)
  bool segmentation;   // learner layer from learnerseg
  bool fusion;         // cameras 1 and 2 (else camera 1 only)
  bool truth_labels;   // ground-truth labels instead of learnerseg (reference row)
};

// `rooms` (one per source, or null): the room behind the learners each
// source remembers, drawn behind them where the configuration has a static
// layer and learners.
void synthesize(const std::vector<CameraCalib>& cams, const std::vector<RgbdImages>& in,
                const std::vector<cv::Mat>& priors, const std::vector<cv::Mat>& labels, const Config& c,
                const CameraCalib& virt, const WarpParams& wp, const FuseParams& fp, std::vector<ViewWarper>& warpers,
                const std::vector<std::pair<cv::Mat, cv::Mat>>* rooms, FusedView* out,
                HoleFillHistory* fill_history = nullptr) {
  std::vector<WarpedView> warped(cams.size());
  std::vector<const WarpedView*> ptrs;
  for (size_t i = 0; i < cams.size(); ++i) {
    if (!c.fusion && i > 0) break;
    WarpSource src;
    src.color = in[i].color;
    src.depth = in[i].depth;
    if (c.segmentation) src.label = labels[i];
    if (c.static_prior) src.static_depth = priors[i];
    if (rooms && c.segmentation && c.static_prior) {
      src.room_color = (*rooms)[i].first;
      src.room_depth = (*rooms)[i].second;
    }
    warpers[i].warp(cams[i], src, virt, wp, &warped[i]);
    ptrs.push_back(&warped[i]);
  }
  fuse_views(ptrs, fp, out, fill_history);
}

// The view as viewfuse room-view=true makes it (docs/vva.md, "How a view is made"): the room rasterised from
// each source's mesh of its static depth and looked up backward in the sources (RoomViewRenderer), the
// learners and the room's pixels beside them warped forward from each source (WarpParams::learners_only),
// fused with the room as the base.
struct RoomViewPath {
  std::vector<std::shared_ptr<RoomShape>> shapes;
  std::vector<ViewWarper> warpers = std::vector<ViewWarper>(3);
  RoomViewRenderer renderer;
  Stats psnr, ssim, npsnr, nssim;
  Stats unseen;  // Table I on the pixels no source sees (the full system's mask)
  std::vector<HoleFillHistory> histories;
  HoleScore holes;  // Table I: what the fill made
  double filled_share = 0;
  long views = 0;
};

void synthesize_room_view(RoomViewPath& p, const std::vector<CameraCalib>& cams, const std::vector<RgbdImages>& in,
                          const std::vector<cv::Mat>& priors, const std::vector<cv::Mat>& labels,
                          const std::vector<std::pair<cv::Mat, cv::Mat>>* rooms, const CameraCalib& virt,
                          const WarpParams& wp, const FuseParams& fp, FusedView* out, HoleFillHistory* history) {
  if (p.shapes.empty())
    for (size_t i = 0; i < cams.size(); ++i) p.shapes.push_back(std::make_shared<RoomShape>(cams[i], priors[i]));
  std::vector<RoomTexture> textures(cams.size());
  std::vector<RoomCamera> room_cams;
  std::vector<WarpedView> learners(cams.size());
  WarpedView room;
  std::vector<const WarpedView*> ptrs{&room};
  WarpParams only = wp;
  only.learners_only = true;
  std::vector<Eigen::Vector3d> centres;
  for (const CameraCalib& c : cams) centres.push_back(c.center_in_rig());
  for (size_t i = 0; i < cams.size(); ++i) {
    WarpSource src;
    src.color = in[i].color;
    src.depth = in[i].depth;
    src.label = labels[i];
    src.static_depth = priors[i];
    if (rooms) src.room_color = (*rooms)[i].first, src.room_depth = (*rooms)[i].second;
    pack_room_records(cams[i], priors[i].ptr<uint16_t>(), labels[i].ptr<uint8_t>(), src.color, src.room_depth,
                      src.room_color, &textures[i]);
    textures[i].steady = rooms != nullptr;  // the sources' colour through the background memory
    room_cams.push_back(RoomCamera{p.shapes[i].get(), &textures[i]});
    if (learners_left_to_nearer(cams[i].center_in_rig(), centres, virt.center_in_rig()))
      p.warpers[i].warp_nothing(virt, &learners[i]);  // as viewwarp: its learners left to nearer cameras
    else
      p.warpers[i].warp(cams[i], src, virt, only, &learners[i]);
    ptrs.push_back(&learners[i]);
  }
  p.renderer.render(room_cams, virt, room_lookup_params(fp), &room);
  ++p.views;
  FuseParams base = fp;
  base.first_is_base = true;
  fuse_views(ptrs, base, out, history);
  p.filled_share += double(cv::countNonZero(out->filled)) / double(out->filled.total());
}

void eval_classroom(const Options& opt) {
  const FuseParams fp = fuse_params(opt);
  const Rig rig = default_classroom_rig();
  const ClassroomConfig cfg{1, 6, 2.0};
  const Classroom room(cfg), empty(ClassroomConfig{cfg.seed, 0, cfg.camera_height});
  std::vector<CameraCalib> all;
  for (int id : {0, 1, 2}) all.push_back(scale_camera(rig.camera(id), opt.width, opt.height));
  const std::vector<CameraCalib> sources{all[1], all[2]};
  const CameraCalib& target = all[0];
  // Novel lecturer poses in the paper's slider notation around camera 0.
  const std::vector<std::string> novel_sliders = {"[40,50,55,50,50,50]", "[60,45,60,55,45,50]",
                                                  "[50,55,65,45,50,50]"};
  std::vector<CameraCalib> novel;
  for (const auto& s : novel_sliders)
    novel.push_back(virtual_camera(target, sliders_to_pose(parse_sliders(s), target).cam_to_rig(), NAN));

  const std::vector<Config> configs = {
      {"full system (static prior + learnerseg + fusion)", true, true, true, false},
      {"w/o V-DA (raw sensor depth)", false, true, true, false},
      {"w/o segmentation (static prior everywhere)", true, false, true, false},
      {"w/o multi-view fusion (camera 1 only)", true, true, false, false},
      {"reference: ground-truth labels", true, true, true, true},
  };
  std::vector<Stats> psnr(configs.size()), ssim(configs.size()), npsnr(configs.size()), nssim(configs.size());
  std::vector<LearnerSegmenter> seg(3);
  std::vector<Stats> iou(3), learner_iou(3);
  std::vector<ViewWarper> warpers(2);
  ClassroomRenderer renderer;
  SensorParams sensor;
  WarpParams wp;
  wp.boundary_px = opt.boundary_px;
  wp.mesh = opt.mesh;
  std::vector<cv::Mat> priors(3);
  // With a model: what the live pipeline runs per camera before learnerseg.
  std::vector<StaticPrior> vda_prior(3);
  std::vector<PlaneMaps> vda_planes(3);
  const bool vda = !opt.model.empty();
  if (vda) {
    const StaticModel m = load_static_model(opt.model);
    for (int i = 0; i < 3; ++i) {
      const int id = all[i].id;
      if (m.prior(id).size() != cv::Size(all[i].width, all[i].height))
        throw std::runtime_error("model " + opt.model + ": camera " + std::to_string(id) + " is not " +
                                 std::to_string(all[i].width) + "x" + std::to_string(all[i].height));
      priors[i] = m.prior(id).clone();
      vda_prior[i] = m.prior_for(id);
      const CameraCalib* cam = m.rig.find(id);
      vda_planes[i] = plane_maps_for_camera(m.planes, cam ? *cam : all[i], m.prior(id));
    }
  } else {
    for (int i = 0; i < 3; ++i) {
      RenderOutput e;
      renderer.render(empty, 0.0, all[i], &e);
      priors[i] = e.depth.clone();
    }
  }
  for (int i = 0; i < 3; ++i) seg[i].set_static_depth(priors[i]);
  std::vector<BackgroundMemory> memories(3, BackgroundMemory(BackgroundMemoryParams{std::max(1, opt.memory), 24}));
  if (opt.memory > 0) {
    // Seeded with the empty room, as the capture of the empty classroom
    // seeds viewwarp's memory: V-DA's model's colour, or for the stand-in
    // the empty room rendered.
    const StaticModel m = vda ? load_static_model(opt.model) : StaticModel();
    for (int i = 0; i < 3; ++i) {
      cv::Mat seed = vda ? m.color(all[i].id) : cv::Mat();
      if (seed.empty()) {
        RenderOutput e;
        renderer.render(empty, 0.0, all[i], &e);
        seed = e.color;
      }
      memories[i].seed(seed);
    }
  }
  HoleScore filled_holes;  // the full system: what the hole filling made
  Stats hole_psnr;     // the full system's leave-one-out on the pixels no source sees now
  double hole_share = 0;
  const double fps = 10.0;  // segmentation sees consecutive frames at 10 fps
  FusedView fused;
  // Each configuration's view from each pose is a sequence of its own, as one viewfuse's output from a pose
  // that stays: it keeps its fill's history from frame to frame (HoleFillHistory), the others' never reach it.
  std::vector<HoleFillHistory> histories(configs.size() * (1 + novel.size()));
  cv::Mat last_synth, last_real;
  RoomViewPath room_view;
  const bool room_views = opt.room_view;
  room_view.histories.resize(1 + novel.size());
  // The sources' own places, where a lecturer standing at a camera sees (with camera 0's lens): today's view and
  // the room view against the truth, each frame on its own (no fill history).
  const std::vector<CameraCalib> own{virtual_camera(target, all[1].cam_to_rig, NAN),
                                     virtual_camera(target, all[2].cam_to_rig, NAN)};
  Stats own_psnr, own_room_psnr;
  // A lecturer near camera 0 with all three cameras as sources (as the live flow, each through the background
  // memory): camera 0's place and the novel poses, today's view and the room view against the truth.
  RoomViewPath near_room;
  std::vector<ViewWarper> near_warpers(3);
  std::vector<CameraCalib> near_poses{target};
  near_poses.insert(near_poses.end(), novel.begin(), novel.end());
  Stats near_psnr, near_room_psnr;
  FusedView room_fused;
  vclassroom_tools::Progress progress("synthetic classroom frames", opt.frames);
  for (int f = 0; f < opt.frames; ++f) {
    progress.step(f + 1);
    const double t = f / fps;
    std::vector<RgbdImages> imgs(3);
    std::vector<cv::Mat> labels(3), truth(3), raw_depth(3);
    std::vector<std::pair<cv::Mat, cv::Mat>> rooms(2);  // the sources' remembered room behind the learners
    std::vector<std::pair<cv::Mat, cv::Mat>> all_rooms(3);  // likewise for cameras 0, 1 and 2
    cv::Mat camera0_remembered;
    for (int i = 0; i < 3; ++i) {
      RenderOutput r;
      renderer.render(room, t, all[i], &r);
      apply_sensor_model(r, all[i], sensor, cfg.seed, uint64_t(f), &imgs[i].depth, &imgs[i].color);
      raw_depth[i] = imgs[i].depth;
      if (vda) {
        cv::Mat completed;
        depth_complete(imgs[i].depth, imgs[i].color, vda_prior[i], cv::Mat(), DepthCompleteOptions(), completed);
        plane_refine(completed, vda_planes[i], cv::Mat(), PlaneTolerance(), completed);
        imgs[i].depth = completed;
      }
      truth[i] = r.label.clone();
      seg[i].segment(imgs[i].color, imgs[i].depth, &labels[i]);
      // The cameras as viewwarp background-memory=N shows them: the sources for Table I, and all three for a
      // lecturer near camera 0 (camera 0's own colour stays Table I's truth).
      if (opt.memory > 0) {
        cv::Mat remembered;
        memories[i].update(imgs[i].color, labels[i], &remembered);
        if (i > 0) imgs[i].color = remembered;
        else camera0_remembered = remembered;
        all_rooms[size_t(i)].first.release();  // not shared with the last frame's layer
        memories[i].room_behind_learners(labels[i], priors[i], &all_rooms[size_t(i)].first,
                                         &all_rooms[size_t(i)].second);
        if (i > 0) rooms[i - 1] = all_rooms[size_t(i)];
      }
      const SegScore sc = score_segmentation(labels[i], truth[i]);
      iou[i].add(sc.fg_iou);
      learner_iou[i].add(sc.mean_learner_iou);
    }
    // "w/o V-DA" sees the sensor's depth as it came.
    std::vector<RgbdImages> raw_imgs{imgs[1], imgs[2]};
    raw_imgs[0].depth = raw_depth[1];
    raw_imgs[1].depth = raw_depth[2];
    const std::vector<RgbdImages> src_imgs{imgs[1], imgs[2]};
    const std::vector<cv::Mat> src_priors{priors[1], priors[2]};
    for (size_t c = 0; c < configs.size(); ++c) {
      const std::vector<cv::Mat> src_labels = configs[c].truth_labels ? std::vector<cv::Mat>{truth[1], truth[2]}
                                                                      : std::vector<cv::Mat>{labels[1], labels[2]};
      const std::vector<RgbdImages>& in = configs[c].static_prior ? src_imgs : raw_imgs;
      const auto* room_layers = opt.memory > 0 ? &rooms : nullptr;
      cv::Mat unseen;  // what no source sees now (the fusion's holes without the remembered room)
      if (c == 0 && room_layers) {
        synthesize(sources, in, src_priors, src_labels, configs[c], target, wp, fp, warpers, nullptr, &fused);
        unseen = fused.filled.clone();
      }
      synthesize(sources, in, src_priors, src_labels, configs[c], target, wp, fp, warpers, room_layers, &fused,
                 &histories[c * (1 + novel.size())]);
      if (c == 0) {
        if (unseen.empty()) unseen = fused.filled.clone();
        if (cv::countNonZero(unseen) > 0) hole_psnr.add(psnr_rgb_masked(fused.color, imgs[0].color, unseen));
        hole_share += double(cv::countNonZero(unseen)) / double(unseen.total()) / opt.frames;
        filled_holes.add(fused.color, imgs[0].color, fused.filled, cv::Rect(0, 0, fused.color.cols, fused.color.rows));
        if (room_views) {
          RoomViewPath& p = room_view;
          synthesize_room_view(p, sources, in, src_priors, src_labels, room_layers, target, wp, fp, &room_fused,
                               &p.histories[0]);
          p.psnr.add(psnr_rgb(room_fused.color, imgs[0].color));
          if (cv::countNonZero(unseen) > 0) p.unseen.add(psnr_rgb_masked(room_fused.color, imgs[0].color, unseen));
          p.holes.add(room_fused.color, imgs[0].color, room_fused.filled,
                      cv::Rect(0, 0, room_fused.color.cols, room_fused.color.rows));
          p.ssim.add(ssim_luma(room_fused.color, imgs[0].color));
          // Today's view and the room view of these poses from these sources, each against the truth.
          auto score_both = [&](const std::vector<CameraCalib>& poses, const std::vector<CameraCalib>& cams,
                                const std::vector<RgbdImages>& images, const std::vector<cv::Mat>& static_depths,
                                const std::vector<cv::Mat>& labelled, std::vector<ViewWarper>& warps,
                                const std::vector<std::pair<cv::Mat, cv::Mat>>* layers, RoomViewPath& path,
                                Stats* today, Stats* by_room) {
            FusedView view;
            for (const CameraCalib& v : poses) {
              RenderOutput gt;
              renderer.render(room, t, v, &gt);
              synthesize(cams, images, static_depths, labelled, configs[c], v, wp, fp, warps, layers, &view);
              today->add(psnr_rgb(view.color, gt.color));
              synthesize_room_view(path, cams, images, static_depths, labelled, layers, v, wp, fp, &view, nullptr);
              by_room->add(psnr_rgb(view.color, gt.color));
            }
          };
          std::vector<RgbdImages> near_imgs = imgs;
          if (!camera0_remembered.empty()) near_imgs[0].color = camera0_remembered;
          score_both(near_poses, all, near_imgs, priors, labels, near_warpers, opt.memory > 0 ? &all_rooms : nullptr,
                     near_room, &near_psnr, &near_room_psnr);
          score_both(own, sources, in, src_priors, src_labels, warpers, room_layers, p, &own_psnr, &own_room_psnr);
        }
      }
      psnr[c].add(psnr_rgb(fused.color, imgs[0].color));
      ssim[c].add(ssim_luma(fused.color, imgs[0].color));
      if (c == 0 && f == opt.frames - 1) {
        last_synth = fused.color.clone();
        last_real = imgs[0].color.clone();
      }
      for (size_t k = 0; k < novel.size(); ++k) {
        RenderOutput gt;
        renderer.render(room, t, novel[k], &gt);
        synthesize(sources, in, src_priors, src_labels, configs[c], novel[k], wp, fp, warpers, room_layers, &fused,
                   &histories[c * (1 + novel.size()) + 1 + k]);
        if (c == 0 && room_views) {
          RoomViewPath& p = room_view;
          synthesize_room_view(p, sources, in, src_priors, src_labels, room_layers, novel[k], wp, fp, &room_fused,
                               &p.histories[1 + k]);
          p.npsnr.add(psnr_rgb(room_fused.color, gt.color));
          p.nssim.add(ssim_luma(room_fused.color, gt.color));
        }
        npsnr[c].add(psnr_rgb(fused.color, gt.color));
        nssim[c].add(ssim_luma(fused.color, gt.color));
        if (c == 0 && k == 1 && f == opt.frames - 1 && !opt.images.empty())
          write_side_by_side(opt.images + "/vva-classroom-novel.png", fused.color, gt.color,
                             cv::Rect(0, 0, gt.color.cols, gt.color.rows));
      }
    }
  }
  std::printf("\n== Synthetic classroom (seed %llu, %d learners, sensor model on, %dx%d, %d frames at %.0f fps) ==\n",
              (unsigned long long)cfg.seed, cfg.learners, opt.width, opt.height, opt.frames, fps);
  if (vda)
    std::printf("V-DA: static layer = the model's prior depth (%s); sensor depth -> depthcomplete + planerefine, as live.\n",
                opt.model.c_str());
  else
    std::printf("Static prior = the empty room's clean depth rendered per camera: a STAND-IN for V-DA's static model.\n");
  std::printf("Leave-one-out: camera 0 synthesised from cameras 1 and 2, against camera 0's sensor image (Table I layout)\n");
  if (opt.memory > 0)
    std::printf("sources through a background memory of %d frames seeded with the empty room, as server.sh "
                "(--memory 0: off)\n",
                opt.memory);
  else
    std::printf("no background memory (--memory 0)\n");
  std::printf("%-52s | PSNR avg   max   min | SSIMx100 avg   max   min\n", "method");
  for (size_t c = 0; c < configs.size(); ++c)
    std::printf("%-52s | %7.2f %6.2f %6.2f | %11.2f %6.2f %6.2f\n", configs[c].name, psnr[c].avg(), psnr[c].max(),
                psnr[c].min(), 100 * ssim[c].avg(), 100 * ssim[c].max(), 100 * ssim[c].min());
  std::printf("full system on the pixels no source sees now (%.1f %% of camera 0, filled%s): PSNR %.2f dB avg, "
              "%.2f min\n",
              100 * hole_share, opt.memory > 0 ? " from the remembered room, then the hole filling" : " by the hole filling",
              hole_psnr.avg(), hole_psnr.min());
  std::printf("full system, %s (what the hole filling made)\n", filled_holes.line().c_str());
  std::printf("Novel lecturer poses %s, %s, %s (sliders around camera 0) against the exact renderer\n",
              novel_sliders[0].c_str(), novel_sliders[1].c_str(), novel_sliders[2].c_str());
  std::printf("%-52s | PSNR avg   max   min | SSIMx100 avg   max   min\n", "method");
  for (size_t c = 0; c < configs.size(); ++c)
    std::printf("%-52s | %7.2f %6.2f %6.2f | %11.2f %6.2f %6.2f\n", configs[c].name, npsnr[c].avg(), npsnr[c].max(),
                npsnr[c].min(), 100 * nssim[c].avg(), 100 * nssim[c].max(), 100 * nssim[c].min());
  if (room_views) {
    const RoomViewPath& p = room_view;
    std::printf("%-52s | Table I PSNR %.3f (full system %.3f) SSIMx100 %.2f (%.2f) | novel poses PSNR %.3f (%.3f) "
                "SSIMx100 %.2f (%.2f) | at the sources' places PSNR %.3f (%.3f) | near camera 0 from all three "
                "PSNR %.3f (%.3f) | filled %.1f %% of the pixels; Table I %s; Table I on the pixels no source sees "
                "PSNR %.2f dB (full system %.2f)\n",
                "room view (viewfuse room-view=true)", p.psnr.avg(), psnr[0].avg(), 100 * p.ssim.avg(),
                100 * ssim[0].avg(), p.npsnr.avg(), npsnr[0].avg(), 100 * p.nssim.avg(), 100 * nssim[0].avg(),
                own_room_psnr.avg(), own_psnr.avg(), near_room_psnr.avg(), near_psnr.avg(),
                100 * p.filled_share / std::max(1L, p.views),
                p.holes.line().c_str(), p.unseen.avg(), hole_psnr.avg());
  }
  std::printf("learnerseg against the ground-truth labels (IoU avg/min over frames):\n");
  for (int i = 0; i < 3; ++i)
    std::printf("  camera %d: foreground IoU %.3f / %.3f, per-learner IoU %.3f / %.3f\n", i, iou[i].avg(),
                iou[i].min(), learner_iou[i].avg(), learner_iou[i].min());
  if (!opt.images.empty())
    write_side_by_side(opt.images + "/vva-classroom-cam0.png", last_synth, last_real,
                       cv::Rect(0, 0, last_real.cols, last_real.rows));
}

void write_priors(const Options& opt) {
  const Rig rig = default_classroom_rig();
  const Classroom empty(ClassroomConfig{1, 0, 2.0});
  for (int id : {0, 1, 2}) {
    const RenderOutput e = render(empty, 0.0, scale_camera(rig.camera(id), opt.width, opt.height));
    const std::string path = opt.write_priors + "/prior-cam" + std::to_string(id) + ".png";
    if (!cv::imwrite(path, e.depth)) throw Error("cannot write " + path);
    std::printf("wrote %s\n", path.c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  g_autofree gchar *shared = nullptr, *images = nullptr, *only = nullptr, *size = nullptr, *priors_dir = nullptr,
        *model = nullptr, *dataset = nullptr, *sources = nullptr, *rig = nullptr, *out = nullptr, *fill = nullptr;
  gboolean mesh = FALSE, room_view = FALSE;
  opt.frames = 0;  // told apart from "not given" below
  const GOptionEntry entries[] = {
      {"shared", 0, 0, G_OPTION_ARG_FILENAME, &shared,
       "the shared data folder (default ../shared/data, relative to the repo root)", "DIR"},
      {"only", 0, 0, G_OPTION_ARG_STRING, &only, "one evaluation: classroom, middlebury or teddy (default all)",
       "NAME"},
      {"images", 0, 0, G_OPTION_ARG_FILENAME, &images,
       "write side-by-side PNGs (synthesised | real | error x4) there (made if missing)", "DIR"},
      {"frames", 0, 0, G_OPTION_ARG_INT, &opt.frames,
       "frames to average over: synthetic classroom (default 20), or with --dataset (default all)", "N"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size, "synthetic classroom camera size (default 960x540)", "WxH"},
      {"memory", 0, 0, G_OPTION_ARG_INT, &opt.memory,
       "classroom: show each source camera's static room through a background memory of N frames (viewwarp's "
       "background-memory; default 8, as pipelines/server.sh; 0: off)",
       "N"},
      {"fill-texture", 0, 0, G_OPTION_ARG_DOUBLE, &opt.fill_texture,
       "share of the background's texture the hole filling carries into a hole, as viewfuse's fill-texture "
       "(default 0: a smooth fill)",
       "T"},
      {"fill", 0, 0, G_OPTION_ARG_STRING, &fill,
       "the hole filling, as viewfuse's fill-method: pyramid (the default since issue 35) or rays (the fill "
       "before it)",
       "METHOD"},
      {"fill-smooth", 0, 0, G_OPTION_ARG_INT, &opt.fill_smooth_px,
       "the box blur over the filled pixels, radius in px (default: the method's own, 1 for pyramid next to a hole's border and 2 deeper in, 2 for rays; 0: none)", "PX"},
      {"boundary", 0, 0, G_OPTION_ARG_INT, &opt.boundary_px, "source pixels dropped next to depth edges (default 0)",
       "PX"},
      {"mesh", 0, 0, G_OPTION_ARG_NONE, &mesh,
       "warp with the triangle mesh rasteriser (reference) instead of the cell splat", nullptr},
      {"room-view", 0, 0, G_OPTION_ARG_NONE, &room_view,
       "classroom: also score the full system's view as viewfuse room-view=true makes it (the room rasterised from "
       "meshes and looked up backward, the learners warped alone), and both views at the sources' own places",
       nullptr},
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model,
       "V-DA's static model (vclassroom-build-model --synthetic, 960x540): the static layer is its prior depth "
       "and the sensor depth goes through depthcomplete + planerefine first, as in the live pipeline; without it "
       "the static layer is the empty room's exact depth (a stand-in)",
       "DIR"},
      {"dataset", 0, 0, G_OPTION_ARG_FILENAME, &dataset,
       "leave-one-out on this dataset folder (docs/dataset-format.md: imported, recorded or synthetic) instead of "
       "the built-in evaluations; needs --target and --sources; ends with the line 'PSNR NN.NN dB SSIM NN.NN'",
       "DIR"},
      {"target", 0, 0, G_OPTION_ARG_INT, &opt.target, "with --dataset: the camera to synthesise", "K"},
      {"sources", 0, 0, G_OPTION_ARG_STRING, &sources, "with --dataset: the cameras it is made from", "I,J"},
      {"crop-right", 0, 0, G_OPTION_ARG_INT, &opt.crop_right,
       "with --dataset: right columns of the target left out of the scores (default 0)", "N"},
      {"rig", 0, 0, G_OPTION_ARG_FILENAME, &rig,
       "with --dataset: warp with this rig's calibration instead of the dataset's (e.g. one from "
       "vclassroom-calibrate), scoring against the same images",
       "FILE"},
      {"out", 0, 0, G_OPTION_ARG_FILENAME, &out,
       "with --dataset: write synthesised | real | error PNGs of the first and last frame and a plot of PSNR per "
       "frame there (made if missing)",
       "DIR"},
      {"write-priors", 0, 0, G_OPTION_ARG_FILENAME, &priors_dir,
       "only write the empty classroom's clean depth for cameras 0..2 of the default rig as DIR/prior-cam<K>.png "
       "(16-bit mm), the stand-in for V-DA's model that learnerseg/viewwarp's prior-depth reads (made if missing)",
       "DIR"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Quality of the view algorithm (V-VA): leave-one-out on any dataset (--dataset), or the built-in "
      "evaluations on the synthetic classroom and Middlebury scenes.",
      entries);
  if (shared) opt.shared = shared;
  opt.images = vclassroom_tools::text_of(images);
  opt.only = vclassroom_tools::text_of(only);
  opt.mesh = mesh;
  opt.room_view = room_view;
  opt.write_priors = vclassroom_tools::text_of(priors_dir);
  opt.model = vclassroom_tools::text_of(model);
  if (size) vclassroom_tools::parse_size_or_exit("--size", size, &opt.width, &opt.height);
  opt.dataset = vclassroom_tools::text_of(dataset);
  opt.rig = vclassroom_tools::text_of(rig);
  opt.out = vclassroom_tools::text_of(out);
  if (opt.frames < 0) vclassroom_tools::usage_error("--frames must be at least 1");
  opt.dataset_frames = opt.frames;
  if (opt.frames == 0) opt.frames = 20;
  if (!opt.dataset.empty()) {
    if (opt.target < 0 || !sources) vclassroom_tools::usage_error("--dataset needs --target K and --sources I,J");
    gchar** ids = g_strsplit(sources, ",", -1);
    for (gchar** id = ids; *id; ++id) {
      char* end = nullptr;
      const long v = std::strtol(*id, &end, 10);
      if (end == *id || *end || v < 0 || v > 1000000) {
        g_strfreev(ids);
        vclassroom_tools::usage_error(std::string("--sources must be camera ids like 1,2 (got '") + sources + "')");
      }
      if (int(v) == opt.target) {
        g_strfreev(ids);
        vclassroom_tools::usage_error("--sources must not hold the --target camera");
      }
      opt.sources.push_back(int(v));
    }
    g_strfreev(ids);
    if (opt.sources.empty()) vclassroom_tools::usage_error("--sources names no camera");
  } else if (opt.target >= 0 || sources || rig || out || opt.crop_right) {
    vclassroom_tools::usage_error("--target, --sources, --rig, --crop-right and --out go with --dataset");
  }
  if (!opt.only.empty() && opt.only != "classroom" && opt.only != "middlebury" && opt.only != "teddy")
    vclassroom_tools::usage_error("--only must be classroom, middlebury or teddy (got '" + opt.only + "')");
  if (opt.frames < 1 || opt.boundary_px < 0) vclassroom_tools::usage_error("--frames must be at least 1, --boundary at least 0");
  if (fill) {
    const std::string method = fill;
    if (method == "pyramid")
      opt.fill_method = HoleFillMethod::Pyramid;
    else if (method == "rays")
      opt.fill_method = HoleFillMethod::Rays;
    else
      vclassroom_tools::usage_error("--fill must be pyramid or rays (got '" + method + "')");
  }
  if (opt.fill_smooth_px < -1 || opt.fill_smooth_px > 16) vclassroom_tools::usage_error("--fill-smooth must be 0 to 16");
  if (opt.fill_texture < 0 || opt.fill_texture > 1) vclassroom_tools::usage_error("--fill-texture must be 0 to 1");
  if (opt.memory < 0 || opt.memory > 64)
    vclassroom_tools::usage_error("--memory must be 0 (off) to 64 frames, as viewwarp's background-memory");
  for (const std::string& dir : {opt.images, opt.write_priors, opt.out})
    if (!dir.empty() && !vclassroom_tools::make_folder(dir)) return 1;
  try {
    if (!opt.write_priors.empty()) {
      write_priors(opt);
      return 0;
    }
    if (!opt.dataset.empty()) {
      eval_any_dataset(opt);
      return 0;
    }
    if (opt.only.empty() || opt.only == "classroom") eval_classroom(opt);
    if (opt.only.empty() || opt.only == "middlebury") eval_middlebury(opt);
    if (opt.only.empty() || opt.only == "teddy") eval_teddy(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vclassroom-eval-views: %s\n", e.what());
    return 1;
  }
  return 0;
}
