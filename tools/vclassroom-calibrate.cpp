// vclassroom-calibrate: the rig of a classroom's cameras from a printed
// checkerboard carried through the room (docs/real-classroom.md,
// "Calibrating"). Reads every camera through its own GStreamer source
// (rgbdsrc for real cameras, rgbdtestsrc with calibration-board=true for the
// synthetic classroom), takes a view whenever the board is held still at a new
// place, and writes rig.yaml in the paper's frame.
//
//   vclassroom-calibrate --synthetic --out DIR
//   vclassroom-calibrate --source 'rgbdsrc color-device=... depth-device=...' --source '...' --out DIR
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/rig_calibration.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/synthetic/board_trace.h>

#include "tool_options.h"

using namespace vclassroom;
using namespace vclassroom_tools;

namespace {

// Corners that moved less than this since the last frame: the board is held still.
constexpr double kStillPx = 0.75;
// Frames in a row the board must be still before a view is taken.
constexpr int kStillFrames = 3;
// A new view needs the board this far (mean corner travel) from the last one taken.
constexpr double kNewPlacePx = 25;
// The image is divided into this grid to report how much of it the corners covered.
constexpr int kCoverCols = 8, kCoverRows = 6;

struct Camera {
  GstElement* sink = nullptr;
  RgbdInfo info;
  GstClockTime pts = GST_CLOCK_TIME_NONE;
  cv::Mat gray, depth;
  std::optional<std::vector<cv::Point2f>> corners, previous, last_taken;
  int still = 0;
  std::vector<bool> covered = std::vector<bool>(kCoverCols * kCoverRows, false);
};

double mean_travel(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += cv::norm(a[i] - b[i]);
  return s / double(std::max<size_t>(1, a.size()));
}

double max_travel(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s = std::max(s, double(cv::norm(a[i] - b[i])));
  return s;
}

// A camera that sends nothing for this long (a stalled device) ends the run with an error.
constexpr int kSilentSeconds = 10;

// Pulls the next frame of `cam`; false at the end of its stream or on an error.
bool pull(Camera* cam, int index, GstBus* bus, std::string* error) {
  for (int waited_ms = 0;; waited_ms += 200) {
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      *error = std::string(GST_OBJECT_NAME(m->src)) + ": " + (e ? e->message : "?");
      g_clear_error(&e);
      gst_message_unref(m);
      return false;
    }
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(cam->sink), 200 * GST_MSECOND);
    if (!s) {
      if (gst_app_sink_is_eos(GST_APP_SINK(cam->sink))) return false;
      if (waited_ms >= kSilentSeconds * 1000) {
        *error = "camera " + std::to_string(index) + " (--source number " + std::to_string(index + 1) +
                 ") gave no frame for " + std::to_string(kSilentSeconds) + " s";
        return false;
      }
      continue;
    }
    std::string err;
    if (!rgbd_info_from_caps(gst_sample_get_caps(s), &cam->info, &err) || !cam->info.has(Plane::Color) ||
        !cam->info.has(Plane::Depth)) {
      *error = "a camera's stream is not video/x-rgbd with colour and depth: " + err;
      gst_sample_unref(s);
      return false;
    }
    RgbdFrame frame;
    if (!frame.map(gst_sample_get_buffer(s), cam->info, GST_MAP_READ, &err)) {
      std::fprintf(stderr, "vclassroom-calibrate: a frame dropped: %s\n", err.c_str());
      gst_sample_unref(s);
      continue;
    }
    cv::cvtColor(frame.color(), cam->gray, cv::COLOR_RGB2GRAY);
    frame.depth().copyTo(cam->depth);
    cam->pts = GST_BUFFER_PTS(gst_sample_get_buffer(s));
    frame.unmap();
    gst_sample_unref(s);
    return true;
  }
}

std::string pair_name(int a, int b) { return std::to_string(a) + "-" + std::to_string(b); }

void print_progress(const std::vector<Camera>& cams, const CalibrationCapture& cap) {
  const int n = int(cams.size());
  std::string line = "view " + std::to_string(cap.views.size()) + ": per camera";
  for (int c = 0; c < n; ++c) {
    int k = 0;
    for (const auto& v : cap.views) k += v[size_t(c)].has_value();
    const long cover = std::count(cams[size_t(c)].covered.begin(), cams[size_t(c)].covered.end(), true);
    line += " " + std::to_string(k) + " (" + std::to_string(100 * cover / (kCoverCols * kCoverRows)) + "% of image)";
  }
  if (n > 1) line += "; pairs";
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      int k = 0;
      for (const auto& v : cap.views) k += v[size_t(a)].has_value() && v[size_t(b)].has_value();
      line += " " + pair_name(a, b) + ": " + std::to_string(k);
    }
  std::printf("%s\n", line.c_str());
}

