// Speed of the V-VA server stages (docs/vva.md): learnerseg per camera,
// viewwarp per camera, viewfuse, on synthetic classroom frames with the
// sensor model, as frames per second; and how the cost grows with the output
// resolution and the number of cameras. GStreamer-free (the algorithms the
// elements call), so it measures the algorithms, not the pipeline overhead.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/background_memory.h>
#include <gst/vclassroom/vva/learner_seg.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "cpu_clock.h"
#include "tool_options.h"

using namespace vclassroom;
using Clock = std::chrono::steady_clock;

namespace {

struct Camera {
  CameraCalib calib;
  std::vector<cv::Mat> color, depth;  // recorded frames, played in a loop
  cv::Mat prior;
  LearnerSegmenter seg;
  BackgroundMemory memory;  // --memory: seeded with the empty room
  ViewWarper warper;
  cv::Mat label;
  WarpedView warped;
};

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

using vclassroom_tools::process_cpu_ms;
using vclassroom_tools::thread_cpu_ms;

struct Result {
  double seg_ms = 0, memory_ms = 0, warp_ms = 0, fuse_ms = 0;  // CPU time per frame, summed over cameras
  double total_ms = 0;                          // wall time per frame
  double cpu_ms = 0;  // process CPU time per frame: what the work costs whatever the load
};

// The rig's cameras `ids`, each with `recorded` frames of `room` (sensor model on) to play in a loop, the
// empty room's depth as their static layer (with `model`) and a background memory of `memory` frames
// seeded with the empty room (memory > 0); each camera's view of the empty room into `empty_rooms`.
std::vector<Camera> record_cameras(const Rig& rig, const std::vector<int>& ids, const Classroom& room,
                                   const Classroom& empty, int recorded, bool model, int memory,
                                   std::vector<cv::Mat>* empty_rooms) {
  std::vector<Camera> cams(ids.size());
  empty_rooms->clear();
  ClassroomRenderer renderer;
  for (size_t i = 0; i < ids.size(); ++i) {
    Camera& c = cams[i];
    c.calib = rig.camera(ids[i]);
    RenderOutput e;
    renderer.render(empty, 0.0, c.calib, &e);
    empty_rooms->push_back(e.color);
    if (model) {
      c.prior = e.depth.clone();
      c.seg.set_static_depth(c.prior);
    }
    if (memory > 0) {
      BackgroundMemoryParams mp;
      mp.frames = memory;
      c.memory = BackgroundMemory(mp);
      c.memory.seed(e.color);
    }
    for (int f = 0; f < recorded; ++f) {
      RenderOutput r;
      renderer.render(room, f / 30.0, c.calib, &r);
      cv::Mat d, col;
      apply_sensor_model(r, c.calib, SensorParams(), 1, uint64_t(f), &d, &col);
      c.color.push_back(col);
      c.depth.push_back(d);
    }
  }
  return cams;
}

// One server step per frame: every camera segmented and warped (cameras split
// over `threads` threads), then fused. The virtual view moves every frame, as
// a lecturer's head does: nothing can be reused from the frame before.
Result run(std::vector<Camera>& cams, const std::function<CameraCalib(int)>& virt_at_frame, int frames, int threads,
           bool memory, const WarpParams& wp) {
  Result r;
  FuseParams fp;
  FusedView fused;
  std::vector<double> seg_ms(cams.size()), memory_ms(cams.size()), warp_ms(cams.size());
  auto work = [&](size_t i, int f, const CameraCalib& virt) {
    Camera& c = cams[i];
    const size_t k = size_t(f) % c.color.size();
    double t0 = thread_cpu_ms();
    c.seg.segment(c.color[k], c.depth[k], &c.label);
    seg_ms[i] += thread_cpu_ms() - t0;
    WarpSource src{c.color[k], c.depth[k], c.label, c.prior};
    if (memory) {  // viewwarp background-memory=N with empty-room: the room behind the learners drawn too
      t0 = thread_cpu_ms();
      c.memory.apply(&src);
      memory_ms[i] += thread_cpu_ms() - t0;
    }
    t0 = thread_cpu_ms();
    c.warper.warp(c.calib, src, virt, wp, &c.warped);
    warp_ms[i] += thread_cpu_ms() - t0;
  };
  const auto start = Clock::now();
  const double cpu0 = process_cpu_ms();
  for (int f = 0; f < frames; ++f) {
    const CameraCalib virt = virt_at_frame(f);
    if (threads <= 1) {
      for (size_t i = 0; i < cams.size(); ++i) work(i, f, virt);
    } else {
      std::vector<std::thread> pool;
      for (int t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
          for (size_t i = size_t(t); i < cams.size(); i += size_t(threads)) work(i, f, virt);
        });
      for (auto& th : pool) th.join();
    }
    const double t0 = thread_cpu_ms();
    std::vector<const WarpedView*> views;
    for (auto& c : cams) views.push_back(&c.warped);
    fuse_views(views, fp, &fused);
    r.fuse_ms += thread_cpu_ms() - t0;
  }
  r.total_ms = ms_since(start) / frames;
  r.cpu_ms = (process_cpu_ms() - cpu0) / frames;
  for (size_t i = 0; i < cams.size(); ++i) {
    r.seg_ms += seg_ms[i] / frames;
    r.memory_ms += memory_ms[i] / frames;
    r.warp_ms += warp_ms[i] / frames;
  }
  r.fuse_ms /= frames;
  return r;
}

