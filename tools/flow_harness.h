// What the tools that run the whole flow on loopback share
// (vclassroom-measure-flow, vclassroom-fault-inject): the pipeline scripts
// as child processes, this program as the lecturer (pipelines/lecturer.sh's
// pipeline with probes: every displayed frame's pose stamp from the RTP
// header extension gives pose-to-display latency), a pose walk, and what
// /proc says about each process (CPU, resident memory).
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <memory>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <gst/gst.h>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/core/pose_meta.h>

#include "tool_support.h"

namespace vclassroom_tools {

inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

// A process and its live descendants (a pipeline script and the gst-launch-1.0
// it runs), found through the parent pid in /proc/*/stat.
inline std::vector<pid_t> process_tree(pid_t root) {
  std::map<pid_t, std::vector<pid_t>> children;
  if (GDir* dir = g_dir_open("/proc", 0, nullptr)) {
    while (const gchar* name = g_dir_read_name(dir)) {
      const pid_t pid = static_cast<pid_t>(std::atol(name));
      if (pid <= 0) continue;
      std::ifstream in(std::string("/proc/") + name + "/stat");
      std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      const size_t close = s.rfind(')');
      if (close == std::string::npos) continue;
      std::istringstream rest(s.substr(close + 2));
      std::string state;
      long ppid = 0;
      if (rest >> state >> ppid) children[static_cast<pid_t>(ppid)].push_back(pid);
    }
    g_dir_close(dir);
  }
  std::vector<pid_t> tree{root};
  for (size_t i = 0; i < tree.size(); ++i)
    for (pid_t c : children[tree[i]]) tree.push_back(c);
  return tree;
}

// User + system CPU seconds of a process and its children that have exited.
inline double cpu_seconds_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t close = s.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream rest(s.substr(close + 2));
  std::vector<std::string> f;
  std::string tok;
  while (rest >> tok) f.push_back(tok);
  if (f.size() < 15) return 0;
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  return (std::stod(f[11]) + std::stod(f[12]) + std::stod(f[13]) + std::stod(f[14])) / tick;
}

// ... and with its live descendants: the CPU of a script is its pipeline's.
inline double cpu_seconds(pid_t pid) {
  double total = 0;
  for (pid_t p : process_tree(pid)) total += cpu_seconds_of(p);
  return total;
}

// Resident memory of one process in KiB (VmRSS in /proc/PID/status); -1 when
// it is gone.
inline long rss_kib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  return -1;
}

// ... of a process and its live descendants (a script's is mostly its
// gst-launch-1.0's); -1 when it is gone.
inline long tree_rss_kib(pid_t pid) {
  long total = -1;
  for (pid_t p : process_tree(pid))
    if (const long r = rss_kib(p); r >= 0) total = std::max(total, 0L) + r;
  return total;
}

