// vclassroom-build-model: the static classroom model of V-DA (docs/vda.md).
// From a short capture of the empty room by every camera of a rig (a recorded
// dataset, or the synthetic classroom with learners=0 and the sensor model),
// refines the extrinsics by ICP, fuses the clouds, finds the planes and writes
// the model folder that depthcomplete and planerefine read.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/vda/static_model.h>

#include "tool_options.h"

using namespace vclassroom;

int main(int argc, char** argv) {
  g_autofree gchar *out_arg = nullptr, *dataset_arg = nullptr, *size_arg = nullptr;
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
      {}};
  vclassroom_tools::parse_command_line(&argc, &argv, "", "Builds V-DA's static classroom model (docs/vda.md).",
                                       entries);
  const std::string out = vclassroom_tools::text_of(out_arg), dataset = vclassroom_tools::text_of(dataset_arg);
  if (out.empty()) vclassroom_tools::usage_error("--out FOLDER is required");
  if (synthetic == !dataset.empty()) vclassroom_tools::usage_error("give exactly one of --dataset FOLDER and --synthetic");
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
  } catch (const Error& e) {
    std::cerr << "vclassroom-build-model: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
