// Faults the flow must survive, measured: the loopback flow (pipelines/server.sh
// and one pipelines/classroom.sh per camera as processes, this program as the
// lecturer) runs once per scenario, on its own ports, while one fault is
// applied: packet loss on the camera links (the scripts' DROP), garbage UDP on
// every port, a camera killed and restarted, a 1 kHz flood of foreign and
// garbage poses, or broken poses (NaN, Inf, absurd) in the lecturer's own
// authenticated session, or a captured signed pose replayed. For each it prints frames displayed per second,
// pose-to-display latency p50/p99, the warnings and errors the server posted,
// and every process's resident memory at the start and end of the measured span.
// --soak runs the fault-free flow for long and samples memory every 10 s.
// Figures: docs/reliability.md. Run from the source root inside `meson devenv -C build`.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>

#include <gst/rtp/gstrtpbuffer.h>

#include <functional>
#include <random>

#include <gst/vclassroom/net/pose_wire.h>

#include "flow_harness.h"
#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
namespace vt = vclassroom_tools;

namespace {

// A script's memory is its process tree's (server.sh runs gst-launch-1.0 as a
// child); this program's own (the lecturer) is its process alone, whose tree
// holds every other.
long process_rss(pid_t pid) {
  return pid == getpid() ? vclassroom_tools::rss_kib(pid) : vclassroom_tools::tree_rss_kib(pid);
}

struct Options {
  int seconds = 25;
  int warmup = 8;
  int soak = 0;
  std::vector<int> cameras{0, 1};
  std::string scenario = "all";
  std::string pipelines = "pipelines";
  int base_port = 15400;
  int mtu = 1400;
  int garbage_rate = 200;  // packets per second on each port
  guint32 seed = 1;
};

// The ports of one run: camera k on base + k, the lecturer's video on base + 10, poses on base + 11.
struct Ports {
  int base;
  int camera(int k) const { return base + k; }
  int video() const { return base + 10; }
  int pose() const { return base + 11; }
};

// A UDP socket that sends to 127.0.0.1.
class UdpSender {
 public:
  UdpSender() : fd_(socket(AF_INET, SOCK_DGRAM, 0)) {}
  ~UdpSender() {
    if (fd_ >= 0) close(fd_);
  }
  void send(int port, const std::vector<uint8_t>& bytes) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    (void)sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  }

 private:
  int fd_;
};

// `payload` as the RTP packet of the pose back channel (payload type 96).
std::vector<uint8_t> pose_rtp_packet(const uint8_t* payload, size_t size, uint32_t ssrc, uint16_t seq) {
  GstBuffer* buf = gst_rtp_buffer_new_allocate(static_cast<guint>(size), 0, 0);
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  gst_rtp_buffer_map(buf, GST_MAP_WRITE, &rtp);
  gst_rtp_buffer_set_payload_type(&rtp, 96);
  gst_rtp_buffer_set_ssrc(&rtp, ssrc);
  gst_rtp_buffer_set_seq(&rtp, seq);
  gst_rtp_buffer_set_marker(&rtp, TRUE);
  std::memcpy(gst_rtp_buffer_get_payload(&rtp), payload, size);
  gst_rtp_buffer_unmap(&rtp);
  std::vector<uint8_t> out(gst_buffer_get_size(buf));
  gst_buffer_extract(buf, 0, out.data(), out.size());
  gst_buffer_unref(buf);
  return out;
}

// The lecturer's pose stream as it leaves posesend: its SSRC, session, latest packet number and seq, and its
// first packet's payload as captured on the way (for the replay).
struct LecturerStream {
  std::mutex lock;
  bool seen = false;
  uint32_t ssrc = 0;
  uint64_t session = 0, packet = 0, seq = 0;
  std::vector<uint8_t> first_payload;
};

