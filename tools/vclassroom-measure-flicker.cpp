// Temporal stability of the lecturer's view (issue 15, item 4): the view from
// one fixed pose, rendered by the all-in-one chain (3 synthetic cameras with
// the sensor model and 6 learners -> learnerseg with the empty room's depth as
// prior -> viewwarp -> viewfuse) for N frames, against the ground truth the
// classroom renders for that virtual camera. On the static pixels (no learner
// in the truth at either frame) it reports the flicker, the mean absolute
// difference between consecutive frames (the truth's own is the floor), and the
// mean absolute error against the truth.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
using namespace vclassroom_tools;

namespace {

// Mean absolute difference per channel of two RGB images over `mask`'s non-zero pixels.
double mean_abs(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar sum = cv::sum(diff.setTo(cv::Scalar::all(0), mask == 0));
  const double n = cv::countNonZero(mask);
  return n > 0 ? (sum[0] + sum[1] + sum[2]) / (3.0 * n) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  gint frames = 300, memory = 0, precision = 2;
  gchar* out_dir = nullptr;
  gchar* fill = nullptr;
  gchar* room_view = nullptr;
  const GOptionEntry entries[] = {
      {"room-view", 0, 0, G_OPTION_ARG_STRING, &room_view,
       "viewfuse room-view: on (the default: the room from its meshes, the learners warped alone) or off", "on|off"},
      {"fill", 0, 0, G_OPTION_ARG_STRING, &fill,
       "viewfuse fill-method: pyramid (the default) or rays (the fill before issue 35)", "METHOD"},
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "Frames at 30 fps (default 300)", "N"},
      {"memory", 0, 0, G_OPTION_ARG_INT, &memory, "viewwarp background-memory (frames; default 0: off)", "N"},
      {"precision", 0, 0, G_OPTION_ARG_INT, &precision,
       "Decimals of the figures (default 2; 4 tells apart fills whose flicker differs by less than 0.01)", "N"},
      {"out", 0, 0, G_OPTION_ARG_FILENAME, &out_dir, "Also write the first and last rendered frame there", "DIR"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "Flicker of the lecturer's view on a fixed pose: consecutive-frame difference on static pixels "
                     "of the synthetic classroom, against the ground truth.",
                     entries, gst_init_get_option_group());
  if (frames < 10 || frames > 3000) usage_error("--frames must be 10 to 3000");
  if (memory < 0 || memory > 64) usage_error("--memory must be 0 to 64");
  if (precision < 0 || precision > 6) usage_error("--precision must be 0 to 6");
  const std::string fill_method = fill ? fill : "pyramid";
  if (fill_method != "pyramid" && fill_method != "rays") usage_error("--fill must be pyramid or rays");
  const std::string room_choice = room_view ? room_view : "on";
  if (room_choice != "on" && room_choice != "off") usage_error("--room-view must be on or off");
  const Rig rig = default_classroom_rig();
  // A novel view between the centre and the right camera, a little forward and turned.
  Pose pose = offset_to_pose(ViewOffset{0.3, 0.05, 0.4, 8, 2, 0}, rig.camera(0));
  pose.seq = 1;
  const CameraCalib virt = virtual_camera(rig.camera(0), pose.cam_to_rig(), std::nan(""));
  const std::string tmp = make_temp_dir("vclassroom-flicker");
  if (tmp.empty()) {
    std::fprintf(stderr, "%s: cannot make a temporary folder\n", g_get_prgname());
    return 1;
  }
  save_pose_trace({PoseSample{0.0, pose}}, tmp + "/pose.csv");
  ClassroomConfig empty;
  empty.learners = 0;
  const Classroom empty_room(empty);
  std::string desc = "viewfuse name=fuse fill-method=" + fill_method +
                     " room-view=" + (room_choice == "on" ? "true" : "false") +
                     " ! videoconvert ! video/x-raw,format=RGB ! appsink name=out sync=false";
  for (int k = 0; k < 3; ++k) {
    const std::string prior = tmp + "/prior" + std::to_string(k) + ".png";
    cv::imwrite(prior, render(empty_room, 0.0, rig.camera(k)).depth);
    desc += " rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 learners=6 num-buffers=" + std::to_string(frames) +
            " ground-truth=false ! learnerseg prior-depth=" + prior + " ! viewwarp background-memory=" +
            std::to_string(memory) + " prior-depth=" + prior +
            " pose-trace=" + tmp + "/pose.csv ! queue max-size-buffers=2 ! fuse.cam_" + std::to_string(k);
  }
  GError* err = nullptr;
  GstElement* pipe = gst_parse_launch(desc.c_str(), &err);
  if (!pipe) {
    std::fprintf(stderr, "%s: %s\n", g_get_prgname(), err ? err->message : "cannot build the chain");
    return 1;
  }
  GstElement* out = gst_bin_get_by_name(GST_BIN(pipe), "out");
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  ClassroomConfig cc;
  cc.learners = 6;
  const Classroom room(cc);
  Progress progress("frames", frames);
  cv::Mat prev, prev_truth, prev_label;
  double flicker = 0, truth_flicker = 0, error = 0, static_share = 0;
  int pairs = 0, got = 0;
  for (; got < frames; ++got) {
    GstSample* sample = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 120 * GST_SECOND);
    if (!sample) break;
    GstBuffer* b = gst_sample_get_buffer(sample);
    GstMapInfo map;
    cv::Mat frame;
    if (gst_buffer_map(b, &map, GST_MAP_READ)) {
      frame = cv::Mat(virt.height, virt.width, CV_8UC3, map.data, GST_ROUND_UP_4(virt.width * 3)).clone();
      gst_buffer_unmap(b, &map);
    }
    gst_sample_unref(sample);
    const RenderOutput truth = render(room, got / 30.0, virt);
    if (!prev.empty()) {
      const cv::Mat still = (truth.label == 0) & (prev_label == 0) & (truth.depth > 0);
      flicker += mean_abs(frame, prev, still);
      truth_flicker += mean_abs(truth.color, prev_truth, still);
      error += mean_abs(frame, truth.color, still);
      static_share += double(cv::countNonZero(still)) / still.total();
      ++pairs;
    }
    if (out_dir && (got == 0 || got == frames - 1)) {
      make_folder(out_dir);
      cv::Mat bgr;
      cv::cvtColor(frame, bgr, cv::COLOR_RGB2BGR);
      cv::imwrite(std::string(out_dir) + "/flicker-frame" + std::to_string(got) + ".png", bgr);
    }
    prev = frame;
    prev_truth = truth.color;
    prev_label = truth.label;
    progress.step(got + 1);
  }
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(out);
  gst_object_unref(pipe);
  std::error_code ec;
  std::filesystem::remove_all(tmp, ec);
  if (pairs == 0) {
    std::fprintf(stderr, "%s: the chain gave %d frames\n", g_get_prgname(), got);
    return 1;
  }
  std::printf("%d frames, %.1f %% of the view static in the truth\n", got, 100.0 * static_share / pairs);
  std::printf("static pixels: error against the truth %.*f grey levels per channel\n", precision, error / pairs);
  std::printf("flicker %.*f grey levels (ground truth %.*f)\n", precision, flicker / pairs, precision,
              truth_flicker / pairs);
  return 0;
}