// Runs `script` with bash, `env` added to this program's environment, stdout
// and stderr into `log`. The returned pid is the script's: server.sh runs
// gst-launch-1.0 as its child (pipelines/launch.sh), the others exec it; CPU
// and memory are counted over the process tree.
inline pid_t spawn(const std::string& script, const std::map<std::string, std::string>& env, const std::string& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    for (const auto& [k, v] : env) setenv(k.c_str(), v.c_str(), 1);
    FILE* f = std::freopen(log.c_str(), "w", stdout);
    (void)f;
    dup2(fileno(stdout), fileno(stderr));
    execl("/bin/bash", "bash", script.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

// Whether a child has already ended (without reaping one that has not).
inline bool has_exited(pid_t pid) {
  siginfo_t info{};
  return waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid;
}

// Ctrl-C to each (gst-launch -e then sends end-of-stream), then up to 5 s
// for each to finish, then SIGKILL; reaps them.
inline void stop_children(const std::vector<pid_t>& pids) {
  for (pid_t pid : pids) kill(pid, SIGINT);
  for (pid_t pid : pids) {
    int status;
    for (int i = 0; i < 50 && waitpid(pid, &status, WNOHANG) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // a tool's patience, not synchronisation
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
}

// stop_children for one script and then its descendants (gst-launch-1.0 is
// server.sh's child, not ours): whatever of its tree outlived it is killed,
// and this returns once all of it is gone, so that the next run's server does
// not share the ports (udpsrc reuses addresses) or the CPU with the last one.
inline void stop_tree(pid_t pid) {
  const std::vector<pid_t> tree = process_tree(pid);
  stop_children({pid});
  for (size_t i = 1; i < tree.size(); ++i) {
    kill(tree[i], SIGKILL);
    for (int k = 0; k < 50 && kill(tree[i], 0) == 0; ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // a tool's patience, not synchronisation
  }
}

inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  return v[i];
}

// What the lecturer's display saw.
struct Display {
  std::mutex lock;
  std::map<uint64_t, GstClockTime> first_shown;  // pose seq -> display time
  std::map<uint64_t, int64_t> viewer_time;        // pose seq -> when it was taken
  uint64_t frames = 0, frames_with_pose = 0;
  uint64_t video_bytes = 0;

  // Forgets what was seen so far (the start of a measured span).
  void reset() {
    std::lock_guard<std::mutex> g(lock);
    first_shown.clear();
    viewer_time.clear();
    frames = frames_with_pose = video_bytes = 0;
  }
  // Pose-to-display latency of every distinct pose displayed, in ms.
  std::vector<double> latencies_ms() {
    std::lock_guard<std::mutex> g(lock);
    std::vector<double> out;
    for (const auto& [seq, shown] : first_shown)
      out.push_back((static_cast<double>(shown) - static_cast<double>(viewer_time[seq])) / 1e6);
    return out;
  }
};

inline GstPadProbeReturn on_display(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* d = static_cast<Display*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  const GstClockTime now = gst_util_get_timestamp();
  std::lock_guard<std::mutex> g(d->lock);
  d->frames++;
  if (const vclassroom::PoseMeta* m = vclassroom::buffer_get_pose_meta(buf)) {
    d->frames_with_pose++;
    if (!d->first_shown.count(m->seq) && m->viewer_time_ns >= 0) {
      d->first_shown[m->seq] = now;
      d->viewer_time[m->seq] = m->viewer_time_ns;
    }
  }
  return GST_PAD_PROBE_OK;
}

inline GstPadProbeReturn on_video_packet(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* d = static_cast<Display*>(data);
  std::lock_guard<std::mutex> g(d->lock);
  if (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST)
    d->video_bytes += gst_buffer_list_calculate_size(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
  else
    d->video_bytes += gst_buffer_get_size(GST_PAD_PROBE_INFO_BUFFER(info));
  return GST_PAD_PROBE_OK;
}

// Where the lecturer listens and sends, as lecturer.sh's variables.
struct LecturerConfig {
  int video_port = 5010;
  int pose_port = 5011;
  int mtu = 1400;
  std::string key_file;  // POSE_KEY; empty: untagged poses
};

// pipelines/lecturer.sh's pipeline in this process, displaying into a
// fakesink with probes (frames, pose stamps, video bytes); `pose_out` is the
// udpsink that carries posesend's packets to the server.
class Lecturer {
 public:
  // False, with the reason on stderr, when the pipeline cannot be built.
  bool start(const LecturerConfig& c) {
    const std::string key = c.key_file.empty() ? "" : " key-file=\"" + c.key_file + "\"";
    const std::string desc =
        "udpsrc name=video port=" + std::to_string(c.video_port) + " buffer-size=8388608 mtu=" +
        std::to_string(c.mtu + 100) +
        " caps=\"application/x-rtp,media=application,clock-rate=90000,"
        "encoding-name=X-GST,extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose\" ! "
        "senderfilter name=from_server allow=127.0.0.1 payload-types=96 ! "
        "rtpjitterbuffer latency=30 ! rtpgstdepay ! jpegdec ! posesend name=back" + key +
        " ! videoconvert ! fakesink name=display sync=false  back.rtp ! "
        "udpsink name=pose_out host=127.0.0.1 port=" + std::to_string(c.pose_port) + " sync=false async=false";
    GError* err = nullptr;
    pipeline_ = gst_parse_launch(desc.c_str(), &err);
    if (!pipeline_ || err) {
      std::fprintf(stderr, "lecturer pipeline: %s\n", err ? err->message : "?");
      g_clear_error(&err);
      return false;
    }
    display_ = gst_bin_get_by_name(GST_BIN(pipeline_), "display");
    GstElement* video = gst_bin_get_by_name(GST_BIN(pipeline_), "video");
    GstPad* dpad = gst_element_get_static_pad(display_, "sink");
    gst_pad_add_probe(dpad, GST_PAD_PROBE_TYPE_BUFFER, on_display, &shown, nullptr);
    GstPad* vpad = gst_element_get_static_pad(video, "src");
    gst_pad_add_probe(vpad, GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
                      on_video_packet, &shown, nullptr);
    gst_object_unref(dpad);
    gst_object_unref(vpad);
    gst_object_unref(video);
    gst_element_set_state(pipeline_, GST_STATE_PLAYING);
    return true;
  }

  // A slow walk along the front and a head turn, one pose every 33 ms, until stop().
  void start_walk() {
    walking_ = true;
    walker_ = std::thread([this] {
      const vclassroom::CameraCalib reference = vclassroom::rig_origin_reference();
      uint64_t seq = 0;
      const auto t0 = std::chrono::steady_clock::now();
      while (walking_) {
        const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        vclassroom::ViewOffset v;
        v.right = 0.4 * std::sin(0.2 * t);
        v.forward = -0.3 + 0.1 * std::sin(0.13 * t);
        v.yaw = 15 * std::sin(0.3 * t);
        vclassroom::Pose p = vclassroom::offset_to_pose(v, reference);
        p.seq = ++seq;
        p.viewer_time_ns = static_cast<int64_t>(gst_util_get_timestamp());
        gst_element_send_event(display_, vclassroom::pose_event_new(p));
        poses_sent = seq;
        std::this_thread::sleep_for(std::chrono::milliseconds(33));  // a tool's pacing, not a test
      }
    });
  }

  void stop_walk() {
    walking_ = false;
    if (walker_.joinable()) walker_.join();
  }

  // Counts the warnings and errors posted on the lecturer's own bus since the last call.
  void count_bus_messages() {
    if (!pipeline_) return;
    GstBus* bus = gst_element_get_bus(pipeline_);
    while (GstMessage* m = gst_bus_pop_filtered(bus, GstMessageType(GST_MESSAGE_WARNING | GST_MESSAGE_ERROR))) {
      (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR ? errors : warnings)++;
      if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING) warnings_by_element[GST_OBJECT_NAME(m->src)]++;
      gst_message_unref(m);
    }
    gst_object_unref(bus);
  }

  // The bin, e.g. to probe an element by name.
  GstElement* pipeline() const { return pipeline_; }

  void stop() {
    stop_walk();
    if (!pipeline_) return;
    gst_element_set_state(pipeline_, GST_STATE_NULL);
    gst_object_unref(display_);
    gst_object_unref(pipeline_);
    pipeline_ = display_ = nullptr;
  }

  ~Lecturer() { stop(); }

  Display shown;
  std::atomic<uint64_t> poses_sent{0};
  uint64_t warnings = 0, errors = 0;
  std::map<std::string, uint64_t> warnings_by_element;

 private:
  GstElement* pipeline_ = nullptr;
  GstElement* display_ = nullptr;
  std::atomic<bool> walking_{false};
  std::thread walker_;
};

// What a pipeline script's gst-launch-1.0 -e -m printed in `log`.
struct LaunchLogCounts {
  long warnings = 0, errors = 0;
  long cameras_lost = 0, cameras_returned = 0;  // viewfuse's vclassroom-camera-status messages
  std::string first_warning, first_error;
  std::map<std::string, long> warnings_by_element;  // element name -> warnings it posted
};

inline LaunchLogCounts count_launch_log(const std::string& log) {
  LaunchLogCounts c;
  std::ifstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("WARNING: from element", 0) == 0) {
      if (c.warnings++ == 0) c.first_warning = line;
      // "WARNING: from element /GstPipeline:pipeline0/GstRgbdDec:dec0: ...": the name after the last ':' of the path.
      const size_t path_end = line.find(": ", 22);
      const size_t name_start = line.rfind(':', path_end - 1);
      if (path_end != std::string::npos && name_start != std::string::npos && name_start > 22)
        c.warnings_by_element[line.substr(name_start + 1, path_end - name_start - 1)]++;
    } else if (line.rfind("ERROR: from element", 0) == 0) {
      if (c.errors++ == 0) c.first_error = line;
    } else if (line.find("vclassroom-camera-status") != std::string::npos) {
      if (line.find("status=(string)lost") != std::string::npos) c.cameras_lost++;
      if (line.find("status=(string)returned") != std::string::npos) c.cameras_returned++;
    }
  }
  return c;
}

// The last vclassroom-codec-stats message `element` posted, as gst-launch -m
// printed it in `log`: {frames, frames-dropped}; {-1, -1} when there is none.
inline std::pair<long long, long long> last_codec_stats(const std::string& log, const std::string& element) {
  std::ifstream in(log);
  std::string line;
  std::pair<long long, long long> last{-1, -1};
  const std::string from = "from element \"" + element + "\"";
  auto field = [](const std::string& l, const std::string& name) -> long long {
    const size_t at = l.find(" " + name + "=(guint64)");
    return at == std::string::npos ? -1 : std::atoll(l.c_str() + at + name.size() + 11);
  };
  while (std::getline(in, line))
    if (line.find(from) != std::string::npos && line.find("vclassroom-codec-stats") != std::string::npos)
      last = {field(line, "frames"), field(line, "frames-dropped")};
  return last;
}

// The classroom side of pipelines/classroom.sh after rgbdenc, fed from memory:
// each camera's recorded coded stream (record_stream of rgbdtestsrc ! rgbdenc)
// sent over RTP to server.sh's port for it, with classroom.sh's default SSRC,
// every camera frame f at f/30 s as a live camera would (on a real rig the
// cameras are other machines, so their rendering must not take the server's CPU).
class CameraReplay {
 public:
  CameraReplay() = default;
  CameraReplay(const CameraReplay&) = delete;
  CameraReplay& operator=(const CameraReplay&) = delete;
  ~CameraReplay() { stop(); }

  // `recordings[i]` is camera `cameras[i]`, sent through `payloader` (rtpgstpay for rgbdenc's frames,
  // rtph264pay for the H.264 link's) to 127.0.0.1:base_port + camera; `drop` the share of packets lost on the
  // way. False, with the reason on stderr, when a pipeline cannot start.
  bool start(const std::vector<const Recording*>& recordings, const std::vector<int>& cameras, double drop, int mtu,
             const std::string& payloader = "rtpgstpay config-interval=1", int base_port = 5000) {
    for (size_t i = 0; i < recordings.size(); ++i) {
      auto c = std::make_unique<Camera>();
      c->recording = recordings[i];
      const std::string desc = "appsrc name=src format=time is-live=true ! " + payloader + " mtu=" +
                               std::to_string(mtu) + " pt=96 ssrc=" + std::to_string(0x56430000u + unsigned(cameras[i])) +
                               " ! identity drop-probability=" + std::to_string(drop) +
                               " ! udpsink host=127.0.0.1 port=" + std::to_string(base_port + cameras[i]) + " sync=false";
      GError* err = nullptr;
      c->pipeline = gst_parse_launch(desc.c_str(), &err);
      if (!c->pipeline || err) {
        std::fprintf(stderr, "camera replay pipeline: %s\n", err ? err->message : "?");
        g_clear_error(&err);
        if (c->pipeline) gst_object_unref(c->pipeline);
        c->pipeline = nullptr;
        stop();
        return false;
      }
      c->src = gst_bin_get_by_name(GST_BIN(c->pipeline), "src");
      gst_app_src_set_caps(GST_APP_SRC(c->src), recordings[i]->caps);
      gst_element_set_state(c->pipeline, GST_STATE_PLAYING);
      cameras_.push_back(std::move(c));
    }
    running_ = true;
    pacer_ = std::thread([this] {
      const auto t0 = std::chrono::steady_clock::now();
      for (uint64_t f = 0; running_; ++f) {
        std::this_thread::sleep_until(t0 + std::chrono::microseconds(f * 1000000 / 30));  // a tool's pacing
        for (auto& c : cameras_) {
          const auto& frames = c->recording->frames;
          GstBuffer* b = gst_buffer_copy(frames[f % frames.size()]);
          GST_BUFFER_PTS(b) = f * GST_SECOND / 30;
          GST_BUFFER_DURATION(b) = GST_SECOND / 30;
          if (gst_app_src_push_buffer(GST_APP_SRC(c->src), b) == GST_FLOW_OK) c->sent++;
        }
      }
    });
    return true;
  }

  void stop() {
    running_ = false;
    if (pacer_.joinable()) pacer_.join();
    for (auto& c : cameras_) {
      if (!c->pipeline) continue;
      gst_element_set_state(c->pipeline, GST_STATE_NULL);
      gst_object_unref(c->src);
      gst_object_unref(c->pipeline);
      c->pipeline = nullptr;
    }
  }

  // Frames camera i (in start's order) has sent.
  uint64_t sent(size_t i) const { return cameras_.at(i)->sent; }

 private:
  struct Camera {
    const Recording* recording = nullptr;
    GstElement* pipeline = nullptr;
    GstElement* src = nullptr;
    std::atomic<uint64_t> sent{0};
  };
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::atomic<bool> running_{false};
  std::thread pacer_;
};

}  // namespace vclassroom_tools