// Each camera's viewprep: the empty room's depth as its static layer, the background memory from the empty room.
void set_up_preparers(const std::vector<Camera>& cams, int memory, const std::vector<cv::Mat>& empty_rooms,
                      std::vector<FramePreparer>* preparers) {
  for (size_t i = 0; i < cams.size(); ++i) {
    (*preparers)[i].set_static_depth(cams[i].prior);
    (*preparers)[i].set_memory(memory, empty_rooms[i]);
  }
}

// The camera side of frame f, as learnerseg and viewprep run it: each camera's frame segmented and prepared.
void prepare_frames(std::vector<Camera>& cams, std::vector<FramePreparer>& preparers, int f, const WarpParams& wp,
                    std::vector<std::shared_ptr<PreparedFrame>>* prepared, std::vector<WarpSource>* sources) {
  prepared->assign(cams.size(), nullptr);
  sources->clear();
  for (size_t i = 0; i < cams.size(); ++i) {
    Camera& c = cams[i];
    const size_t k = size_t(f) % c.color.size();
    c.seg.segment(c.color[k], c.depth[k], &c.label);
    (*prepared)[i] = preparers[i].prepare(c.calib, c.color[k], c.depth[k], c.label, wp);
    sources->push_back(FramePreparer::source_of(*(*prepared)[i], c.color[k], c.depth[k], c.label));
  }
}

