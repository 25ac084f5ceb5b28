// Throughput of the V-VA server as GStreamer runs it (docs/vva.md): three
// camera branches `appsrc ! learnerseg ! viewwarp ! queue` into `viewfuse`,
// at 960x540 in and out, the lecturer walking along a pose trace, as fast as
// the machine goes. Where vclassroom-bench-server times the algorithms one
// by one, this is what a user gets: the elements' own threads spread over
// the cores, caps, buffers, events and the aggregator included.
//
// The camera frames are recorded from rgbdtestsrc (sensor model on) before
// the clock starts and played in a loop, so the cameras cost nothing here:
// on a real server they arrive over the network.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_trace.h>

#include "cpu_clock.h"
#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
using vclassroom_tools::Recording;
using Clock = std::chrono::steady_clock;

namespace {

struct Feeder {
  const Recording* rec = nullptr;
  int total = 0;
  int next = 0;
};

void feed(GstAppSrc* src, guint, gpointer data) {
  Feeder* f = static_cast<Feeder*>(data);
  if (f->next >= f->total) {
    gst_app_src_end_of_stream(src);
    return;
  }
  GstBuffer* b = gst_buffer_copy(f->rec->frames[size_t(f->next) % f->rec->frames.size()]);
  GST_BUFFER_PTS(b) = gst_util_uint64_scale(guint64(f->next), GST_SECOND, 30);
  GST_BUFFER_DTS(b) = GST_CLOCK_TIME_NONE;
  GST_BUFFER_DURATION(b) = gst_util_uint64_scale(1, GST_SECOND, 30);
  ++f->next;
  gst_app_src_push_buffer(src, b);
}

struct Counter {
  std::atomic<int> frames{0};
  int warmup = 0;
  Clock::time_point first, last;
  double cpu_first = 0, cpu_last = 0;
};

GstPadProbeReturn count_frame(GstPad*, GstPadProbeInfo*, gpointer data) {
  Counter* c = static_cast<Counter*>(data);
  const int n = ++c->frames;
  if (n == c->warmup) {
    c->first = Clock::now();
    c->cpu_first = vclassroom_tools::process_cpu_ms();
  }
  c->last = Clock::now();
  c->cpu_last = vclassroom_tools::process_cpu_ms();
  return GST_PAD_PROBE_OK;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 300, learners = 6, cameras = 3, runs = 3, memory = 0;
  gchar* room_view = nullptr;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per run (default 300, at least 40)", "N"},
      {"runs", 0, 0, G_OPTION_ARG_INT, &runs, "runs, each printed, then the median (default 3)", "R"},
      {"learners", 0, 0, G_OPTION_ARG_INT, &learners, "learners in the synthetic classroom (default 6)", "L"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "cameras, 1 to 3 (default 3)", "C"},
      {"memory", 0, 0, G_OPTION_ARG_INT, &memory,
       "viewwarp background-memory=N with the empty room as its empty-room, as server.sh runs it (default 0: off)",
       "N"},
      {"room-view", 0, 0, G_OPTION_ARG_STRING, &room_view,
       "viewfuse room-view: on (the default: the room drawn from the cameras' meshes, the learners warped alone) "
       "or off (every camera warped whole)",
       "on|off"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Frames per second of `appsrc ! learnerseg ! viewwarp ! queue` x C into viewfuse -> fakesink at 960x540,\n"
      "the virtual view following a lecturer's walk (a new pose every frame). Needs the plugins: run it inside\n"
      "`meson devenv -C build` or after `meson install`.",
      entries, gst_init_get_option_group());
  const std::string room_choice = room_view ? room_view : "on";
  if (room_choice != "on" && room_choice != "off") vclassroom_tools::usage_error("--room-view must be on or off");
  if (frames < 40 || runs < 1 || learners < 0 || cameras < 1 || cameras > 3 || memory < 0)
    vclassroom_tools::usage_error(
        "--frames must be at least 40, --runs at least 1, --cameras 1 to 3, --memory at least 0");
  for (const char* e : {"rgbdtestsrc", "learnerseg", "viewwarp", "viewfuse"})
    if (!gst_element_factory_find(e)) {
      std::fprintf(stderr, "element %s not found: run inside `meson devenv -C build` or install the plugins\n", e);
      return 1;
    }
  const std::string dir_path = vclassroom_tools::make_temp_dir("vclassroom-bench");
  const char* dir = dir_path.empty() ? nullptr : dir_path.c_str();
  if (!dir) {
    std::perror("cannot make a scratch folder");
    return 1;
  }
  const std::string tmp = dir;

  // The empty room's depth and colour per camera (what V-DA's model gives), and the walk.
  const Rig rig = default_classroom_rig();
  const Classroom empty(ClassroomConfig{1, 0, 2.0});
  ClassroomRenderer renderer;
  std::vector<std::string> priors, rooms;
  for (int k = 0; k < cameras; ++k) {
    RenderOutput r;
    renderer.render(empty, 0.0, rig.camera(k), &r);
    priors.push_back(tmp + "/prior-cam" + std::to_string(k) + ".png");
    cv::imwrite(priors.back(), r.depth);
    rooms.push_back(tmp + "/room-cam" + std::to_string(k) + ".png");
    cv::Mat bgr;
    cv::cvtColor(r.color, bgr, cv::COLOR_RGB2BGR);
    cv::imwrite(rooms.back(), bgr);
  }
  std::vector<PoseSample> walk;
  for (int f = 0; f < frames; ++f) {
    // 0.2 m left of camera 0, walking right 1 cm per frame and turning 0.2 deg per frame.
    const double s = f * 0.5;
    PoseSample p;
    p.t = f / 30.0;
    p.pose = sliders_to_pose(Sliders{40 + std::fmod(s, 20.0), 50, 50, 50 + std::fmod(s * 0.1, 10.0), 50, 50},
                             rig.camera(0));
    walk.push_back(p);
  }
  const std::string trace = tmp + "/walk.csv";
  save_pose_trace(walk, trace);

  std::vector<Recording> rec(static_cast<size_t>(cameras));
  for (int k = 0; k < cameras; ++k)
    if (!vclassroom_tools::record_stream("rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 learners=" +
                                             std::to_string(learners) + " num-buffers=8 ground-truth=false",
                                         8, &rec[size_t(k)])) {
      std::fprintf(stderr, "could not record camera %d from rgbdtestsrc\n", k);
      return 1;
    }

  // One measured run; the machine's speed drifts (other work, a virtual
  // machine's neighbours), so several runs are reported, not one.
  struct RunFigures {
    double fps = 0, cpu_ms = 0, cores = 0;
    int frames = 0;
  };
  auto run_once = [&](RunFigures* fig) -> int {
    std::string desc = "viewfuse name=fuse pose-trace=" + trace +
                       " room-view=" + (room_choice == "on" ? "true" : "false") + " ! fakesink name=out sync=false";
    for (int k = 0; k < cameras; ++k)
      desc += " appsrc name=src" + std::to_string(k) + " format=time max-buffers=2 ! learnerseg prior-depth=" +
              priors[size_t(k)] + " ! viewwarp prior-depth=" + priors[size_t(k)] +
              (memory > 0 ? " background-memory=" + std::to_string(memory) + " empty-room=" + rooms[size_t(k)] : "") +
              " ! queue max-size-buffers=2 ! fuse.cam_" + std::to_string(k);
    GError* err = nullptr;
    GstElement* pipeline = gst_parse_launch(desc.c_str(), &err);
    if (!pipeline || err) {
      std::fprintf(stderr, "cannot build the pipeline: %s\n", err ? err->message : "?");
      g_clear_error(&err);
      if (pipeline) gst_object_unref(pipeline);
      return 1;
    }
    std::vector<Feeder> feeders(static_cast<size_t>(cameras));
    for (int k = 0; k < cameras; ++k) {
      GstElement* src = gst_bin_get_by_name(GST_BIN(pipeline), ("src" + std::to_string(k)).c_str());
      gst_app_src_set_caps(GST_APP_SRC(src), rec[size_t(k)].caps);
      feeders[size_t(k)] = Feeder{&rec[size_t(k)], frames, 0};
      GstAppSrcCallbacks cb = {};
      cb.need_data = feed;
      gst_app_src_set_callbacks(GST_APP_SRC(src), &cb, &feeders[size_t(k)], nullptr);
      gst_object_unref(src);
    }
    Counter counter;
    counter.warmup = 30;  // the first frames set up rays, buffers, the memory of learnerseg
    GstElement* sink = gst_bin_get_by_name(GST_BIN(pipeline), "out");
    GstPad* sinkpad = gst_element_get_static_pad(sink, "sink");
    gst_pad_add_probe(sinkpad, GST_PAD_PROBE_TYPE_BUFFER, count_frame, &counter, nullptr);
    gst_object_unref(sinkpad);
    gst_object_unref(sink);

    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(pipeline);
    GstMessage* msg =
        gst_bus_timed_pop_filtered(bus, GST_CLOCK_TIME_NONE, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    int rc = 0;
    if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
      GError* e = nullptr;
      gst_message_parse_error(msg, &e, nullptr);
      std::fprintf(stderr, "pipeline error from %s: %s\n", GST_OBJECT_NAME(msg->src), e->message);
      g_clear_error(&e);
      rc = 1;
    }
    gst_message_unref(msg);
    gst_object_unref(bus);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);

    const int n = counter.frames.load();
    if (rc == 0 && n > counter.warmup + 1) {
      const double secs = std::chrono::duration<double>(counter.last - counter.first).count();
      const int measured = n - counter.warmup;
      fig->fps = measured / secs;
      fig->cpu_ms = (counter.cpu_last - counter.cpu_first) / measured;
      fig->cores = (counter.cpu_last - counter.cpu_first) / (1000.0 * secs);
      fig->frames = n;
    } else if (rc == 0) {
      std::fprintf(stderr, "only %d frames came out\n", n);
      rc = 1;
    }
    return rc;
  };
  std::vector<RunFigures> figs;
  int rc = 0;
  for (int r = 0; r < runs && rc == 0; ++r) {
    RunFigures f;
    rc = run_once(&f);
    if (rc == 0) figs.push_back(f);
  }
  std::sort(figs.begin(), figs.end(), [](const RunFigures& a, const RunFigures& b) { return a.fps < b.fps; });
  std::printf("%d camera(s) 960x540 -> learnerseg -> viewwarp -> viewfuse 960x540 (room-view %s), %d learners, "
              "%d frames per run\n",
              cameras, room_choice.c_str(), learners, frames);
  for (const RunFigures& f : figs)
    std::printf("  run: %.1f fps, CPU %.1f ms per output frame (%.0f%% of one core)\n", f.fps, f.cpu_ms,
                100 * f.cores);
  if (!figs.empty()) {
    const RunFigures& med = figs[figs.size() / 2];
    std::printf("throughput: median %.1f fps (min %.1f, max %.1f over %d runs of %d frames after %d warm-up "
                "frames); CPU %.1f ms per output frame\n",
                med.fps, figs.front().fps, figs.back().fps, int(figs.size()), frames - 30, 30, med.cpu_ms);
  }
  for (const auto& p : priors) std::remove(p.c_str());
  for (const auto& p : rooms) std::remove(p.c_str());
  std::remove(trace.c_str());
  rmdir(dir);
  return rc;
}
