// vclassroom-build-model: the static classroom model of V-DA (docs/vda.md).
// From a short capture of the empty room by every camera of a rig (a recorded
// dataset, or the synthetic classroom with learners=0 and the sensor model),
// refines the extrinsics by ICP, fuses the clouds, finds the planes and writes
// the model folder that depthcomplete and planerefine read; its rig.yaml gets
// the navigation bounds (docs/navigation.md): where a lecturer's view stays
// covered by the cameras.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/vva/navigation.h>

#include "tool_options.h"

using namespace vclassroom;

int main(int argc, char** argv) {
  g_autofree gchar *out_arg = nullptr, *dataset_arg = nullptr, *size_arg = nullptr, *map_arg = nullptr;
  double coverage = 0.91;
  int reference_camera = -1;
  gboolean synthetic = FALSE, align = FALSE, no_icp = FALSE, no_plane_snap = FALSE;
  int frames = 8, start = 0, width = 960, height = 540;
  gint64 seed = 1;
  StaticModelOptions o;
  const GOptionEntry entries[] = {
      {"out", 0, 0, G_OPTION_ARG_FILENAME, &out_arg, "model folder to write (made with its parents)", "FOLDER"},
      {"dataset", 0, 0, G_OPTION_ARG_FILENAME, &dataset_arg,
       "recorded empty room (rig.yaml + cam<ID>/...), e.g. from rgbdfilesink", "FOLDER"},
      {"synthetic", 0, 0, G_OPTION_ARG_NONE, &synthetic,
       "the synthetic classroom, empty (learners=0), sensor model on, default rig", nullptr},
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per camera to use (default 8)", "N"},
      {"start", 0, 0, G_OPTION_ARG_INT, &start, "first frame of the dataset (default 0)", "I"},
      {"seed", 0, 0, G_OPTION_ARG_INT64, &seed, "synthetic classroom seed (default 1; use rgbdtestsrc's seed)", "N"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size_arg, "synthetic camera size (default 960x540)", "WxH"},
      {"no-icp", 0, 0, G_OPTION_ARG_NONE, &no_icp, "keep the rig's extrinsics", nullptr},
      {"align", 0, 0, G_OPTION_ARG_NONE, &align, "re-align the rig frame: Y up from the floor, X along the largest wall",
       nullptr},
      {"voxel", 0, 0, G_OPTION_ARG_DOUBLE, &o.voxel_m, "fused cloud voxel size in metres (default 0.01)", "M"},
      {"no-plane-snap", 0, 0, G_OPTION_ARG_NONE, &no_plane_snap,
       "leave the prior depth off the planes (V-DA's \"without planes\" ablation)", nullptr},
      {"coverage", 0, 0, G_OPTION_ARG_DOUBLE, &coverage,
       "navigation bounds (docs/navigation.md) where the cameras see at least this share of the lecturer's view, "
       "written into the model's rig.yaml (default 0.91; 0: none)",
       "SHARE"},
      {"reference-camera", 0, 0, G_OPTION_ARG_INT, &reference_camera,
       "the camera the navigation bounds are relative to (default the rig's first)", "ID"},
      {"coverage-map", 0, 0, G_OPTION_ARG_FILENAME, &map_arg,
       "also write the coverage map: CSV of right,up,forward (m, every 0.5 m), yaw,pitch (deg, every 15), coverage",
       "FILE"},
      {}};
  vclassroom_tools::parse_command_line(&argc, &argv, "", "Builds V-DA's static classroom model (docs/vda.md).",
                                       entries);
  const std::string out = vclassroom_tools::text_of(out_arg), dataset = vclassroom_tools::text_of(dataset_arg);
  if (out.empty()) vclassroom_tools::usage_error("--out FOLDER is required");
  if (synthetic == !dataset.empty()) vclassroom_tools::usage_error("give exactly one of --dataset FOLDER and --synthetic");
  if (!(coverage >= 0 && coverage <= 1)) vclassroom_tools::usage_error("--coverage must be 0 to 1");
  if (frames < 1 || start < 0 || seed < 0 || !(o.voxel_m > 0))
    vclassroom_tools::usage_error("--frames must be at least 1, --start, --seed at least 0, --voxel above 0");
  if (size_arg) vclassroom_tools::parse_size_or_exit("--size", size_arg, &width, &height);
  o.refine_extrinsics = !no_icp;
  o.snap_planes = !no_plane_snap;
  // Before hours of work, not after: the folder must be writable.
  if (!vclassroom_tools::make_folder(out)) return 1;
  try {
    Rig rig;
    std::vector<CameraCapture> caps;
    if (synthetic) {
      rig = default_classroom_rig();
      for (CameraCalib& c : rig.cameras) c = scale_camera(c, width, height);
      ClassroomConfig cfg;
      cfg.seed = static_cast<uint64_t>(seed);
      cfg.learners = 0;
      const Classroom room(cfg);
      for (const CameraCalib& cam : rig.cameras) {
        std::fprintf(stderr, "vclassroom-build-model: rendering camera %d, %d frames\n", cam.id, frames);
        const RenderOutput clean = render(room, 0.0, cam);
        CameraCapture c;
        c.camera_id = cam.id;
        for (int f = 0; f < frames; ++f) {
          cv::Mat depth, color;
          apply_sensor_model(clean, cam, SensorParams(), static_cast<uint64_t>(seed), static_cast<uint64_t>(f), &depth, &color);
          c.depth.push_back(depth);
          if (f == 0) c.color = color;
        }
        caps.push_back(c);
      }
    } else {
      const Dataset ds = Dataset::open(dataset);
      rig = ds.rig();
      for (const CameraCalib& cam : rig.cameras) {
        const size_t n = ds.frame_count(cam.id);
        if (n <= static_cast<size_t>(start))
          throw Error(dataset + ": camera " + std::to_string(cam.id) + " has " + std::to_string(n) +
                      " frames, none from frame " + std::to_string(start));
        std::fprintf(stderr, "vclassroom-build-model: reading camera %d\n", cam.id);
        CameraCapture c;
        c.camera_id = cam.id;
        for (size_t f = start; f < n && f < static_cast<size_t>(start + frames); ++f) {
          RgbdImages im = ds.load(cam.id, f);
          if (im.depth.empty())
            throw Error(dataset + ": camera " + std::to_string(cam.id) + " has no depth; every camera needs depth");
          c.depth.push_back(im.depth);
          if (c.color.empty()) c.color = im.color;
        }
        caps.push_back(c);
      }
    }
    const auto t0 = std::chrono::steady_clock::now();
    std::fprintf(stderr, "vclassroom-build-model: refining extrinsics, fusing the clouds, finding the planes\n");
    StaticModel m = build_static_model(rig, caps, o);
    if (align && !align_model_to_room(m)) std::cerr << "vclassroom-build-model: no floor plane found, not aligned\n";
    if (coverage > 0 || map_arg) {
      const int ref = reference_camera >= 0 ? reference_camera : m.rig.cameras.front().id;
      std::vector<cv::Mat> priors;
      for (const CameraCalib& c : m.rig.cameras) priors.push_back(m.prior(c.id));
      CoverageEstimator estimator(m.rig.cameras, priors, m.rig.camera(ref));
      NavigationSearch search;
      if (coverage > 0) {
        search.threshold = coverage;
        std::fprintf(stderr, "vclassroom-build-model: navigation bounds at %.0f %% coverage\n", 100 * coverage);
        m.rig.navigation = derive_navigation(estimator, ref, search, [](const std::string& s) {
          std::fprintf(stderr, "vclassroom-build-model: %s\n", s.c_str());
        });
      }
      if (map_arg) {
        std::unique_ptr<vclassroom_tools::Progress> progress;
        const auto map = coverage_map(estimator, search, 0.5, 15, [&](size_t done, size_t total) {
          if (!progress) progress = std::make_unique<vclassroom_tools::Progress>("coverage map views", long(total));
          progress->step(long(done));
        });
        FILE* f = std::fopen(map_arg, "w");
        if (!f) throw Error(std::string(map_arg) + ": cannot write the coverage map");
        std::fprintf(f, "right,up,forward,yaw,pitch,coverage\n");
        for (const CoverageSample& s : map)
          std::fprintf(f, "%.2f,%.2f,%.2f,%.1f,%.1f,%.4f\n", s.offset.right, s.offset.up, s.offset.forward, s.offset.yaw,
                       s.offset.pitch, s.coverage);
        std::fclose(f);
      }
    }
    std::fprintf(stderr, "vclassroom-build-model: writing %s\n", out.c_str());
    save_static_model(m, out);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("model of %zu cameras, %d frames each, built in %.1f s -> %s\n", rig.cameras.size(), frames, s,
                out.c_str());
    std::printf("fused cloud: %zu points (voxel %.3f m)\n", m.points.size(), o.voxel_m);
    for (const ExtrinsicsChange& c : m.refinement)
      std::printf("ICP camera %d: moved %.2f mm, %.3f deg; point-to-plane RMS %.2f -> %.2f mm (%d pairs)\n",
                  c.camera_id, c.translation_mm, c.rotation_deg, c.rms_before_mm, c.rms_after_mm, c.pairs);
    for (const RoomPlane& p : m.planes)
      std::printf("plane %-7s normal (%+.3f %+.3f %+.3f) offset %+.3f m, %d points\n", p.name.c_str(), p.normal.x(),
                  p.normal.y(), p.normal.z(), p.offset, p.inliers);
    for (const auto& [id, measured] : m.prior_measured)
      std::printf("prior camera %d: %.1f %% measured by no camera (completed%s)\n", id,
                  100.0 * (1.0 - double(cv::countNonZero(measured)) / double(measured.total())),
                  o.close_room ? ", kept inside the room" : "");
    if (const auto& b = m.rig.navigation)
      std::printf("navigation (camera %d, %.0f %% covered): right %.2f..%.2f, up %.2f..%.2f, forward %.2f..%.2f m; "
                  "yaw %.1f..%.1f, pitch %.1f..%.1f, roll %.1f..%.1f deg\n",
                  b->reference_camera, 100 * b->coverage, b->min[0], b->max[0], b->min[1], b->max[1], b->min[2],
                  b->max[2], b->min[3], b->max[3], b->min[4], b->max[4], b->min[5], b->max[5]);
  } catch (const Error& e) {
    std::cerr << "vclassroom-build-model: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