// Several lecturers, each with a view of their own, as whepviewsink renders them: every camera frame is
// segmented and prepared once (viewprep: the background memory, the warp's half that does not depend on the
// pose), then warped and fused once per view for that view's pose. Prints the camera side per frame and what
// one view frame costs: everything that depends on the lecturer's pose (warps, fuse with its fill and fade).
// The views' CPU is the process's, so that it would count OpenCV's threads too (the room view's lookup runs in
// bands through cv::parallel_for_); this tool runs OpenCV on one thread (main), so it gives what the calling
// thread's clock gave before 2026-11-28, within the noise.
void run_views(std::vector<Camera>& cams, const std::function<CameraCalib(int, int)>& virt_at_frame, int frames,
               int views, int memory, const std::vector<cv::Mat>& empty_rooms, const WarpParams& wp) {
  std::vector<FramePreparer> preparers(cams.size());
  set_up_preparers(cams, memory, empty_rooms, &preparers);
  const FuseParams fp;  // viewfuse's
  std::vector<std::vector<ViewWarper>> warpers(size_t(views), std::vector<ViewWarper>(cams.size()));
  std::vector<WarpedView> warped(cams.size());
  FusedView fused;
  double camera_ms = 0, warp_ms = 0, fuse_ms = 0, share = 0, drawn = 0;
  const int warm_up = 3;
  for (int f = 0; f < warm_up + frames; ++f) {
    const bool timed = f >= warm_up;
    double t0 = process_cpu_ms();
    std::vector<std::shared_ptr<PreparedFrame>> prepared;
    std::vector<WarpSource> sources;
    prepare_frames(cams, preparers, f, wp, &prepared, &sources);
    if (timed) camera_ms += process_cpu_ms() - t0;
    for (int v = 0; v < views; ++v) {
      const CameraCalib virt = virt_at_frame(f, v);
      t0 = process_cpu_ms();
      for (size_t i = 0; i < cams.size(); ++i)
        warpers[size_t(v)][i].warp_prepared(cams[i].calib, sources[i], prepared[i]->source, virt, wp, &warped[i]);
      const double t1 = process_cpu_ms();
      std::vector<const WarpedView*> inputs;
      for (auto& w : warped) inputs.push_back(&w);
      fuse_views(inputs, fp, &fused);
      if (timed) {
        warp_ms += t1 - t0;
        fuse_ms += process_cpu_ms() - t1;
        for (size_t i = 0; i < cams.size(); ++i) {  // not timed
          share += warpers[size_t(v)][i].warped_share();
          drawn += double(cv::countNonZero(warped[i].depth)) / double(warped[i].depth.total());
        }
      }
    }
  }
  const double per_view = (warp_ms + fuse_ms) / (double(frames) * views);
  std::printf("%d views, background-memory=%d: per camera frame, once for all views (learnerseg + viewprep): %.2f ms "
              "CPU for %zu cameras; per view frame: warp %.2f + fuse %.2f ms\n",
              views, memory, camera_ms / frames, cams.size(), warp_ms / (double(frames) * views),
              fuse_ms / (double(frames) * views));
  std::printf("the warps set up %.1f %% of the cameras' pixels (the rest cannot land in the views)\n",
              100 * share / (double(frames) * views * double(cams.size())));
  // Each drawn view pixel is a z-buffer record with its colour sampled: what the view's cost grows with.
  std::printf("the warps drew %.2f samples per view pixel (each camera %.1f %% of the view)\n",
              drawn / (double(frames) * views), 100 * drawn / (double(frames) * views * double(cams.size())));
  std::printf("per view frame: %.1f ms CPU (%d views, %zu cameras %dx%d -> %dx%d)\n", per_view, views, cams.size(),
              cams[0].calib.width, cams[0].calib.height, fused.color.cols, fused.color.rows);
}

