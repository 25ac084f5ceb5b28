// The whole flow on loopback, measured: the classroom cameras and the server
// run as child processes (pipelines/classroom.sh, pipelines/server.sh); this
// program is the lecturer. It sends a pose 30 times a second (a slow walk and
// head turn), displays into a fakesink, and for every displayed frame reads
// the pose it was rendered for (RTP header extension) to get pose-to-display
// latency. It reports p50/p99 latency, frames displayed, bitrates and CPU.
// Run from the source root inside `meson devenv -C build` (plugins on the path).
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <gst/gst.h>

#include <gst/vclassroom/net/pose_wire.h>
#include <gst/vclassroom/core/pose_meta.h>

#include "camera_link_chain.h"
#include "flow_harness.h"
#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
using vclassroom_tools::spawn;

namespace {

struct Options {
  int seconds = 20;
  std::vector<int> cameras{0, 1, 2};
  std::string model;
  std::string pipelines = "pipelines";
  double drop = 0;
  // true: the cameras are pipelines/classroom.sh processes rendering live;
  // false: this program replays each camera's coded stream, recorded before
  // the run, at 30 fps (on a real rig the cameras are other machines, and
  // here three live renderers alone would need more than this machine's cores).
  bool live_cameras = false;
  // Largest RTP packet on every link (pipelines' MTU). Loopback's own MTU is
  // 64 KiB, as pipelines/loopback.sh uses: ~9 packets per camera frame instead
  // of ~400 at the 1400 that fits an Ethernet frame (--mtu 1400 measures that).
  int mtu = 65000;
  // Nice value of the server's camera-preparing threads (server.sh's PREP_NICE); -1: the script's default.
  int prep_nice = -1;
  // The camera link (classroom.sh's and server.sh's LINK): vcrd1 or h264.
  std::string link = "h264";
};

// Bytes per second one classroom pipeline sends (measured in this process, before the run).
double camera_link_rate(const Options& o) {
  uint64_t bytes = 0;
  GstElement* p = gst_parse_launch(
      ("rgbdtestsrc camera-id=0 num-buffers=60 ground-truth=false ! " +
       vclassroom_tools::camera_link_replay_coder(o.link) + " ! " +
       vclassroom_tools::camera_link_replay_payloader(o.link) +
       " mtu=" + std::to_string(o.mtu) + " ! fakesink name=net").c_str(),
      nullptr);
  GstElement* net = gst_bin_get_by_name(GST_BIN(p), "net");
  GstPad* pad = gst_element_get_static_pad(net, "sink");
  // The payloaders push buffer lists: one buffer per packet, each with 28 bytes of IP/UDP header to add.
  gst_pad_add_probe(
      pad, GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
      [](GstPad*, GstPadProbeInfo* info, gpointer data) {
        auto* total = static_cast<uint64_t*>(data);
        if (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST) {
          GstBufferList* list = GST_PAD_PROBE_INFO_BUFFER_LIST(info);
          *total += gst_buffer_list_calculate_size(list) + 28 * gst_buffer_list_length(list);
        } else {
          *total += gst_buffer_get_size(GST_PAD_PROBE_INFO_BUFFER(info)) + 28;
        }
        return GST_PAD_PROBE_OK;
      },
      &bytes, nullptr);
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  GstMessage* m = gst_bus_timed_pop_filtered(bus, 120 * GST_SECOND, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
  if (m) gst_message_unref(m);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(bus);
  gst_object_unref(pad);
  gst_object_unref(net);
  gst_object_unref(p);
  return bytes / 2.0;  // 60 frames = 2 s at 30 fps
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  g_autofree gchar *cameras = nullptr, *model = nullptr, *pipelines = nullptr, *link = nullptr;
  gboolean live_cameras = FALSE;
  const GOptionEntry entries[] = {
      {"seconds", 0, 0, G_OPTION_ARG_INT, &o.seconds, "measured seconds (default 20)", "N"},
      {"cameras", 0, 0, G_OPTION_ARG_STRING, &cameras, "rig cameras to stream (default \"0 1 2\")", "\"K ...\""},
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model, "V-DA model folder for server.sh (MODEL)", "DIR"},
      {"drop", 0, 0, G_OPTION_ARG_DOUBLE, &o.drop, "probability that a camera packet is dropped (identity drop-probability), 0 to 1", "P"},
      {"live-cameras", 0, 0, G_OPTION_ARG_NONE, &live_cameras,
       "run pipelines/classroom.sh per camera (rendering live) instead of replaying recorded streams", nullptr},
      {"mtu", 0, 0, G_OPTION_ARG_INT, &o.mtu,
       "largest RTP packet on every link (default 65000, loopback's; 1400 fits Ethernet)", "BYTES"},
      {"prep-nice", 0, 0, G_OPTION_ARG_INT, &o.prep_nice, "server.sh's PREP_NICE (default: the script's)", "N"},
      {"link", 0, 0, G_OPTION_ARG_STRING, &link,
       "the camera link: h264 (default: H.264 with the depth, rtph264pay, as classroom.sh) or vcrd1 (rgbdenc over rtpgstpay)", "LINK"},
      {"pipelines", 0, 0, G_OPTION_ARG_FILENAME, &pipelines, "folder of server.sh and classroom.sh (default pipelines)",
       "DIR"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Runs pipelines/server.sh as a process on loopback, acts as the lecturer, and prints pose-to-display\n"
      "latency p50/p99, frames sent and decoded per camera, frames displayed, bitrate per link and CPU per\n"
      "process. The cameras' coded streams are recorded first and replayed at 30 fps by this program.\n"
      "Run inside `meson devenv -C build`.",
      entries, gst_init_get_option_group());
  if (model) o.model = model;
  if (pipelines) o.pipelines = pipelines;
  if (link) o.link = link;
  if (o.link != "vcrd1" && o.link != "h264") vclassroom_tools::usage_error("--link is vcrd1 or h264");
  o.live_cameras = live_cameras;
  if (cameras) {
    o.cameras.clear();
    std::istringstream is(cameras);
    int k;
    while (is >> k) o.cameras.push_back(k);
    if (!is.eof() || o.cameras.empty())
      vclassroom_tools::usage_error(std::string("--cameras must be camera ids, e.g. \"0 1 2\" (got '") + cameras + "')");
  }
  if (o.seconds < 1 || !(o.drop >= 0 && o.drop <= 1) || o.mtu < 200 || o.mtu > 65000 || o.prep_nice < -1 ||
      o.prep_nice > 19)
    vclassroom_tools::usage_error("--seconds at least 1, --drop 0 to 1, --mtu 200 to 65000, --prep-nice 0 to 19");
  const double cam_rate = camera_link_rate(o);
  // Each camera's coded stream, as classroom.sh sends it, recorded once.
  std::vector<vclassroom_tools::Recording> recordings(o.live_cameras ? 0 : o.cameras.size());
  for (size_t i = 0; i < recordings.size(); ++i)
    if (!vclassroom_tools::record_stream("rgbdtestsrc camera-id=" + std::to_string(o.cameras[i]) +
                                             " num-buffers=60 ground-truth=false ! " +
                                             vclassroom_tools::camera_link_replay_coder(o.link),
                                         60, &recordings[i])) {
      std::fprintf(stderr, "could not record camera %d\n", o.cameras[i]);
      return 1;
    }

  std::string cams;
  for (int k : o.cameras) cams += (cams.empty() ? "" : " ") + std::to_string(k);
  // Each process logs its bus messages there; the codecs post their counts once a second.
  const std::string log_dir_path = vclassroom_tools::make_temp_dir("vclassroom-flow");
  const char* log_dir = log_dir_path.empty() ? nullptr : log_dir_path.c_str();
  if (!log_dir) {
    std::perror("cannot make a scratch folder");
    return 1;
  }
  const std::string server_log = std::string(log_dir) + "/server.log";
  std::vector<std::string> camera_logs;
  std::vector<pid_t> children;
  std::map<std::string, std::string> server_env = {
      {"CAMERAS", cams}, {"MODEL", o.model}, {"STATS", "30"}, {"MTU", std::to_string(o.mtu)}};
  if (o.prep_nice >= 0) server_env["PREP_NICE"] = std::to_string(o.prep_nice);
  // The replay sends plain RTP (classroom.sh with RTX=0): the server must not wait for retransmissions
  // that never come (each frame with a lost packet would be held for RTX_LATENCY, 300 ms).
  if (!o.live_cameras) server_env["RTX"] = "0";
  // The replay sends the recorded frames of the link asked for; live cameras and the server take it too.
  server_env["LINK"] = o.link;
  const pid_t server = spawn(o.pipelines + "/server.sh", server_env, server_log);
  children.push_back(server);

  // The lecturer: as pipelines/lecturer.sh, with probes before the sink.
  vclassroom_tools::Lecturer lecturer;
  if (!lecturer.start({5010, 5011, o.mtu, ""})) {
    vclassroom_tools::stop_children({server});
    return 1;
  }
  vclassroom_tools::Display& d = lecturer.shown;
  vclassroom_tools::CameraReplay replay;
  if (o.live_cameras) {
    for (int k : o.cameras) {
      camera_logs.push_back(std::string(log_dir) + "/camera" + std::to_string(k) + ".log");
      children.push_back(spawn(o.pipelines + "/classroom.sh",
                               {{"CAMERA", std::to_string(k)}, {"DROP", std::to_string(o.drop)}, {"STATS", "30"},
                                {"MTU", std::to_string(o.mtu)}, {"LINK", o.link}},
                               camera_logs.back()));
    }
  } else {
    std::vector<const vclassroom_tools::Recording*> streams;
    for (const auto& r : recordings) streams.push_back(&r);
    if (!replay.start(streams, o.cameras, o.drop, o.mtu, vclassroom_tools::camera_link_replay_payloader(o.link))) {
      std::fprintf(stderr, "could not start the cameras' replay\n");
      // The server already runs: stop it, so it does not keep the ports.
      for (pid_t c : children) {
        kill(c, SIGKILL);
        waitpid(c, nullptr, 0);
      }
      lecturer.stop();
      return 1;
    }
  }

  lecturer.start_walk();
  vclassroom_tools::Progress progress("measuring (s)", o.seconds);
  for (int t = 1; t <= o.seconds; ++t) {
    std::this_thread::sleep_for(std::chrono::seconds(1));  // the measured span, in steps that show progress
    progress.step(t);
  }
  std::vector<double> cpu;
  for (pid_t c : children) cpu.push_back(vclassroom_tools::cpu_seconds(c));
  lecturer.stop_walk();
  replay.stop();

  lecturer.stop();
  vclassroom_tools::stop_children(children);
  struct rusage self_usage;
  getrusage(RUSAGE_SELF, &self_usage);
  const double lect_cpu = self_usage.ru_utime.tv_sec + self_usage.ru_utime.tv_usec / 1e6 + self_usage.ru_stime.tv_sec +
                          self_usage.ru_stime.tv_usec / 1e6;

  const std::vector<double> latency_ms = d.latencies_ms();
  const uint64_t poses_sent = lecturer.poses_sent;
  std::printf("machine: %s, %ld cores; %zu synthetic cameras 960x540 at 30 fps on loopback (%s, LINK=%s), %d s, V-DA %s, MTU %d, PREP_NICE %s\n",
              vclassroom_tools::cpu_model().c_str(), sysconf(_SC_NPROCESSORS_ONLN), o.cameras.size(),
              o.live_cameras ? "live: pipelines/classroom.sh processes" : "coded streams replayed by this program",
              o.link.c_str(),
              o.seconds, o.model.empty() ? "off" : "on", o.mtu,
              o.prep_nice >= 0 ? std::to_string(o.prep_nice).c_str() : "default");
  std::printf("poses sent: %lu; distinct poses displayed: %zu\n", static_cast<unsigned long>(poses_sent), latency_ms.size());
  std::printf("pose-to-display latency: p50 %.1f ms, p99 %.1f ms\n", vclassroom_tools::percentile(latency_ms, 0.5),
              vclassroom_tools::percentile(latency_ms, 0.99));
  std::printf("frames displayed: %lu of %d rendered-at-30-fps slots (%.1f fps); with a pose stamp: %lu\n",
              static_cast<unsigned long>(d.frames), 30 * o.seconds, d.frames / static_cast<double>(o.seconds),
              static_cast<unsigned long>(d.frames_with_pose));
  for (size_t i = 0; i < o.cameras.size(); ++i) {
    const int k = o.cameras[i];
    const auto sent = o.live_cameras ? vclassroom_tools::last_codec_stats(camera_logs[i], "enc")
                                     : std::pair<long long, long long>{static_cast<long long>(replay.sent(i)), 0};
    const auto got = vclassroom_tools::last_codec_stats(server_log, "dec" + std::to_string(k));
    if (sent.first < 0 || got.first < 0) {
      std::printf("camera %d: no frame counts in the logs\n", k);
      continue;
    }
    std::printf("camera %d: %lld frames sent (%.1f fps), %lld %s by the server (%.1f %%), %lld damaged",
                k, sent.first, sent.first / static_cast<double>(o.seconds), got.first,
                o.link == "h264" ? "received whole" : "decoded", sent.first ? 100.0 * got.first / sent.first : 0.0,
                got.second);
    // The H.264 link's demux ("dec") checks and queues every frame's depth; the frames the server used are
    // those its join decoded (docs/network.md, "Decoding the depth where the picture is used").
    if (o.link == "h264") {
      const auto used = vclassroom_tools::last_codec_stats(server_log, "join" + std::to_string(k));
      std::printf(", %lld joined and used (%.1f %%)", used.first, sent.first ? 100.0 * used.first / sent.first : 0.0);
    }
    std::printf("; final counts at end of stream\n");
  }
  std::printf("bitrate: camera link %.1f Mbit/s each (measured alone); server->lecturer %.2f Mbit/s; pose link %.3f Mbit/s\n",
              cam_rate * 8 / 1e6, d.video_bytes * 8.0 / o.seconds / 1e6,
              (poses_sent + d.frames) * (kPoseWireSize + 12 + 28) * 8.0 / o.seconds / 1e6);
  std::printf("CPU (share of one core): server %.0f %%", 100 * cpu[0] / o.seconds);
  // cpu[] holds the server, then the camera processes when live.
  for (size_t i = 1; i < cpu.size(); ++i) std::printf(", camera %d %.0f %%", o.cameras[i - 1], 100 * cpu[i] / o.seconds);
  std::printf(", lecturer (this program%s) %.0f %%\n", o.live_cameras ? "" : ", with the camera replays",
              100 * lect_cpu / o.seconds);
  for (const auto& f : camera_logs) std::remove(f.c_str());
  std::remove(server_log.c_str());
  rmdir(log_dir);
  return 0;
}