GstPadProbeReturn on_pose_packet(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* s = static_cast<LecturerStream*>(data);
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (!gst_rtp_buffer_map(GST_PAD_PROBE_INFO_BUFFER(info), GST_MAP_READ, &rtp)) return GST_PAD_PROBE_OK;
  const auto* p = static_cast<const uint8_t*>(gst_rtp_buffer_get_payload(&rtp));
  const size_t size = gst_rtp_buffer_get_payload_len(&rtp);
  Pose pose;
  PoseWireInfo wire;
  // Read as the server reads it, without the key (the lecturer's own packets: the tag is not the question).
  if (pose_from_wire(p, size, &pose, nullptr, nullptr, &wire)) {
    std::lock_guard<std::mutex> g(s->lock);
    s->seen = true;
    s->ssrc = gst_rtp_buffer_get_ssrc(&rtp);
    s->session = wire.stamp.session;
    s->packet = wire.stamp.packet;
    s->seq = pose.seq;
    if (s->first_payload.empty()) s->first_payload.assign(p, p + size);
  }
  gst_rtp_buffer_unmap(&rtp);
  return GST_PAD_PROBE_OK;
}

struct Scenario {
  std::string name;
  std::string what;
};

const std::vector<Scenario> kScenarios = {
    {"baseline", "no fault"},
    {"loss5", "5 % of camera packets dropped (classroom.sh DROP=0.05)"},
    {"loss30", "30 % of camera packets dropped (classroom.sh DROP=0.3)"},
    {"garbage", "random UDP (1-1500 bytes) on every camera, pose and video port"},
    {"camera-restart", "the first camera killed (SIGKILL) a third into the span, restarted 5 s later"},
    {"pose-flood", "1000 pose packets/s: foreign sessions untagged, wrongly tagged, seq 2^64-1, garbage"},
    {"bad-poses", "30/s NaN, Inf and absurd poses in the lecturer's own session, tagged with the real key"},
    {"pose-replay", "the lecturer's first signed pose packet, captured, replayed 10/s under a new SSRC each time"},
};

// One process's resident memory over a run.
struct Process {
  std::string name;
  pid_t pid;
  long rss_start = -1, rss_end = -1;
};

struct Result {
  double fps = 0, p50 = 0, p99 = 0;
  size_t poses_displayed = 0;
  vt::LaunchLogCounts server;
  uint64_t lecturer_warnings = 0, lecturer_errors = 0;
  std::map<std::string, uint64_t> lecturer_warnings_by_element;
  std::string load_start, load_end;  // load averages: what else the machine was doing
  bool server_died = false;
  std::vector<Process> processes;
  std::vector<std::pair<double, std::vector<long>>> rss_series;  // soak: seconds, RSS of each process
};

// The 1, 5 and 15 minute load averages (/proc/loadavg): what else the machine was doing.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

std::string random_key_file(const std::string& dir, std::mt19937* rng) {
  const std::string path = dir + "/pose.key";
  std::vector<char> key(32);
  for (char& c : key) c = static_cast<char>((*rng)() & 0xff);
  g_file_set_contents(path.c_str(), key.data(), static_cast<gssize>(key.size()), nullptr);
  return path;
}