// The views as viewfuse room-view=true makes them (docs/vva.md, "How a view is made"), timed by part. Per
// camera frame: learnerseg, viewprep (FramePreparer, which also gives the depth of what goes forward) and the
// room's packed records (PreparedFrame::room_texture, made by the first view that asks). Per view: the room
// rasterised from the cameras' meshes and looked up (RoomViewRenderer), the learners and the room's pixels
// beside them warped forward from each camera, all fused and filled. The meshes are made once, untimed.
void run_room_views(std::vector<Camera>& cams, const std::function<CameraCalib(int, int)>& virt_at_frame,
                    int frames, int views, int memory, const std::vector<cv::Mat>& empty_rooms, const WarpParams& wp) {
  for (const Camera& c : cams)
    if (c.prior.empty()) vclassroom_tools::usage_error("--room-view needs the empty room's depth (no --no-model)");
  std::vector<FramePreparer> preparers(cams.size());
  set_up_preparers(cams, memory, empty_rooms, &preparers);
  FuseParams fp;
  fp.first_is_base = true;
  WarpParams only = wp;
  only.learners_only = true;
  std::vector<std::vector<ViewWarper>> warpers(size_t(views), std::vector<ViewWarper>(cams.size()));
  std::vector<WarpedView> warped(cams.size());
  std::vector<Eigen::Vector3d> centres;
  for (const Camera& c : cams) centres.push_back(c.calib.center_in_rig());
  RoomViewRenderer renderer;
  WarpedView room;
  FusedView fused;
  double camera_ms = 0, texture_ms = 0, room_ms = 0, learner_ms = 0, fuse_ms = 0;
  size_t triangles = 0;
  long left_learners = 0;  // timed camera views whose learners were left to nearer cameras
  const int warm_up = 3;
  for (int f = 0; f < warm_up + frames; ++f) {
    const bool timed = f >= warm_up;
    double t0 = process_cpu_ms();
    std::vector<std::shared_ptr<PreparedFrame>> prepared;
    std::vector<WarpSource> sources;
    prepare_frames(cams, preparers, f, wp, &prepared, &sources);
    if (f == 0)  // the meshes, once: untimed
      for (const auto& p : prepared) triangles += p->room_shape->mesh().triangles();
    double t1 = process_cpu_ms();
    std::vector<RoomCamera> room_cams;
    for (size_t i = 0; i < cams.size(); ++i)
      room_cams.push_back(RoomCamera{prepared[i]->room_shape.get(),
                                     &prepared[i]->room_texture(cams[i].color[size_t(f) % cams[i].color.size()])});
    const double t2 = process_cpu_ms();
    if (timed) camera_ms += t1 - t0, texture_ms += t2 - t1;
    for (int v = 0; v < views; ++v) {
      const CameraCalib virt = virt_at_frame(f, v);
      t0 = process_cpu_ms();
      share_room_planes(cv::Size(virt.width, virt.height), &fused, &room);  // fused in place, as viewfuse does
      renderer.render(room_cams, virt, room_lookup_params(fp), &room);
      t1 = process_cpu_ms();
      std::vector<const WarpedView*> inputs{&room};
      for (size_t i = 0; i < cams.size(); ++i) {
        // As each viewwarp decides: a camera far from the view leaves its learners to the nearer ones.
        if (learners_left_to_nearer(cams[i].calib.center_in_rig(), centres, virt.center_in_rig())) {
          left_learners += timed;
          warpers[size_t(v)][i].warp_nothing(virt, &warped[i]);
        } else {
          warpers[size_t(v)][i].warp_prepared(cams[i].calib, sources[i], prepared[i]->source, virt, only, &warped[i]);
        }
        inputs.push_back(&warped[i]);
      }
      const double t_learners = process_cpu_ms();
      fuse_views(inputs, fp, &fused);
      if (timed) {
        room_ms += t1 - t0;
        learner_ms += t_learners - t1;
        fuse_ms += process_cpu_ms() - t_learners;
      }
    }
  }
  const double n = double(frames) * views;
  std::printf("room view: meshes of %zu triangles for %zu cameras\n", triangles, cams.size());
  std::printf("per camera frame: learnerseg + viewprep %.2f ms, room records %.2f ms CPU for %zu cameras\n",
              camera_ms / frames, texture_ms / frames, cams.size());
  std::printf("per view frame: room (raster + lookup) %.2f + learners %.2f + fuse %.2f ms; of %ld cameras' "
              "views, %ld far ones left their learners to nearer cameras\n",
              room_ms / n, learner_ms / n, fuse_ms / n, long(n) * long(cams.size()), left_learners);
  std::printf("per view frame: %.1f ms CPU (%d views, %zu cameras %dx%d -> %dx%d)\n",
              (room_ms + learner_ms + fuse_ms) / n, views, cams.size(), cams[0].calib.width, cams[0].calib.height,
              fused.color.cols, fused.color.rows);
}

