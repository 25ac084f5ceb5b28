// Several lecturers at once: for each count of lecturers, starts a server
// (pipelines/server.sh with LECTURER_OUT=whep-views: a view per lecturer, fed
// by the cameras' coded streams, recorded once and replayed over RTP at 30 fps
// as cameras on other machines send them; or, with --live-cameras, a
// gst-launch-1.0 that renders the synthetic cameras itself) and that many
// headless Chromium pages (tests/browser/
// measure-lecturers.mjs, each its own browser, moving its head like a headset),
// and reports per count: frames shown per second, bitrate and pose-to-photon
// latency p50/p99 as the browsers saw them, and the server's CPU time per frame
// it delivered (from /proc, over the same window), and the video packets lost,
// sent again and the freezes the browsers counted. With --loss, the server runs
// with tools/lossy_udp.cpp preloaded: a share of its video packets never leaves.
// Browsers and server share the machine: the figures are the whole loop on one
// host.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gio/gio.h>
#include <glib.h>
#include <gst/gst.h>
#include <signal.h>
#include <unistd.h>

#include "browser_driver.h"
#include "camera_link_chain.h"
#include "flow_harness.h"
#include "free_port.h"
#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom_tools;

namespace {

struct LecturerResult {
  double fps = 0, kbps = 0, p50 = 0, p99 = 0;
  // Where the latency goes (medians, ms): the pose to its frame's echo (server), the pose to the frame's
  // last packet (server and transport), that packet to the frame's display (receiver), of which jitter
  // buffer and decode.
  double server_p50 = 0, receive_p50 = 0, display_p50 = 0, jitter_p50 = 0, decode_p50 = 0;
  long frames = 0, samples = 0;
  // The video's counters over the window: packets received, lost, received again, key frames asked for,
  // freezes and their seconds.
  double packets = 0, lost = 0, resent = 0, key_frames_asked = 0, freezes = 0, frozen_s = 0;
};

double json_number(const std::string& json, const std::string& key) {
  const size_t at = json.find("\"" + key + "\":");
  return at == std::string::npos ? std::nan("") : std::atof(json.c_str() + at + key.size() + 3);
}

}  // namespace

