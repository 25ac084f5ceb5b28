// vclassroom-build-model: the static classroom model of V-DA (docs/vda.md).
// From a short capture of the empty room by every camera of a rig (a recorded
// dataset, or the synthetic classroom with learners=0 and the sensor model),
// refines the extrinsics by ICP, fuses the clouds, finds the planes and writes
// the model folder that depthcomplete and planerefine read.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include <gst/vclassroom/classroom.h>
#include <gst/vclassroom/dataset.h>
#include <gst/vclassroom/error.h>
#include <gst/vclassroom/static_model.h>

using namespace vclassroom;

static void usage() {
  std::cerr
      << "usage: vclassroom-build-model --out MODEL_FOLDER (--dataset FOLDER | --synthetic) [options]\n"
         "  --dataset FOLDER   recorded empty room (rig.yaml + cam<ID>/...), e.g. from rgbdfilesink\n"
         "  --synthetic        the synthetic classroom, empty (learners=0), sensor model on, default rig\n"
         "  --frames N         frames per camera to use (default 8)\n"
         "  --start I          first frame of the dataset (default 0)\n"
         "  --seed N           synthetic classroom seed (default 1; use rgbdtestsrc's seed)\n"
         "  --size WxH         synthetic camera size (default 960x540)\n"
         "  --no-icp           keep the rig's extrinsics\n"
         "  --align            re-align the rig frame: Y up from the floor, X along the largest wall\n"
         "  --voxel M          fused cloud voxel size in metres (default 0.01)\n"
         "  --no-plane-snap    leave the prior depth off the planes (V-DA's \"without planes\" ablation)\n";
}

int main(int argc, char** argv) {
  std::string out, dataset;
  bool synthetic = false, align = false;
  int frames = 8, start = 0, width = 960, height = 540;
  uint64_t seed = 1;
  StaticModelOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (k == "--out")
        out = next();
      else if (k == "--dataset")
        dataset = next();
      else if (k == "--synthetic")
        synthetic = true;
      else if (k == "--frames")
        frames = std::stoi(next());
      else if (k == "--start")
        start = std::stoi(next());
      else if (k == "--seed")
        seed = std::stoull(next());
      else if (k == "--size") {
        const std::string s = next();
        if (std::sscanf(s.c_str(), "%dx%d", &width, &height) != 2) throw std::invalid_argument(s);
      } else if (k == "--no-icp")
        o.refine_extrinsics = false;
      else if (k == "--align")
        align = true;
      else if (k == "--no-plane-snap")
        o.snap_planes = false;
      else if (k == "--voxel")
        o.voxel_m = std::stod(next());
      else {
        usage();
        return 2;
      }
    } catch (const std::exception&) {
      std::cerr << "vclassroom-build-model: bad value for " << k << "\n";
      return 2;
    }
  }
  if (out.empty() || synthetic == !dataset.empty() || frames < 1) {
    usage();
    return 2;
  }
  try {
    Rig rig;
    std::vector<CameraCapture> caps;
    if (synthetic) {
      rig = default_classroom_rig();
      for (CameraCalib& c : rig.cameras) c = scale_camera(c, width, height);
      ClassroomConfig cfg;
      cfg.seed = seed;
      cfg.learners = 0;
      const Classroom room(cfg);
      for (const CameraCalib& cam : rig.cameras) {
        const RenderOutput clean = render(room, 0.0, cam);
        CameraCapture c;
        c.camera_id = cam.id;
        for (int f = 0; f < frames; ++f) {
          cv::Mat depth, color;
          apply_sensor_model(clean, cam, SensorParams(), seed, static_cast<uint64_t>(f), &depth, &color);
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
    StaticModel m = build_static_model(rig, caps, o);
    if (align && !align_model_to_room(m)) std::cerr << "vclassroom-build-model: no floor plane found, not aligned\n";
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