// Runs the flow once with `scenario`'s fault for o.seconds (or o.soak) seconds after the warm-up.
bool run_flow(const Options& o, const std::string& scenario, Result* r) {
  const Ports ports{o.base_port};
  std::mt19937 rng(o.seed);
  const std::string dir = vt::make_temp_dir("vclassroom-faults");
  if (dir.empty()) {
    std::perror("cannot make a scratch folder");
    return false;
  }
  const std::string key_file = random_key_file(dir, &rng);
  const std::string server_log = dir + "/server.log";
  std::string cams, camera_ports;
  for (int k : o.cameras) {
    cams += (cams.empty() ? "" : " ") + std::to_string(k);
    camera_ports += (camera_ports.empty() ? "" : " ") + std::to_string(ports.camera(k));
  }
  const pid_t server = vt::spawn(o.pipelines + "/server.sh",
                                 {{"CAMERAS", cams},
                                  {"CAMERA_PORTS", camera_ports},
                                  {"VIDEO_PORT", std::to_string(ports.video())},
                                  {"POSE_PORT", std::to_string(ports.pose())},
                                  {"MTU", std::to_string(o.mtu)},
                                  {"POSE_KEY", key_file},
                                  {"STATS", "30"}},
                                 server_log);
  vt::Lecturer lecturer;
  if (!lecturer.start({ports.video(), ports.pose(), o.mtu, key_file})) {
    vt::stop_children({server});
    return false;
  }
  LecturerStream stream;
  GstElement* pose_out = gst_bin_get_by_name(GST_BIN(lecturer.pipeline()), "pose_out");
  GstPad* pose_pad = gst_element_get_static_pad(pose_out, "sink");
  gst_pad_add_probe(pose_pad, GST_PAD_PROBE_TYPE_BUFFER, on_pose_packet, &stream, nullptr);
  gst_object_unref(pose_pad);
  gst_object_unref(pose_out);

  const std::string drop = scenario == "loss5" ? "0.05" : scenario == "loss30" ? "0.3" : "0";
  auto start_camera = [&](int k) {
    return vt::spawn(o.pipelines + "/classroom.sh",
                     {{"CAMERA", std::to_string(k)}, {"PORT", std::to_string(ports.camera(k))}, {"DROP", drop},
                      {"MTU", std::to_string(o.mtu)}},
                     dir + "/camera" + std::to_string(k) + ".log");
  };
  std::vector<pid_t> cameras;
  for (int k : o.cameras) cameras.push_back(start_camera(k));
  lecturer.start_walk();

  const int span = o.soak > 0 ? o.soak : o.seconds;
  vt::Progress warming("warming up (s)", o.warmup);
  for (int t = 1; t <= o.warmup; ++t) {
    std::this_thread::sleep_for(std::chrono::seconds(1));  // the pipelines start; a tool's pacing
    warming.step(t);
  }
  auto all_pids = [&] {
    std::vector<std::pair<std::string, pid_t>> out{{"server", server}};
    for (size_t i = 0; i < cameras.size(); ++i) out.push_back({"camera" + std::to_string(o.cameras[i]), cameras[i]});
    out.push_back({"lecturer", getpid()});  // this program
    return out;
  };
  for (const auto& [name, pid] : all_pids()) r->processes.push_back({name, pid, process_rss(pid), -1});
  lecturer.shown.reset();
  lecturer.count_bus_messages();
  lecturer.warnings = lecturer.errors = 0;
  lecturer.warnings_by_element.clear();
  r->load_start = load_average();

  // The fault, on its own thread until `faulting` goes false.
  std::atomic<bool> faulting{true};
  std::thread injector;
  if (scenario == "garbage") {
    injector = std::thread([&, seed = rng()] {
      std::mt19937 g(seed);
      UdpSender udp;
      std::vector<int> targets{ports.pose(), ports.video()};
      for (int k : o.cameras) targets.push_back(ports.camera(k));
      const auto t0 = std::chrono::steady_clock::now();
      for (uint64_t n = 0; faulting; ++n) {
        std::this_thread::sleep_until(t0 + std::chrono::microseconds(n * 1000000 / o.garbage_rate));
        for (int port : targets) {
          std::vector<uint8_t> bytes(1 + g() % 1500);
          for (auto& b : bytes) b = static_cast<uint8_t>(g());
          udp.send(port, bytes);
        }
      }
    });
  } else if (scenario == "pose-flood") {
    injector = std::thread([&, seed = rng()] {
      std::mt19937_64 g(seed);
      UdpSender udp;
      PoseKey wrong_key;
      for (int i = 0; i < 32; ++i) wrong_key.bytes.push_back(static_cast<uint8_t>(g()));
      const CameraCalib reference = rig_origin_reference();
      const auto t0 = std::chrono::steady_clock::now();
      uint8_t wire[kPoseWireMaxSize];
      for (uint64_t n = 0; faulting; ++n) {
        std::this_thread::sleep_until(t0 + std::chrono::microseconds(n * 1000));  // 1 kHz
        ViewOffset v;
        v.right = 1.0;  // a view the lecturer did not ask for
        Pose p = offset_to_pose(v, reference);
        p.seq = n + 1;
        p.viewer_time_ns = static_cast<int64_t>(gst_util_get_timestamp());
        std::vector<uint8_t> payload;
        switch (n % 4) {
          case 0:  // well-formed, untagged, a new session every 100 packets
            payload.assign(wire, wire + pose_to_wire(p, wire, 0x5000 + n / 100));
            break;
          case 1:  // tagged with a key that is not the server's
            payload.assign(wire, wire + pose_to_wire(p, wire, 0x6000, &wrong_key));
            break;
          case 2:  // the seq that used to lock the channel
            p.seq = UINT64_MAX;
            payload.assign(wire, wire + pose_to_wire(p, wire, 0x7000 + n));
            break;
          default:  // garbage of a pose packet's size or any size
            payload.resize(g() % 2 ? kPoseWireMaxSize : 1 + g() % 1400);
            for (auto& b : payload) b = static_cast<uint8_t>(g());
        }
        udp.send(ports.pose(), pose_rtp_packet(payload.data(), payload.size(), static_cast<uint32_t>(g()),
                                               static_cast<uint16_t>(n)));
      }
    });
  } else if (scenario == "bad-poses") {
    injector = std::thread([&] {
      UdpSender udp;
      const PoseKey key = load_pose_key(key_file);
      const CameraCalib reference = rig_origin_reference();
      const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
      const auto t0 = std::chrono::steady_clock::now();
      uint8_t wire[kPoseWireMaxSize];
      for (uint64_t n = 0; faulting; ++n) {
        std::this_thread::sleep_until(t0 + std::chrono::microseconds(n * 1000000 / 30));
        uint32_t ssrc;
        uint64_t session, packet, seq;
        {
          std::lock_guard<std::mutex> g(stream.lock);
          if (!stream.seen) continue;
          ssrc = stream.ssrc;
          session = stream.session;
          packet = stream.packet;
          seq = stream.seq;
        }
        // Pose carries any numbers; only validate_pose() (not pose_to_wire) refuses them.
        Pose p = offset_to_pose(ViewOffset{}, reference);
        switch (n % 6) {
          case 0: p.position.x() = nan; break;
          case 1: p.position.y() = inf; break;
          case 2: p.position = Eigen::Vector3d(1e6, 0, 0); break;  // 1000 km away
          case 3: p.orientation = Eigen::Quaterniond(nan, 0, 0, 0); break;
          case 4: p.fov_deg = 1e9; break;
          default: p.orientation.coeffs().setZero(); break;  // stays zero through normalized()
        }
        p.seq = seq + 1;  // the lecturer's next
        p.viewer_time_ns = static_cast<int64_t>(gst_util_get_timestamp());
        const PoseWireStamp stamp(session, packet + 1, static_cast<int64_t>(gst_util_get_timestamp()));
        const size_t size = pose_to_wire(p, wire, stamp, &key);
        udp.send(ports.pose(), pose_rtp_packet(wire, size, ssrc, static_cast<uint16_t>(n)));
      }
    });
  } else if (scenario == "pose-replay") {
    injector = std::thread([&, seed = rng()] {
      std::mt19937 g(seed);
      UdpSender udp;
      const auto t0 = std::chrono::steady_clock::now();
      for (uint64_t n = 0; faulting; ++n) {
        std::this_thread::sleep_until(t0 + std::chrono::milliseconds(n * 100));  // 10/s
        std::vector<uint8_t> captured;
        {
          std::lock_guard<std::mutex> lk(stream.lock);
          captured = stream.first_payload;
        }
        if (captured.empty()) continue;
        udp.send(ports.pose(), pose_rtp_packet(captured.data(), captured.size(), static_cast<uint32_t>(g()),
                                               static_cast<uint16_t>(n)));
      }
    });
  } else if (scenario == "camera-restart") {
    injector = std::thread([&] {
      auto pause = [&](int seconds) {
        for (int i = 0; i < 10 * seconds && faulting; ++i)
          std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the fault's schedule
      };
      pause(o.seconds / 3);
      if (!faulting) return;
      kill(cameras[0], SIGKILL);
      waitpid(cameras[0], nullptr, 0);
      std::fprintf(stderr, "camera %d killed\n", o.cameras[0]);
      pause(5);
      if (!faulting) return;
      cameras[0] = start_camera(o.cameras[0]);
      std::fprintf(stderr, "camera %d restarted\n", o.cameras[0]);
    });
  }

  vt::Progress progress(o.soak > 0 ? "soak (s)" : scenario + " (s)", span);
  const auto t0 = std::chrono::steady_clock::now();
  for (int t = 1; t <= span; ++t) {
    std::this_thread::sleep_until(t0 + std::chrono::seconds(t));  // the measured span, in steps that show progress
    progress.step(t);
    lecturer.count_bus_messages();
    if (o.soak > 0 && t % 10 == 0) {
      std::vector<long> rss;
      for (const auto& [name, pid] : all_pids()) rss.push_back(process_rss(pid));
      r->rss_series.push_back({static_cast<double>(t), rss});
    }
  }
  faulting = false;
  if (injector.joinable()) injector.join();
  {
    const auto pids = all_pids();
    for (size_t i = 0; i < pids.size(); ++i) {
      r->processes[i].pid = pids[i].second;  // a restarted camera is a new process
      r->processes[i].rss_end = process_rss(pids[i].second);
    }
  }
  r->server_died = vt::has_exited(server);
  lecturer.count_bus_messages();
  const std::vector<double> latency = lecturer.shown.latencies_ms();
  {
    std::lock_guard<std::mutex> g(lecturer.shown.lock);
    r->fps = lecturer.shown.frames / static_cast<double>(span);
  }
  r->poses_displayed = latency.size();
  r->p50 = vt::percentile(latency, 0.5);
  r->p99 = vt::percentile(latency, 0.99);
  r->lecturer_warnings = lecturer.warnings;
  r->lecturer_errors = lecturer.errors;
  r->lecturer_warnings_by_element = lecturer.warnings_by_element;
  r->load_end = load_average();

  lecturer.stop();
  std::vector<pid_t> children = cameras;
  children.push_back(server);
  vt::stop_children(children);
  r->server = vt::count_launch_log(server_log);
  for (int k : o.cameras) std::remove((dir + "/camera" + std::to_string(k) + ".log").c_str());
  std::remove(server_log.c_str());
  std::remove(key_file.c_str());
  rmdir(dir.c_str());
  return true;
}