int main(int argc, char** argv) {
  g_autofree gchar* counts_text = nullptr;
  gint seconds = 20, cameras = 3;
  g_autofree gchar* size_text = nullptr;
  gboolean live_cameras = FALSE;
  gint64 warp_sync = 100000000, longest_turn = 100000000;
  gdouble loss_percent = 0;
  g_autofree gchar* link_text = nullptr;
  const GOptionEntry entries[] = {
      {"lecturers", 0, 0, G_OPTION_ARG_STRING, &counts_text, "Counts of lecturers to measure (default 1,2,4)", "N,N"},
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "Measured window per count (default 20)", "S"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "Synthetic cameras of the default rig, 1 to 3 (default 3)", "N"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size_text, "Each lecturer's view (default 960x540)", "WxH"},
      {"warp-sync", 0, 0, G_OPTION_ARG_INT64, &warp_sync,
       "How long (ns) each view's cameras wait for each other before reading the pose (whepviewsink warp-sync; "
       "default 100000000; 0: the behaviour before the wait existed)",
       "NS"},
      {"longest-turn", 0, 0, G_OPTION_ARG_INT64, &longest_turn,
       "How long (ns) a view may hold the turn to warp before the next view takes it (whepviewsink longest-turn; "
       "default 100000000; 0: every view warps at once, the behaviour before the turns existed)",
       "NS"},
      {"loss", 0, 0, G_OPTION_ARG_DOUBLE, &loss_percent,
       "Share of the server's video packets lost on the way, in % (tools/lossy_udp.cpp preloaded into the server; "
       "default 0)",
       "PERCENT"},
      {"live-cameras", 0, 0, G_OPTION_ARG_NONE, &live_cameras,
       "Render the synthetic cameras live inside the server (gst-launch-1.0 rgbdtestsrc is-live=true ! learnerseg "
       "! whepviewsink) instead of replaying their coded streams into pipelines/server.sh: the rendering then "
       "takes the server's CPU",
       nullptr},
      {"link", 0, 0, G_OPTION_ARG_STRING, &link_text,
       "The replayed cameras' link (classroom.sh's and server.sh's LINK): h264 (default, as the scripts) or vcrd1 "
       "(rgbdenc over rtpgstpay)",
       "LINK"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "Pose-to-photon latency, bitrate and server CPU with several browser lecturers "
                     "(whepviewsink; needs node, chromium and tests/browser/node_modules).",
                     entries, gst_init_get_option_group());
  int width = 960, height = 540;
  if (size_text) parse_size_or_exit("--size", size_text, &width, &height);
  if (cameras < 1 || cameras > 3) usage_error("--cameras must be 1 to 3");
  if (seconds < 5 || seconds > 600) usage_error("--seconds must be 5 to 600");
  if (warp_sync < 0 || warp_sync > 1000000000) usage_error("--warp-sync must be 0 to 1000000000 ns");
  if (longest_turn < 0 || longest_turn > 1000000000) usage_error("--longest-turn must be 0 to 1000000000 ns");
  if (!(loss_percent >= 0 && loss_percent <= 50)) usage_error("--loss must be 0 to 50 %");
  const std::string link = link_text ? link_text : "h264";
  if (link != "h264" && link != "vcrd1") usage_error("--link is h264 or vcrd1");
  // The lossy network, built beside this tool (a measuring aid of the build tree, not installed).
  std::map<std::string, std::string> loss_env;
  if (loss_percent > 0) {
    gchar* self = g_file_read_link("/proc/self/exe", nullptr);
    gchar* dir = self ? g_path_get_dirname(self) : g_strdup(".");
    const std::string shim = std::string(dir) + "/liblossyudp.so";
    g_free(dir);
    g_free(self);
    if (!g_file_test(shim.c_str(), G_FILE_TEST_EXISTS)) {
      std::fprintf(stderr, "%s: --loss needs %s (built with the tools)\n", g_get_prgname(), shim.c_str());
      return 1;
    }
    const char* preload = g_getenv("LD_PRELOAD");
    loss_env = {{"LD_PRELOAD", preload && *preload ? std::string(preload) + ":" + shim : shim},
                {"VCLASSROOM_LOSS_PERCENT", std::to_string(loss_percent)}};
  }
  std::vector<int> counts;
  gchar** parts = g_strsplit(counts_text ? counts_text : "1,2,4", ",", -1);
  for (gchar** it = parts; *it; ++it) counts.push_back(std::atoi(*it));
  g_strfreev(parts);
  for (int n : counts)
    if (n < 1 || n > 8) usage_error("--lecturers: each count 1 to 8");
  const std::string root = browser_driver_root("measure-lecturers.mjs");
  // The cameras' coded streams, as pipelines/classroom.sh sends them, recorded once (2 s, looped).
  std::vector<Recording> recordings(live_cameras ? 0 : size_t(cameras));
  std::vector<const Recording*> streams;
  std::vector<int> camera_ids;
  for (int k = 0; k < cameras; ++k) camera_ids.push_back(k);
  for (size_t k = 0; k < recordings.size(); ++k) {
    if (!record_stream("rgbdtestsrc camera-id=" + std::to_string(k) + " num-buffers=60 ground-truth=false ! " +
                           camera_link_replay_coder(link),
                       60, &recordings[k])) {
      std::fprintf(stderr, "%s: could not record camera %zu\n", g_get_prgname(), k);
      return 1;
    }
    streams.push_back(&recordings[k]);
  }
  const std::string log_dir = make_temp_dir("vclassroom-lecturers");
  if (log_dir.empty()) {
    std::perror("cannot make a scratch folder");
    return 1;
  }
  const std::string server_log = log_dir + "/server.log";
  std::printf("%d cameras %s, LINK=%s\n", cameras,
              live_cameras ? "rendered live inside the server" : "replayed into pipelines/server.sh", link.c_str());
  std::printf("| lecturers | fps shown (each) | kbit/s (each) | pose-to-photon p50 / p99 ms | server CPU ms per frame | "
              "server CPU %% of one core |\n|---|---|---|---|---|---|\n");
  for (int n : counts) {
    const int port = free_loopback_port(true);
    GPid pid = 0;
    GSubprocess* server = nullptr;
    CameraReplay replay;
    if (live_cameras) {
      std::string launch = "gst-launch-1.0 whepviewsink name=w port=" + std::to_string(port) +
                           " token=measure-token max-sessions=" + std::to_string(n) + " width=" + std::to_string(width) +
                           " height=" + std::to_string(height) + " warp-sync=" + std::to_string(warp_sync) +
                           " longest-turn=" + std::to_string(longest_turn) +
                           " web-root=" + root + "/web/lecturer";
      for (int k = 0; k < cameras; ++k)
        launch += " rgbdtestsrc camera-id=" + std::to_string(k) +
                  " is-live=true ! learnerseg ! queue max-size-buffers=1 leaky=downstream ! w.cam_" + std::to_string(k);
      gchar** server_argv = nullptr;
      g_shell_parse_argv(launch.c_str(), nullptr, &server_argv, nullptr);
      GError* err = nullptr;
      GSubprocessLauncher* server_launcher = g_subprocess_launcher_new(G_SUBPROCESS_FLAGS_STDOUT_SILENCE);
      for (const auto& [key, value] : loss_env) g_subprocess_launcher_setenv(server_launcher, key.c_str(), value.c_str(), TRUE);
      server = g_subprocess_launcher_spawnv(server_launcher, server_argv, &err);
      g_object_unref(server_launcher);
      g_strfreev(server_argv);
      if (!server) {
        std::fprintf(stderr, "%s: cannot start gst-launch-1.0: %s\n", g_get_prgname(), err->message);
        return 1;
      }
      pid = std::atoi(g_subprocess_get_identifier(server));
    } else {
      std::string ids;
      for (int k : camera_ids) ids += (ids.empty() ? "" : " ") + std::to_string(k);
      // RTX=0: the replay sends plain RTP, as classroom.sh with RTX=0 does; a server waiting for
      // retransmissions that never come holds each frame with a lost packet for RTX_LATENCY (300 ms).
      std::map<std::string, std::string> env = loss_env;
      env.insert({{"CAMERAS", ids}, {"MTU", "65000"}, {"RTX", "0"}, {"LINK", link}, {"LECTURER_OUT", "whep-views"},
                  {"TOKEN", "measure-token"}, {"WHEP_PORT", std::to_string(port)},
                  {"WHEP_SESSIONS", std::to_string(n)}, {"WIDTH", std::to_string(width)},
                  {"HEIGHT", std::to_string(height)}, {"WARP_SYNC", std::to_string(warp_sync)},
                  {"LONGEST_TURN", std::to_string(longest_turn)}});
      pid = spawn(root + "/pipelines/server.sh", env, server_log);
      if (!replay.start(streams, camera_ids, 0.0, 65000, camera_link_replay_payloader(link))) {
        stop_tree(pid);
        return 1;
      }
    }
    const std::string base = "http://127.0.0.1:" + std::to_string(port);
    GSubprocess* browsers = start_browser_driver(
        root, "measure-lecturers.mjs", {base, "measure-token", std::to_string(n), std::to_string(seconds)});
    std::fprintf(stderr, "%d lecturer(s): joining, then %d s measured\n", n, seconds);
    GDataInputStream* out = g_data_input_stream_new(g_subprocess_get_stdout_pipe(browsers));
    double cpu_start = -1, cpu_end = -1;
    gint64 t_start = 0, t_end = 0;
    std::vector<LecturerResult> results;
    while (gchar* line = g_data_input_stream_read_line(out, nullptr, nullptr, nullptr)) {
      const std::string l = line;
      g_free(line);
      if (l == "window start") {
        cpu_start = cpu_seconds(pid);
        t_start = g_get_monotonic_time();
      } else if (l == "window end") {
        cpu_end = cpu_seconds(pid);
        t_end = g_get_monotonic_time();
      } else if (l.rfind("lecturer {", 0) == 0) {
        LecturerResult r;
        r.fps = json_number(l, "fps");
        r.kbps = json_number(l, "kbps");
        r.p50 = json_number(l, "p50");
        r.p99 = json_number(l, "p99");
        r.frames = long(json_number(l, "frames"));
        r.samples = long(json_number(l, "samples"));
        r.server_p50 = json_number(l, "server_p50");
        r.receive_p50 = json_number(l, "receive_p50");
        r.display_p50 = json_number(l, "display_p50");
        r.jitter_p50 = json_number(l, "jitter_p50");
        r.decode_p50 = json_number(l, "decode_p50");
        r.packets = json_number(l, "packets");
        r.lost = json_number(l, "lost");
        r.resent = json_number(l, "resent");
        r.key_frames_asked = json_number(l, "key_frames_asked");
        r.freezes = json_number(l, "freezes");
        r.frozen_s = json_number(l, "frozen_s");
        results.push_back(r);
      }
    }
    g_object_unref(out);
    g_subprocess_wait(browsers, nullptr, nullptr);
    const bool browsers_ok = g_subprocess_get_if_exited(browsers) && g_subprocess_get_exit_status(browsers) == 0;
    g_object_unref(browsers);
    replay.stop();
    if (server) {
      g_subprocess_send_signal(server, SIGINT);
      g_subprocess_wait(server, nullptr, nullptr);
      g_object_unref(server);
    } else {
      stop_tree(pid);
    }
    if (!browsers_ok || int(results.size()) != n || cpu_start < 0 || cpu_end < 0) {
      std::fprintf(stderr,
                   "%s: %d lecturer(s): the browsers did not finish (%zu results); the server's log is kept: %s\n",
                   g_get_prgname(), n, results.size(), server_log.c_str());
      return 1;
    }
    auto list = [&](auto field, const char* format) {
      std::string s;
      for (const LecturerResult& r : results) {
        char b[32];
        std::snprintf(b, sizeof b, format, field(r));
        s += (s.empty() ? "" : ", ") + std::string(b);
      }
      return s;
    };
    long frames = 0;
    double p50 = 0, p99 = 0;
    for (const LecturerResult& r : results) {
      frames += r.frames;
      p50 = std::max(p50, r.p50);
      p99 = std::max(p99, r.p99);
    }
    const double cpu = cpu_end - cpu_start, wall = double(t_end - t_start) / 1e6;
    const std::string fps = list([](const LecturerResult& r) { return r.fps; }, "%.1f"),
                      kbps = list([](const LecturerResult& r) { return r.kbps; }, "%.0f"),
                      latency = list([](const LecturerResult& r) { return r.p50; }, "%.0f") + " / " +
                                list([](const LecturerResult& r) { return r.p99; }, "%.0f");
    std::printf("| %d | %s | %s | %s | %.1f | %.0f %% |\n", n, fps.c_str(), kbps.c_str(), latency.c_str(),
                frames > 0 ? cpu * 1000.0 / frames : 0.0, 100.0 * cpu / wall);
    std::printf("lecturers %d: medians: pose to echo (server) %s ms, pose to the frame's last packet %s ms, that "
                "packet to display %s ms, of which jitter buffer %s ms and decode %s ms\n",
                n, list([](const LecturerResult& r) { return r.server_p50; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.receive_p50; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.display_p50; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.jitter_p50; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.decode_p50; }, "%.1f").c_str());
    std::printf("lecturers %d: video packets lost %s %%, sent again %s, key frames asked for %s, freezes %s "
                "(%s s)\n",
                n, list([](const LecturerResult& r) { return 100.0 * r.lost / std::max(1.0, r.packets + r.lost); }, "%.1f").c_str(),
                list([](const LecturerResult& r) { return r.resent; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.key_frames_asked; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.freezes; }, "%.0f").c_str(),
                list([](const LecturerResult& r) { return r.frozen_s; }, "%.2f").c_str());
    std::printf("lecturers %d: worst p50 %.0f ms, worst p99 %.0f ms, %ld frames shown in %.1f s\n", n, p50, p99, frames,
                wall);
  }
  std::remove(server_log.c_str());
  g_rmdir(log_dir.c_str());
  return 0;
}
