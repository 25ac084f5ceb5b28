// How much of the lecturer's view is invented when the lecturer tries to
// leave what the cameras see (docs/navigation.md): a scripted walk on the
// synthetic classroom that turns to the side wall, walks out sideways, looks
// at the ceiling and backs away, rendered as the server renders it (the
// cameras' frames warped with V-DA's static layer, fused), once as before
// (poses as asked, holes filled from the nearest pixels) and once with the
// model's navigation bounds and the honest edge. Prints the share of unseen
// pixels per frame for both and writes the worst frame of each.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/datasets/dataset.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/vva/navigation.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "tool_options.h"

using namespace vclassroom;

namespace {

// The walk: 15 frames each of turning right to 60°, walking 2 m to the right,
// looking up to 70° and backing off 1.5 m while rising 0.8 m.
ViewOffset walk(int f) {
  const double s = std::min(1.0, (f % 15) / 14.0);
  ViewOffset o;
  const int phase = f / 15;
  o.yaw = phase == 0 ? 60 * s : (phase == 1 ? 60 : 0);
  o.right = phase == 1 ? 2 * s : 0;
  o.pitch = phase == 2 ? 70 * s : 0;
  o.forward = phase == 3 ? -1.5 * s : 0;
  o.up = phase == 3 ? 0.8 * s : 0;
  return o;
}

// At half size: a picture for the docs, not a measurement.
void write_rgb(const std::string& path, const cv::Mat& rgb) {
  cv::Mat bgr, half;
  cv::resize(rgb, half, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  cv::cvtColor(half, bgr, cv::COLOR_RGB2BGR);
  if (!cv::imwrite(path, bgr)) throw Error("cannot write " + path);
  std::printf("wrote %s\n", path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  g_autofree gchar *model_arg = nullptr, *images_arg = nullptr;
  const GOptionEntry entries[] = {
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model_arg,
       "V-DA's model of the synthetic classroom with navigation bounds (vclassroom-build-model --synthetic --out "
       "DIR; default out/model)",
       "DIR"},
      {"images", 0, 0, G_OPTION_ARG_FILENAME, &images_arg,
       "write the frame where most is unseen (below 60 %) at half size: before (navigation-before.png), the pose "
       "as asked with the honest edge (navigation-edge.png), and with the bounds too (navigation-after.png)",
       "DIR"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "The share of the lecturer's view no camera sees along a walk that tries to leave the room, without and with "
      "the navigation bounds and the honest edge.",
      entries);
  const std::string model_dir = model_arg ? model_arg : "out/model", images = vclassroom_tools::text_of(images_arg);
  if (!images.empty() && !vclassroom_tools::make_folder(images)) return 1;
  try {
    const StaticModel model = load_static_model(model_dir);
    if (!model.rig.navigation)
      throw Error(model_dir + "/rig.yaml has no navigation section (vclassroom-build-model writes one)");
    const Rig& rig = model.rig;
    const CameraCalib& reference = rig.camera(rig.navigation->reference_camera);
    NavigationClamp clamp(rig);
    const Classroom room(ClassroomConfig{1, 6, 2.0});
    ClassroomRenderer renderer;
    std::vector<ViewWarper> warpers(rig.cameras.size());
    std::vector<WarpedView> warped(rig.cameras.size());
    FuseParams before_params, after_params;
    before_params.fade_unseen = false;
    const int frames = 60;
    std::vector<double> before(frames), after(frames);
    int worst = 0;
    cv::Mat worst_before, worst_after, worst_edge;
    std::printf("frame   right     up forward    yaw  pitch | unseen before | after (clamped pose)\n");
    vclassroom_tools::Progress progress("walk frames", frames);
    for (int f = 0; f < frames; ++f) {
      progress.step(f + 1);
      const double t = f / 10.0;
      std::vector<RgbdImages> in(rig.cameras.size());
      std::vector<cv::Mat> labels(rig.cameras.size());
      for (size_t i = 0; i < rig.cameras.size(); ++i) {
        RenderOutput r;
        renderer.render(room, t, rig.cameras[i], &r);
        apply_sensor_model(r, rig.cameras[i], SensorParams(), 1, uint64_t(f), &in[i].depth, &in[i].color);
        labels[i] = r.label;  // the learners as learnerseg would find them
      }
      auto render_view = [&](const Pose& pose, const FuseParams& params, FusedView* out) {
        const CameraCalib virt = virtual_camera(reference, pose.cam_to_rig(), std::nan(""));
        std::vector<const WarpedView*> views;
        for (size_t i = 0; i < rig.cameras.size(); ++i) {
          const CameraCalib& c = rig.cameras[i];
          warpers[i].warp(c, WarpSource{in[i].color, in[i].depth, labels[i], model.prior(c.id)}, virt, WarpParams(),
                          &warped[i]);
          views.push_back(&warped[i]);
        }
        fuse_views(views, params, out);
      };
      const ViewOffset o = walk(f);
      Pose pose = offset_to_pose(o, reference);
      FusedView a, b;
      render_view(pose, before_params, &a);
      std::string warning;
      clamp.apply(&pose, 0, "the walk", &warning);
      render_view(pose, after_params, &b);
      before[f] = a.unseen_share;
      after[f] = b.unseen_share;
      std::printf("%5d %7.2f %6.2f %7.2f %6.1f %6.1f | %12.1f %% | %5.1f %%\n", f, o.right, o.up, o.forward, o.yaw,
                  o.pitch, 100 * before[f], 100 * after[f]);
      // The frame to show: the most unseen while something is still seen
      // (a view of nothing but the ceiling shows nothing to compare).
      if (f == 0 || (before[f] > before[worst] && before[f] < 0.6)) {
        worst = f;
        worst_before = a.color.clone();
        worst_after = b.color.clone();
        FusedView edge;  // the pose as asked, with the honest edge alone
        render_view(offset_to_pose(o, reference), after_params, &edge);
        worst_edge = edge.color.clone();
      }
    }
    const auto mean = [](const std::vector<double>& v) {
      double s = 0;
      for (double x : v) s += x;
      return s / double(v.size());
    };
    std::printf("unseen share per frame: before mean %.1f %%, max %.1f %%; after mean %.1f %%, max %.1f %%; "
                "%d poses clamped\n",
                100 * mean(before), 100 * *std::max_element(before.begin(), before.end()), 100 * mean(after),
                100 * *std::max_element(after.begin(), after.end()), int(clamp.clamped()));
    if (!images.empty()) {
      write_rgb(images + "/navigation-before.png", worst_before);
      write_rgb(images + "/navigation-edge.png", worst_edge);
      write_rgb(images + "/navigation-after.png", worst_after);
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "vclassroom-measure-navigation: %s\n", e.what());
    return 1;
  }
  return 0;
}
