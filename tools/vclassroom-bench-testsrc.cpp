// Benchmark of the synthetic classroom (rgbdtestsrc's renderer and sensor
// model) on one thread, and the tool that draws the pictures of
// docs/synthetic-classroom.md.
//
//   vclassroom-bench-testsrc [--frames N] [--learners N] [--seed S] [--write-png DIR] [--time T]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/core/visualize.h>

#include "tool_options.h"

using namespace vclassroom;

namespace {

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) {
      const auto p = line.find(':');
      return p == std::string::npos ? line : line.substr(p + 2);
    }
  return "unknown";
}

// Documentation pictures are shrunk to 640x360 to keep the repository small.
void write_rgb(const std::string& path, const cv::Mat& rgb) {
  cv::Mat small, bgr;
  cv::resize(rgb, small, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
  cv::cvtColor(small, bgr, cv::COLOR_RGB2BGR);
  if (!cv::imwrite(path, bgr, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    std::exit(1);
  }
  std::printf("wrote %s\n", path.c_str());
}

// What the sensor model does to the default views and to a wall at 1, 3, 5 m:
// the figures quoted in docs/synthetic-classroom.md.
void print_sensor_ranges(const Classroom& room, const SensorParams& sp, uint64_t seed) {
  ClassroomRenderer r;
  RenderOutput out;
  cv::Mat depth, color;
  std::printf("sensor model, default views (30 frames each, share of pixels with clean depth):\n");
  for (const auto& cam : default_classroom_rig().cameras) {
    double holes = 0, fov = 0, valid = 0, edge = 0;
    for (int f = 0; f < 30; ++f) {
      r.render(room, f / 3.0, cam, &out);
      apply_sensor_model(out, cam, sp, seed, uint64_t(f), &depth, &color);
      const cv::Mat edges = sensor_edge_mask(out.depth, sp);
      for (int y = 0; y < out.depth.rows; ++y)
        for (int x = 0; x < out.depth.cols; ++x) {
          if (!out.depth.at<uint16_t>(y, x)) continue;
          ++valid;
          const double xn = (x - cam.cx) / cam.fx / sp.fov_ax, yn = (y - cam.cy) / cam.fy / sp.fov_ay;
          const bool outside = xn * xn + yn * yn > 1;
          fov += outside;
          edge += edges.at<uint8_t>(y, x) != 0;
          holes += depth.at<uint16_t>(y, x) == 0;
        }
    }
    std::printf("  camera %d: missing %.1f %% (outside the depth field of view %.1f %%, depth edges %.1f %%)\n",
                cam.id, 100 * holes / valid, 100 * fov / valid, 100 * edge / valid);
  }
  std::printf("sensor model, matte back wall seen head-on (4 frames, centre of a 320x240 view):\n");
  for (double d : {1.0, 3.0, 4.9}) {
    const double y = room.floor_y() + 1.5;
    const CameraCalib cam = look_at_camera({0.3, y, room.back_z() + d}, {0.3, y, room.back_z()}, 320, 240);
    r.render(room, 0, cam, &out);
    const cv::Mat edges = sensor_edge_mask(out.depth, sp);
    double s = 0, s2 = 0, n = 0, holes = 0;
    for (int f = 0; f < 4; ++f) {
      apply_sensor_model(out, cam, sp, seed, uint64_t(f), &depth, &color);
      for (int yy = 60; yy < 180; ++yy)
        for (int x = 80; x < 240; ++x) {
          const int zc = out.depth.at<uint16_t>(yy, x), zn = depth.at<uint16_t>(yy, x);
          if (!zc || edges.at<uint8_t>(yy, x) || std::abs(zc - 1000 * d) > 100 * d) continue;
          if (!zn) {
            ++holes;
            continue;
          }
          s += zn - zc;
          s2 += double(zn - zc) * (zn - zc);
          ++n;
        }
    }
    const double mean = s / n;
    std::printf("  %.1f m: noise sigma %.2f mm (model %.2f mm), bias %+.2f mm, missing %.1f %%\n", d,
                std::sqrt(s2 / n - mean * mean), sensor_depth_sigma_mm(sp, d), mean, 100 * holes / (holes + n));
  }
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 150, learners = 3;
  gint64 seed = 1;
  double t_png = 4.0;
  g_autofree gchar *png_arg = nullptr, *rig_arg = nullptr;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per camera (default 150)", "N"},
      {"learners", 0, 0, G_OPTION_ARG_INT, &learners, "learners in the classroom (default 3)", "N"},
      {"seed", 0, 0, G_OPTION_ARG_INT64, &seed, "scene and noise seed (default 1)", "S"},
      {"time", 0, 0, G_OPTION_ARG_DOUBLE, &t_png, "scene time of the pictures of --write-png (default 4 s)", "T"},
      {"write-png", 0, 0, G_OPTION_ARG_FILENAME, &png_arg,
       "write the documentation pictures there (made if missing) instead of timing", "DIR"},
      {"write-rig", 0, 0, G_OPTION_ARG_FILENAME, &rig_arg,
       "write the default rig (rgbdtestsrc's rig when none is given) as YAML and stop", "FILE"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Renders N frames per camera of the default rig at 960x540 on one thread, without and with the sensor\n"
      "model, and prints frames per second per camera.",
      entries);
  if (frames < 1 || learners < 0 || seed < 0)
    vclassroom_tools::usage_error("--frames must be at least 1, --learners and --seed at least 0");
  const std::string png_dir = vclassroom_tools::text_of(png_arg);
  if (rig_arg) {
    if (!vclassroom_tools::make_parent_folder(rig_arg)) return 1;
    try {
      save_rig(default_classroom_rig(), rig_arg);
    } catch (const Error& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
    return 0;
  }
  if (!png_dir.empty() && !vclassroom_tools::make_folder(png_dir)) return 1;
  try {
    ClassroomConfig cfg;
    cfg.seed = seed;
    cfg.learners = learners;
    const auto t_build0 = std::chrono::steady_clock::now();
    Classroom room(cfg);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_build0).count();
    const Rig rig = default_classroom_rig();
    ClassroomRenderer renderer;
    RenderOutput out;
    SensorParams sp;

    if (!png_dir.empty()) {
      cv::Mat depth, color;
      for (const auto& cam : rig.cameras) {
        renderer.render(room, t_png, cam, &out);
        apply_sensor_model(out, cam, sp, seed, 0, &depth, &color);
        // The sensor's colour noise does not show at this size but bloats the files: clean colour.
        write_rgb(png_dir + "/camera" + std::to_string(cam.id) + "-color.png", out.color);
        if (cam.id == 0) {
          cv::Mat vis;
          colorize_depth(out.depth, vis, 500, 6000);
          write_rgb(png_dir + "/camera0-depth-clean.png", vis);
          colorize_depth(depth, vis, 500, 6000);
          write_rgb(png_dir + "/camera0-depth-sensor.png", vis);
          cv::Mat lab;
          cv::Mat l8 = out.label * 60;
          cv::applyColorMap(l8, lab, cv::COLORMAP_HSV);
          lab.setTo(cv::Scalar(0, 0, 0), out.label == 0);
          cv::cvtColor(lab, lab, cv::COLOR_BGR2RGB);
          write_rgb(png_dir + "/camera0-label.png", lab);
        }
      }
      // Novel poses: the back of the room looking at the board, and the
      // lecturer's spot in front of the board looking at the class.
      const double fy = room.floor_y();
      CameraCalib back = look_at_camera({1.2, fy + 1.7, room.back_z() + 0.4}, {-0.3, fy + 1.1, room.front_z()});
      renderer.render(room, t_png, back, &out);
      write_rgb(png_dir + "/novel-back-to-board.png", out.color);
      CameraCalib lect = look_at_camera({-1.0, fy + 1.65, room.front_z() - 0.6}, {0.6, fy + 0.9, room.back_z()});
      renderer.render(room, t_png, lect, &out);
      write_rgb(png_dir + "/novel-lecturer.png", out.color);
      return 0;
    }

    std::printf("machine: %s (%u hardware threads; this benchmark uses one)\n", cpu_model().c_str(),
                std::max(1u, (unsigned)std::thread::hardware_concurrency()));
    std::printf("scene: seed %llu, %d learners, built in %.3f s\n", (unsigned long long)seed, learners, build_s);
    std::printf("frames per camera: %d at 960x540\n", frames);
    for (int pass = 0; pass < 2; ++pass) {
      const bool noise = pass == 1;
      cv::Mat depth, color;
      for (const auto& cam : rig.cameras) {
        // One warm-up frame so allocation is not timed.
        renderer.render(room, 0, cam, &out);
        const auto t0 = std::chrono::steady_clock::now();
        for (int f = 0; f < frames; ++f) {
          renderer.render(room, f / 30.0, cam, &out);
          if (noise) apply_sensor_model(out, cam, sp, seed, uint64_t(f), &depth, &color);
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("camera %d %-6s sensor-model %-3s: %7.1f frames/s (%.2f ms/frame)\n", cam.id, cam.name.c_str(),
                    noise ? "on" : "off", frames / s, 1000.0 * s / frames);
      }
    }
    print_sensor_ranges(room, sp, seed);
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