bool parse_points(const std::string& text, Eigen::Vector3d* a, Eigen::Vector3d* b) {
  char tail = 0;
  return std::sscanf(text.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf%c", &a->x(), &a->y(), &a->z(), &b->x(), &b->y(), &b->z(),
                     &tail) == 6;
}

}  // namespace

int main(int argc, char** argv) {
  gboolean synthetic = FALSE, no_depth_refine = FALSE;
  g_auto(GStrv) sources = nullptr;
  g_autofree gchar *out_dir = nullptr, *board_text = nullptr, *intrinsics = nullptr, *x_axis = nullptr,
                   *true_rig = nullptr, *base_rig = nullptr;
  double square_mm = 80;
  int max_views = 40, seconds = 300, reference = 0, learners = 0, fps = 5;
  const GOptionEntry entries[] = {
      {"synthetic", 0, 0, G_OPTION_ARG_NONE, &synthetic,
       "The three cameras of the synthetic classroom's default rig, sensor model on, with the board carried "
       "through the room; the result is compared with the true rig",
       nullptr},
      {"source", 0, 0, G_OPTION_ARG_STRING_ARRAY, &sources,
       "One camera: a gst-launch description giving video/x-rgbd with colour and depth (repeat per camera; the "
       "first is the reference)",
       "PIPELINE"},
      {"out", 0, 0, G_OPTION_ARG_FILENAME, &out_dir, "Folder to write rig.yaml into", "DIR"},
      {"board", 0, 0, G_OPTION_ARG_STRING, &board_text, "Inner corners of the checkerboard (default 9x6)", "COLSxROWS"},
      {"square-mm", 0, 0, G_OPTION_ARG_DOUBLE, &square_mm, "Side of one printed square in mm, measured (default 80)",
       "MM"},
      {"views", 0, 0, G_OPTION_ARG_INT, &max_views, "Stop after this many views of the board (default 40)", "N"},
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "Stop after this many seconds of stream (default 300)", "S"},
      {"reference", 0, 0, G_OPTION_ARG_INT, &reference, "Index of the camera at the rig's origin (default 0)", "N"},
      {"intrinsics", 0, 0, G_OPTION_ARG_STRING, &intrinsics,
       "Where each camera's focal length, centre and distortion come from: board (from the board's views; "
       "default with --source, as V4L2 cameras give none) or stream (the calibration in the stream's caps, "
       "i.e. the rig file given to the source; default with --synthetic)",
       "board|stream"},
      {"x-axis", 0, 0, G_OPTION_ARG_STRING, &x_axis,
       "The rig's X: wall (along the wall the reference camera faces, parallel to the front wall; default), camera "
       "(the reference camera's own x, levelled), or two points along the front wall in the reference camera's "
       "frame, metres",
       "wall|camera|X1,Y1,Z1,X2,Y2,Z2"},
      {"no-depth-refine", 0, 0, G_OPTION_ARG_NONE, &no_depth_refine,
       "Poses from the board's corners alone, without its plane in the depth", nullptr},
      {"base-rig", 0, 0, G_OPTION_ARG_FILENAME, &base_rig,
       "Keep each camera's name and depth lens (depth_to_color, depth_lens, depth_scale) from this rig file (e.g. the one rgbdsrc was given)", "FILE"},
      {"true-rig", 0, 0, G_OPTION_ARG_FILENAME, &true_rig,
       "Compare the result with this rig (with --synthetic: the default rig)", "FILE"},
      {"learners", 0, 0, G_OPTION_ARG_INT, &learners, "--synthetic: learners in the room (default 0)", "N"},
      {"fps", 0, 0, G_OPTION_ARG_INT, &fps, "--synthetic: frames per second rendered (default 5)", "N"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "", "The rig of all cameras from a checkerboard moved through the room.", entries,
                     gst_init_get_option_group());

  std::vector<std::string> descs;
  for (gchar** s = sources; s && *s; ++s) descs.emplace_back(*s);
  if (synthetic && !descs.empty()) usage_error("give --synthetic or --source, not both");
  if (!out_dir) usage_error("--out DIR is required");
  if (fps < 1 || fps > 60) usage_error("--fps must be 1..60");
  if (max_views < 2 || seconds < 1) usage_error("--views must be at least 2 and --seconds at least 1");
  CalibrationCapture cap;
  RigCalibrationOptions opt;
  Rig truth;
  bool compare = false;
  try {
    cap.board = board_text ? parse_board_size(board_text, square_mm / 1000, "--board")
                           : CalibrationBoard{9, 6, square_mm / 1000};
    validate_board(cap.board);
    if (true_rig) truth = load_rig(true_rig), compare = true;
  } catch (const Error& e) {
    usage_error(e.what());
  }
  if (synthetic) {
    truth = default_classroom_rig();
    compare = true;
    const long frames = std::lround(kBoardStops * kBoardStopSeconds * fps);
    for (int i = 0; i < 3; ++i)
      descs.push_back("rgbdtestsrc camera-id=" + std::to_string(i) + " calibration-board=true ground-truth=false learners=" +
                      std::to_string(learners) + " framerate=" + std::to_string(fps) + "/1 num-buffers=" +
                      std::to_string(frames));
  }
  if (descs.empty()) usage_error("give the cameras: --synthetic, or one --source per camera");
  if (reference < 0 || reference >= int(descs.size())) usage_error("--reference must name one of the cameras");
  opt.reference = reference;
  opt.depth_refine = !no_depth_refine;
  const std::string intr = text_of(intrinsics).empty() ? (synthetic ? "stream" : "board") : text_of(intrinsics);
  if (intr != "stream" && intr != "board") usage_error("--intrinsics must be board or stream");
  opt.intrinsics_from_board = intr == "board";
  const std::string xa = text_of(x_axis);
  if (xa.empty() || xa == "wall") opt.x_axis = XAxisFrom::Wall;
  else if (xa == "camera") opt.x_axis = XAxisFrom::Camera;
  else if (parse_points(xa, &opt.x_from, &opt.x_to)) opt.x_axis = XAxisFrom::Points;
  else usage_error("--x-axis must be wall, camera or X1,Y1,Z1,X2,Y2,Z2");

  // One pipeline for all cameras, each into its own appsink.
  std::string launch;
  for (size_t i = 0; i < descs.size(); ++i)
    launch += descs[i] + " ! appsink name=cam" + std::to_string(i) + " sync=false max-buffers=1  ";
  GError* err = nullptr;
  GstElement* pipeline = gst_parse_launch(launch.c_str(), &err);
  if (!pipeline || err) {
    std::fprintf(stderr, "vclassroom-calibrate: cannot build the cameras' pipeline: %s\n", err ? err->message : "?");
    return 1;
  }
  std::vector<Camera> cams(descs.size());
  for (size_t i = 0; i < cams.size(); ++i)
    cams[i].sink = gst_bin_get_by_name(GST_BIN(pipeline), ("cam" + std::to_string(i)).c_str());
  GstBus* bus = gst_element_get_bus(pipeline);
  // Live cameras keep running while a frame is looked at: keep only the newest.
  if (gst_element_set_state(pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_NO_PREROLL)
    for (auto& c : cams) gst_app_sink_set_drop(GST_APP_SINK(c.sink), TRUE);

  std::string error;
  GstClockTime first = GST_CLOCK_TIME_NONE;
  bool running = true;
  GstClockTime skew = 20 * GST_MSECOND;  // half a frame, once the caps say the rate
  while (running && int(cap.views.size()) < max_views) {
    // One frame per camera, at the same instant (within half a frame).
    for (size_t i = 0; i < cams.size() && running; ++i)
      if (!pull(&cams[i], int(i), bus, &error)) running = false;
    for (int tries = 0; running && tries < 30; ++tries) {
      GstClockTime newest = 0;
      for (auto& c : cams) newest = std::max(newest, c.pts);
      if (GST_CLOCK_TIME_IS_VALID(cams[0].info.frame_duration())) skew = cams[0].info.frame_duration() / 2;
      bool behind = false;
      for (size_t i = 0; i < cams.size() && running; ++i)
        if (cams[i].pts + skew < newest) {
          behind = true;
          if (!pull(&cams[i], int(i), bus, &error)) running = false;
        }
      if (!behind) break;
    }
    if (!running) break;
    if (first == GST_CLOCK_TIME_NONE) {
      first = cams[0].pts;
      for (auto& c : cams) cap.room_depth.push_back(c.depth.clone());
    }
    if (cams[0].pts - first > GstClockTime(seconds) * GST_SECOND) break;

    bool all_still = true, any = false, moved = false;
    for (auto& c : cams) {
      c.previous = std::move(c.corners);
      c.corners = detect_board(c.gray, cap.board);
      if (!c.corners) continue;
      any = true;
      c.still = c.previous && max_travel(*c.corners, *c.previous) < kStillPx ? c.still + 1 : 0;
      all_still = all_still && c.still >= kStillFrames - 1;
      moved = moved || !c.last_taken || mean_travel(*c.corners, *c.last_taken) > kNewPlacePx;
    }
    if (!any || !all_still || !moved) continue;
    std::vector<std::optional<BoardSighting>> view(cams.size());
    for (size_t i = 0; i < cams.size(); ++i) {
      Camera& c = cams[i];
      if (!c.corners) continue;
      BoardSighting s;
      s.corners = *c.corners;
      s.depth_samples = board_depth_samples(cap.board, s.corners, c.depth);
      view[i] = std::move(s);
      c.last_taken = c.corners;
      for (const auto& p : *c.corners) {
        const int gx = std::clamp(int(p.x * kCoverCols / c.info.width()), 0, kCoverCols - 1);
        const int gy = std::clamp(int(p.y * kCoverRows / c.info.height()), 0, kCoverRows - 1);
        c.covered[size_t(gy * kCoverCols + gx)] = true;
      }
    }
    cap.views.push_back(std::move(view));
    print_progress(cams, cap);
  }
  gst_element_set_state(pipeline, GST_STATE_NULL);
  for (auto& c : cams) gst_object_unref(c.sink);
  gst_object_unref(bus);
  gst_object_unref(pipeline);
  if (!error.empty()) {
    std::fprintf(stderr, "vclassroom-calibrate: %s\n", error.c_str());
    return 1;
  }
  if (cap.room_depth.size() != cams.size()) {
    std::fprintf(stderr, "vclassroom-calibrate: the cameras gave no frame\n");
    return 1;
  }

  for (auto& c : cams) {
    CameraCalib cam = c.info.camera;
    if (opt.intrinsics_from_board) cam.fx = cam.fy = cam.cx = cam.cy = 0, cam.distortion = {};
    cap.cameras.push_back(cam);
  }
  RigCalibrationReport report;
  try {
    if (base_rig) {
      const Rig base = load_rig(base_rig);
      for (auto& cam : cap.cameras)
        if (const CameraCalib* b = base.find(cam.id)) {
          cam.name = b->name;
          cam.depth_to_color = b->depth_to_color;
          cam.depth_lens = b->depth_lens;
          cam.depth_scale = b->depth_scale;
        }
    }
    report = calibrate_rig(cap, opt);
  } catch (const Error& e) {
    std::fprintf(stderr, "vclassroom-calibrate: %s\n", e.what());
    return 1;
  }
  for (size_t i = 0; i < cams.size(); ++i) {
    const CameraCalib& c = report.rig.cameras[i];
    std::printf("camera %d: %d views, reprojection %.2f px, board depth %.1f mm rms, intrinsics from %s "
                "(fx %.1f fy %.1f cx %.1f cy %.1f)\n",
                c.id, report.views[i], report.reprojection_px[i], report.depth_plane_mm[i],
                report.intrinsics_from_board[i] ? "the board" : "the stream", c.fx, c.fy, c.cx, c.cy);
  }
  for (const auto& p : report.pairs)
    std::printf("cameras %s: %d shared views, corners agree within %.1f mm (mean)\n", pair_name(p.a, p.b).c_str(),
                p.views, p.agreement_mm);
  std::printf("floor: cameras agree within %.2f deg; reference camera %.2f m above it; X from %s\n",
              report.floor_spread_deg, report.camera_height_m, report.x_axis_from.c_str());
  if (!make_folder(out_dir)) return 1;
  const std::string path = std::string(out_dir) + "/rig.yaml";
  try {
    save_rig(report.rig, path);
  } catch (const Error& e) {
    std::fprintf(stderr, "vclassroom-calibrate: %s\n", e.what());
    return 1;
  }
  std::printf("wrote %s\n", path.c_str());
  if (compare) {
    try {
      const RigError e = compare_rigs(report.rig, truth, report.rig.cameras[size_t(reference)].id);
      std::printf("rig error: max %.2f cm, max %.2f deg, floor %.2f deg\n", e.max_position_cm, e.max_rotation_deg,
                  e.floor_deg);
    } catch (const Error& e) {
      std::fprintf(stderr, "vclassroom-calibrate: cannot compare with the true rig: %s\n", e.what());
      return 1;
    }
  }
  return 0;
}