std::string mib(long kib) {
  if (kib < 0) return "gone";
  char s[32];
  std::snprintf(s, sizeof s, "%.0f", kib / 1024.0);
  return s;
}

// Least-squares slope of y over x (per unit of x).
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = x.size();
  if (n < 2) return 0;
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) mx += x[i] / n, my += y[i] / n;
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < n; ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
  return sxx > 0 ? sxy / sxx : 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  gchar *cameras = nullptr, *scenario = nullptr, *pipelines = nullptr;
  gint seed = 1;
  const GOptionEntry entries[] = {
      {"scenario", 0, 0, G_OPTION_ARG_STRING, &scenario,
       "one of baseline, loss5, loss30, garbage, camera-restart, pose-flood, bad-poses, pose-replay, or all (default)", "NAME"},
      {"seconds", 0, 0, G_OPTION_ARG_INT, &o.seconds, "measured seconds per scenario (default 25)", "N"},
      {"warmup", 0, 0, G_OPTION_ARG_INT, &o.warmup, "seconds the flow runs before each measured span (default 8)",
       "N"},
      {"soak", 0, 0, G_OPTION_ARG_INT, &o.soak,
       "instead of the scenarios: the fault-free flow for N seconds, every process's RSS every 10 s", "N"},
      {"cameras", 0, 0, G_OPTION_ARG_STRING, &cameras, "rig cameras to stream (default \"0 1\")", "\"K ...\""},
      {"base-port", 0, 0, G_OPTION_ARG_INT, &o.base_port,
       "camera k on PORT + k, the lecturer's video on PORT + 10, poses on PORT + 11 (default 15400)", "PORT"},
      {"mtu", 0, 0, G_OPTION_ARG_INT, &o.mtu, "the scripts' MTU (default 1400, as they default to)", "BYTES"},
      {"garbage-rate", 0, 0, G_OPTION_ARG_INT, &o.garbage_rate,
       "garbage packets per second on each port in the garbage scenario (default 200)", "N"},
      {"seed", 0, 0, G_OPTION_ARG_INT, &seed, "seed of the pose key, garbage and flood (default 1)", "N"},
      {"pipelines", 0, 0, G_OPTION_ARG_FILENAME, &pipelines, "folder of server.sh and classroom.sh (default pipelines)",
       "DIR"},
      {}};
  vt::parse_command_line(
      &argc, &argv, "",
      "Runs the loopback flow (pipelines/server.sh and classroom.sh as processes, this program as the\n"
      "lecturer, 960x540, authenticated poses) once per fault scenario and prints, for each, frames displayed\n"
      "per second, pose-to-display latency p50/p99, warnings and errors the server posted, and the RSS of\n"
      "every process at the start and end. --soak N runs the fault-free flow for N s and prints every\n"
      "process's RSS every 10 s with its growth per minute. Run inside `meson devenv -C build`.",
      entries, gst_init_get_option_group());
  if (scenario) o.scenario = scenario;
  if (pipelines) o.pipelines = pipelines;
  o.seed = static_cast<guint32>(seed);
  if (cameras) {
    o.cameras.clear();
    std::istringstream is(cameras);
    int k;
    while (is >> k) o.cameras.push_back(k);
    if (!is.eof() || o.cameras.empty() || o.cameras.size() > 8 ||
        std::any_of(o.cameras.begin(), o.cameras.end(), [](int c) { return c < 0 || c > 9; }))
      vt::usage_error(std::string("--cameras must be 1 to 8 camera ids 0 to 9, e.g. \"0 1\" (got '") + cameras + "')");
  }
  std::vector<Scenario> chosen;
  for (const auto& s : kScenarios)
    if (o.scenario == "all" || o.scenario == s.name) chosen.push_back(s);
  if (chosen.empty()) vt::usage_error("unknown --scenario '" + o.scenario + "' (see --help)");
  if (o.seconds < 3 || o.warmup < 0 || o.soak < 0 || o.mtu < 200 || o.mtu > 65000 || o.garbage_rate < 1 ||
      o.garbage_rate > 10000 || o.base_port < 1024 || o.base_port > 65000)
    vt::usage_error("--seconds at least 3, --warmup and --soak not negative, --mtu 200 to 65000, --garbage-rate 1 "
                    "to 10000, --base-port 1024 to 65000");
  if (o.soak > 0) chosen = {kScenarios[0]};

  std::string cams;
  for (int k : o.cameras) cams += (cams.empty() ? "" : " ") + std::to_string(k);
  std::printf("machine: %s, %ld cores, load average now %s; cameras \"%s\" (pipelines/classroom.sh, live, 960x540 at "
              "30 fps), MTU %d, ports %d-%d, seed %u\n",
              vt::cpu_model().c_str(), sysconf(_SC_NPROCESSORS_ONLN),
              load_average().c_str(),
              cams.c_str(), o.mtu, o.base_port, o.base_port + 11, o.seed);
  if (o.soak > 0) {
    Result r;
    if (!run_flow(o, "baseline", &r)) return 1;
    std::printf("soak: %d s of the fault-free flow; RSS in MiB every 10 s\n", o.soak);
    std::printf("%6s", "t (s)");
    for (const auto& p : r.processes) std::printf("  %s", p.name.c_str());
    std::printf("\n");
    for (const auto& [t, rss] : r.rss_series) {
      std::printf("%6.0f", t);
      for (size_t i = 0; i < rss.size(); ++i)
        std::printf("  %*s", static_cast<int>(r.processes[i].name.size()), mib(rss[i]).c_str());
      std::printf("\n");
    }
    std::printf("RSS growth per minute (least squares over all samples; over the second half):\n");
    for (size_t i = 0; i < r.processes.size(); ++i) {
      std::vector<double> x, y, x2, y2;
      for (const auto& [t, rss] : r.rss_series) {
        if (rss[i] < 0) continue;
        x.push_back(t / 60);
        y.push_back(rss[i]);
        if (t > o.soak / 2.0) x2.push_back(t / 60), y2.push_back(rss[i]);
      }
      std::printf("  %s: %+.0f KiB/min; %+.0f KiB/min\n", r.processes[i].name.c_str(), slope(x, y), slope(x2, y2));
    }
    std::printf("displayed %.1f fps, latency p50 %.0f ms, p99 %.0f ms; server: %ld warnings, %ld errors, cameras lost %ld "
                "/ returned %ld%s; load average at start %s, at end %s\n",
                r.fps, r.p50, r.p99, r.server.warnings, r.server.errors, r.server.cameras_lost,
                r.server.cameras_returned, r.server_died ? "; SERVER EXITED" : "", r.load_start.c_str(),
                r.load_end.c_str());
    return 0;
  }

  std::vector<std::pair<Scenario, Result>> results;
  for (const auto& s : chosen) {
    std::fprintf(stderr, "scenario %s: %s\n", s.name.c_str(), s.what.c_str());
    Result r;
    if (!run_flow(o, s.name, &r)) return 1;
    results.push_back({s, std::move(r)});
  }
  std::printf("%d s measured per scenario after %d s of warm-up\n", o.seconds, o.warmup);
  std::printf("| scenario | fault | fps displayed | latency p50 / p99 (ms) | server warnings / errors | "
              "cameras lost / returned | RSS start -> end (MiB) |\n|---|---|---|---|---|---|---|\n");
  for (const auto& [s, r] : results) {
    std::string rss;
    for (const auto& p : r.processes)
      rss += (rss.empty() ? "" : ", ") + p.name + " " + mib(p.rss_start) + " -> " + mib(p.rss_end);
    std::printf("| %s | %s | %.1f | %.0f / %.0f | %ld / %ld%s | %ld / %ld | %s |\n", s.name.c_str(), s.what.c_str(),
                r.fps, r.p50, r.p99, r.server.warnings, r.server.errors, r.server_died ? " (server exited)" : "",
                r.server.cameras_lost, r.server.cameras_returned, rss.c_str());
  }
  for (const auto& [s, r] : results) {
    if (!r.server.first_warning.empty())
      std::printf("%s: first server warning: %s\n", s.name.c_str(), r.server.first_warning.substr(0, 300).c_str());
    if (!r.server.first_error.empty())
      std::printf("%s: first server error: %s\n", s.name.c_str(), r.server.first_error.substr(0, 300).c_str());
    std::string by;
    for (const auto& [element, n] : r.server.warnings_by_element) by += " " + element + " " + std::to_string(n) + ";";
    if (!by.empty()) std::printf("%s: server warnings by element:%s\n", s.name.c_str(), by.c_str());
    by.clear();
    for (const auto& [element, n] : r.lecturer_warnings_by_element) by += " " + element + " " + std::to_string(n) + ";";
    if (r.lecturer_warnings || r.lecturer_errors)
      std::printf("%s: lecturer bus: %lu warnings, %lu errors; warnings by element:%s\n", s.name.c_str(),
                  static_cast<unsigned long>(r.lecturer_warnings), static_cast<unsigned long>(r.lecturer_errors),
                  by.c_str());
    std::printf("%s: load average at start %s, at end %s\n", s.name.c_str(), r.load_start.c_str(), r.load_end.c_str());
  }
  return 0;
}