// The hole filling alone (issue 35), both methods on the same fused views, alternating frame by frame so
// that the machine's drift hits both alike: each frame's cameras are segmented and warped (not timed), fused
// without the fill, and then the fill of each method is timed on a copy of that view (thread CPU time; the
// copy not counted). With `memory`, the room behind the learners is drawn first, as server.sh runs it.
void time_fill(std::vector<Camera>& cams, const std::function<CameraCalib(int)>& virt_at_frame, int frames,
               bool memory, const WarpParams& wp) {
  FuseParams unfilled;
  unfilled.fill_holes = false;
  FusedView fused;
  cv::Mat color, mask;
  // The pyramid keeps its history as for a steady pose (live it is cleared when the pose changes, as it does
  // here every frame): the timing includes blending with it, the most it costs.
  HoleFillHistory history;
  const HoleFillMethod methods[2] = {HoleFillMethod::Pyramid, HoleFillMethod::Rays};
  double fill_ms[2] = {0, 0}, holes = 0;
  const int warm_up = 3;
  for (int f = 0; f < warm_up + frames; ++f) {
    const CameraCalib virt = virt_at_frame(f);
    std::vector<const WarpedView*> views;
    for (Camera& c : cams) {
      const size_t k = size_t(f) % c.color.size();
      c.seg.segment(c.color[k], c.depth[k], &c.label);
      WarpSource src{c.color[k], c.depth[k], c.label, c.prior};
      if (memory) c.memory.apply(&src);
      c.warper.warp(c.calib, src, virt, wp, &c.warped);
      views.push_back(&c.warped);
    }
    fuse_views(views, unfilled, &fused);
    if (f >= warm_up) holes += fused.unseen_share;
    for (int i = 0; i < 2; ++i) {
      const int m = (f % 2) ? 1 - i : i;  // ABBA: each method first every other frame
      fused.color.copyTo(color);
      mask.create(color.size(), CV_8UC1);
      mask.setTo(0);
      HoleFillParams p = hole_fill_params(FuseParams());
      p.method = methods[m];
      const double t0 = thread_cpu_ms();
      fill_holes(color, fused.depth, p, mask, nullptr, m == 0 ? &history : nullptr);
      if (f >= warm_up) fill_ms[m] += thread_cpu_ms() - t0;
    }
  }
  std::printf("hole fill alone, 960x540 view, %d frames, holes %.2f %% of the view%s: pyramid (default) %.3f ms, "
              "rays (before issue 35) %.3f ms CPU per view frame\n",
              frames, 100 * holes / frames, memory ? " (room behind the learners drawn)" : "", fill_ms[0] / frames,
              fill_ms[1] / frames);
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 60, threads = 2, memory = -1, views = 0;  // memory -1: not given
  double yaw = 0, pitch = 0;
  gboolean room_view = FALSE, without_camera_0 = FALSE;
  gboolean no_edge_to_near = FALSE, no_model = FALSE, fill_only = FALSE, no_view_cull = FALSE;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames timed (default 60)", "N"},
      {"threads", 0, 0, G_OPTION_ARG_INT, &threads, "threads sharing the cameras (default 2: this machine's cores)", "T"},
      {"no-edge-to-near", 0, 0, G_OPTION_ARG_NONE, &no_edge_to_near,
       "warp as viewwarp edge-to-near=false (the objects' rims stay on the background), for comparison", nullptr},
      {"no-view-cull", 0, 0, G_OPTION_ARG_NONE, &no_view_cull,
       "warp every source column, also those that cannot land in the view (WarpParams::cull_outside_view = "
       "false), for comparison: the same pictures",
       nullptr},
      {"no-model", 0, 0, G_OPTION_ARG_NONE, &no_model,
       "no empty room's depth for learnerseg and viewwarp (what server.sh runs without MODEL: learnerseg learns "
       "the room's depth as it goes)",
       nullptr},
      {"views", 0, 0, G_OPTION_ARG_INT, &views,
       "only time N lecturers' views with different poses rendered from the same camera frames (the camera side "
       "once per frame, as whepviewsink does), ending with the CPU time per view frame; the background memory "
       "as --memory, 8 when --memory is not given (default 0: the stages as above)",
       "N"},
      {"yaw", 0, 0, G_OPTION_ARG_DOUBLE, &yaw,
       "with --views: the lecturers look this many degrees to the right (negative: left) of the walk's heading, "
       "as a lecturer turned towards one side of the class (default 0)",
       "DEG"},
      {"pitch", 0, 0, G_OPTION_ARG_DOUBLE, &pitch,
       "the lecturers look this many degrees up (negative: down) from the cameras' tilt; 20 is a headset worn "
       "level above cameras tilted 20 degrees down, as the browser page's scripted headset in "
       "vclassroom-measure-lecturers, whose view is then a third unseen (default 0)",
       "DEG"},
      {"room-view", 0, 0, G_OPTION_ARG_NONE, &room_view,
       "with --views: the views as viewfuse room-view=true makes them (the room rasterised from meshes and looked "
       "up, the learners and the room's pixels beside them warped alone), timed by part",
       nullptr},
      {"without-camera-0", 0, 0, G_OPTION_ARG_NONE, &without_camera_0,
       "with --views: the views drawn from cameras 1 and 2 alone, as Table I's (no camera at the walk, and none "
       "of the two far from it: each warps its learners)",
       nullptr},
      {"fill-only", 0, 0, G_OPTION_ARG_NONE, &fill_only,
       "only time the hole filling of viewfuse, its two methods (fill-method pyramid and rays) alternating on the "
       "same fused views, with --memory as given",
       nullptr},
      {"memory", 0, 0, G_OPTION_ARG_INT, &memory,
       "also time viewwarp's background memory of N frames, seeded with the empty room, and the room behind the "
       "learners it draws (default 0: off)",
       "N"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Times learnerseg + viewwarp per camera and viewfuse on 960x540 synthetic classroom frames (sensor model\n"
      "on, 6 learners); the virtual view starts at camera 0's pose moved 0.2 m left and walks on sideways with a\n"
      "head turn, a new pose every frame.",
      entries);
  const bool memory_given = memory >= 0;
  if (!memory_given) memory = 0;
  if (frames < 1 || threads < 1 || memory < 0 || views < 0)
    vclassroom_tools::usage_error("--frames and --threads must be at least 1, --memory and --views at least 0");
  if (without_camera_0 && views == 0) vclassroom_tools::usage_error("--without-camera-0 needs --views");
  cv::setNumThreads(1);  // our threads are the cameras
  WarpParams warp;  // viewwarp's defaults
  warp.edge_to_near = !no_edge_to_near;
  warp.cull_outside_view = !no_view_cull;
  const Rig rig = default_classroom_rig();
  const Classroom room(ClassroomConfig{1, 6, 2.0}), empty(ClassroomConfig{1, 0, 2.0});
  const int recorded = 8;
  std::vector<cv::Mat> empty_rooms;  // each camera's view of the empty room, as make_cams made them
  auto make_cams = [&](const std::vector<int>& ids) {
    return record_cameras(rig, ids, room, empty, recorded, !no_model, memory, &empty_rooms);
  };
  const CameraCalib& ref = rig.camera(0);
  // Camera 0's pose moved 0.2 m left, then on along a slow sideways walk with
  // a head turn (1 slider step per 30 frames).
  const double look_up = pitch / kSliderDegrees;
  auto virt_at = [&](int w, int h) {
    return std::function<CameraCalib(int)>([&ref, w, h, look_up](int f) {
      const double s = (f % 300) / 30.0;
      const Pose p = sliders_to_pose(Sliders{40 + s, 50, 50, 50 + s, 50 + look_up, 50}, ref);
      return virtual_camera(scale_camera(ref, w, h), p.cam_to_rig(), NAN);
    });
  };
  if (fill_only) {
    std::vector<Camera> cams = make_cams({0, 1, 2});
    time_fill(cams, virt_at(960, 540), frames, memory > 0, warp);
    return 0;
  }
  if (views > 0) {
    std::vector<Camera> cams = make_cams(without_camera_0 ? std::vector<int>{1, 2} : std::vector<int>{0, 1, 2});
    // View v: the walk above, its start moved v slider steps right and up, so no two views share a pose.
    const double turn = yaw / kSliderDegrees;
    const std::function<CameraCalib(int, int)> view_at = [&ref, turn, look_up](int f, int v) {
      const double s = (f % 300) / 30.0;
      const Pose p = sliders_to_pose(Sliders{40 + s + 4 * v, 50.0 + 3 * v, 50, 50 + s + turn, 50 + look_up, 50}, ref);
      return virtual_camera(ref, p.cam_to_rig(), NAN);
    };
    std::printf("V-VA views, 960x540 RGB-D input, synthetic classroom with sensor model, %d frames, 1 thread\n",
                frames);
    if (room_view)
      run_room_views(cams, view_at, frames, views, memory_given ? memory : 8, empty_rooms, warp);
    else
      run_views(cams, view_at, frames, views, memory_given ? memory : 8, empty_rooms, warp);
    return 0;
  }
  std::printf("V-VA server stages, 960x540 RGB-D input, synthetic classroom with sensor model, %d frames, %d thread(s)\n",
              frames, threads);
  std::printf("(run under whatever load the machine has; see docs/vva.md)\n\n");
  {
    std::vector<Camera> cams = make_cams({0, 1, 2});
    if (memory > 0) {
      run(cams, virt_at(960, 540), 5, 1, true, warp);  // warm-up
      const Result m = run(cams, virt_at(960, 540), frames, 1, true, warp);
      std::printf("with background-memory=%d and the room behind the learners, 1 thread: CPU time per frame %.2f ms "
                  "(seg %.2f + memory %.2f + warp %.2f + fuse %.2f) -> at most %.1f fps on 2 idle cores\n",
                  memory, m.cpu_ms, m.seg_ms, m.memory_ms, m.warp_ms, m.fuse_ms, 2000.0 / m.cpu_ms);
    }
    run(cams, virt_at(960, 540), 5, threads, false, warp);  // warm-up
    const Result r = run(cams, virt_at(960, 540), frames, threads, false, warp);
    std::printf("3 cameras -> 960x540: %.1f fps (%.2f ms/frame); per frame, summed over cameras: learnerseg %.2f ms, "
                "viewwarp %.2f ms, viewfuse %.2f ms\n",
                1000.0 / r.total_ms, r.total_ms, r.seg_ms, r.warp_ms, r.fuse_ms);
    const Result r1 = run(cams, virt_at(960, 540), frames, 1, false, warp);
    std::printf("same, 1 thread: %.1f fps (%.2f ms/frame)\n", 1000.0 / r1.total_ms, r1.total_ms);
    std::printf("CPU time per frame: %.2f ms (1 thread: seg %.2f + warp %.2f + fuse %.2f) -> at most %.1f fps on 2 "
                "idle cores\n\n",
                r1.cpu_ms, r1.seg_ms, r1.warp_ms, r1.fuse_ms, 2000.0 / r1.cpu_ms);
    std::printf("output resolution (3 cameras, %d threads):\n", threads);
    for (auto [w, h] : std::vector<std::pair<int, int>>{{480, 270}, {960, 540}, {1280, 720}, {1920, 1080}}) {
      const Result q = run(cams, virt_at(w, h), std::max(10, frames / 3), threads, false, warp);
      std::printf("  %4dx%-4d  %6.1f fps  (warp %.2f ms, fuse %.2f ms)\n", w, h, 1000.0 / q.total_ms, q.warp_ms,
                  q.fuse_ms);
    }
  }
  std::printf("camera count (960x540 out, %d threads; the 4th camera repeats camera 0):\n", threads);
  for (const std::vector<int>& ids : std::vector<std::vector<int>>{{1}, {1, 2}, {0, 1, 2}, {0, 1, 2, 0}}) {
    std::vector<Camera> cams = make_cams(ids);
    const Result q = run(cams, virt_at(960, 540), std::max(10, frames / 3), threads, false, warp);
    std::printf("  %zu camera(s)  %6.1f fps  (%.2f ms/frame)\n", ids.size(), 1000.0 / q.total_ms, q.total_ms);
  }
  return 0;
}
