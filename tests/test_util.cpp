#include "test_util.h"

#include <cstdlib>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <regex>

#include <sys/wait.h>

#include <gio/gio.h>
#include <gst/app/gstappsink.h>
#include <gtest/gtest.h>

#include <gst/vclassroom/synthetic/classroom.h>

#include "../tools/free_port.h"

namespace fs = std::filesystem;

namespace vctest {

TempDir::TempDir() {
  std::string tmpl = (fs::temp_directory_path() / "vclassroom-test-XXXXXX").string();
  char* p = mkdtemp(tmpl.data());
  path_ = p ? p : "";
}

TempDir::~TempDir() {
  std::error_code ec;
  if (!path_.empty()) fs::remove_all(path_, ec);
}

std::string shared_data() {
  const char* env = std::getenv("VCLASSROOM_SHARED_DATA");
  if (!env || !*env) return "";
  std::error_code ec;
  return fs::is_directory(env, ec) ? std::string(env) : "";
}

std::string shared_path(const std::string& relative) {
  const std::string root = shared_data();
  if (root.empty()) return "";
  std::error_code ec;
  const fs::path p = fs::path(root) / relative;
  return fs::exists(p, ec) ? p.string() : "";
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

vclassroom::Rig make_rig(int n, int width, int height) {
  vclassroom::Rig rig;
  rig.name = "test";
  for (int i = 0; i < n; ++i) {
    vclassroom::CameraCalib c;
    c.id = i;
    c.name = "cam" + std::to_string(i);
    c.width = width;
    c.height = height;
    c.fx = c.fy = 0.8 * width;
    c.cx = (width - 1) / 2.0;
    c.cy = (height - 1) / 2.0;
    c.cam_to_rig.translation() = Eigen::Vector3d(0.1 * i, 0, 0);
    rig.cameras.push_back(c);
  }
  return rig;
}

std::optional<std::string> posted_error(GstElement* element) {
  GstBus* bus = gst_element_get_bus(element);
  GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR);
  gst_object_unref(bus);
  if (!m) return std::nullopt;
  GError* err = nullptr;
  gst_message_parse_error(m, &err, nullptr);
  std::string text = err && err->message ? err->message : "";
  g_clear_error(&err);
  gst_message_unref(m);
  return text;
}

RunResult run_pipeline(GstElement* pipeline, GstClockTime timeout) {
  RunResult r;
  GstBus* bus = gst_element_get_bus(pipeline);
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
  bool done = false;
  while (!done) {
    GstMessage* msg = gst_bus_timed_pop_filtered(
        bus, timeout, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR | GST_MESSAGE_WARNING | GST_MESSAGE_ELEMENT));
    if (!msg) {
      ADD_FAILURE() << "pipeline neither finished nor failed within the time limit (hang)";
      r.error = "timeout";
      break;
    }
    switch (GST_MESSAGE_TYPE(msg)) {
      case GST_MESSAGE_EOS:
        done = true;
        break;
      case GST_MESSAGE_ERROR: {
        GError* err = nullptr;
        gst_message_parse_error(msg, &err, nullptr);
        r.error = err ? err->message : "unknown error";
        r.error_source = GST_OBJECT_NAME(GST_MESSAGE_SRC(msg));
        g_clear_error(&err);
        done = true;
        break;
      }
      case GST_MESSAGE_WARNING: {
        GError* err = nullptr;
        gst_message_parse_warning(msg, &err, nullptr);
        r.warnings.push_back(err ? err->message : "");
        g_clear_error(&err);
        break;
      }
      case GST_MESSAGE_ELEMENT: {
        if (const GstStructure* st = gst_message_get_structure(msg)) {
          gchar* text = gst_structure_to_string(st);
          r.element_messages.push_back(text);
          g_free(text);
        }
        break;
      }
      default:
        break;
    }
    gst_message_unref(msg);
  }
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(bus);
  return r;
}

RunResult run_launch(const std::string& description, GstClockTime timeout) {
  GError* err = nullptr;
  GstElement* pipeline = gst_parse_launch(description.c_str(), &err);
  if (!pipeline || err) {
    RunResult r;
    r.error = std::string("parse: ") + (err ? err->message : "?");
    g_clear_error(&err);
    if (pipeline) gst_object_unref(pipeline);
    return r;
  }
  RunResult r = run_pipeline(pipeline, timeout);
  gst_object_unref(pipeline);
  return r;
}

SampleCollector::SampleCollector(GstElement* appsink) {
  g_mutex_init(&lock_);
  GstAppSinkCallbacks cb{};
  cb.new_sample = &SampleCollector::on_sample;
  gst_app_sink_set_callbacks(GST_APP_SINK(appsink), &cb, this, nullptr);
}

SampleCollector::~SampleCollector() {
  for (GstSample* s : samples_) gst_sample_unref(s);
  g_mutex_clear(&lock_);
}

GstFlowReturn SampleCollector::on_sample(GstAppSink* sink, gpointer data) {
  auto* self = static_cast<SampleCollector*>(data);
  GstSample* s = gst_app_sink_pull_sample(sink);
  if (!s) return GST_FLOW_ERROR;
  g_mutex_lock(&self->lock_);
  self->samples_.push_back(s);
  g_mutex_unlock(&self->lock_);
  return GST_FLOW_OK;
}

int free_udp_port() { return vclassroom_tools::free_loopback_port(false); }

int free_tcp_port() { return vclassroom_tools::free_loopback_port(true); }

std::string first_response_line(int port, bool tls, const std::string& request) {
  GSocketClient* client = g_socket_client_new();
  g_socket_client_set_timeout(client, 30);
  if (tls) {
    g_socket_client_set_tls(client, TRUE);
    G_GNUC_BEGIN_IGNORE_DEPRECATIONS
    g_socket_client_set_tls_validation_flags(client, GTlsCertificateFlags(0));
    G_GNUC_END_IGNORE_DEPRECATIONS
  }
  GSocketConnection* conn = g_socket_client_connect_to_host(client, "127.0.0.1", guint16(port), nullptr, nullptr);
  g_object_unref(client);
  if (!conn) return "";
  GOutputStream* out = g_io_stream_get_output_stream(G_IO_STREAM(conn));
  std::string line;
  if (g_output_stream_write_all(out, request.data(), request.size(), nullptr, nullptr, nullptr)) {
    GDataInputStream* in = g_data_input_stream_new(g_io_stream_get_input_stream(G_IO_STREAM(conn)));
    gchar* text = g_data_input_stream_read_line(in, nullptr, nullptr, nullptr);
    line = text ? text : "";
    g_free(text);
    g_object_unref(in);
  }
  g_io_stream_close(G_IO_STREAM(conn), nullptr, nullptr);
  g_object_unref(conn);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

vclassroom::Pose sample_pose() {
  vclassroom::Pose p;
  p.position = Eigen::Vector3d(0.25, -0.1, 1.5);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1, 0).normalized()));
  p.fov_deg = 90;
  p.seq = 12345678901234ull;
  p.viewer_time_ns = 987654321;
  return p;
}

vclassroom::Pose pose_with_seq(uint64_t seq) {
  vclassroom::Pose p;
  const double k = static_cast<double>(seq % 100);
  p.position = Eigen::Vector3d(0.01 * k, -0.2, 0.5);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitY()));
  p.seq = seq;
  p.viewer_time_ns = 1000 + static_cast<int64_t>(seq);
  return p;
}

void expect_same_pose(const vclassroom::Pose& a, const vclassroom::Pose& b) {
  EXPECT_LT((a.position - b.position).norm(), 1e-12);
  EXPECT_LT(a.orientation.angularDistance(b.orientation), 1e-9);
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_EQ(a.viewer_time_ns, b.viewer_time_ns);
  EXPECT_EQ(a.has_fov(), b.has_fov());
  if (a.has_fov()) {
    EXPECT_DOUBLE_EQ(a.fov_deg, b.fov_deg);
  }
}

bool same_image(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

Exit run_tool(const std::vector<std::string>& argv) {
  std::vector<gchar*> cargv;
  for (const std::string& a : argv) cargv.push_back(const_cast<gchar*>(a.c_str()));
  cargv.push_back(nullptr);
  gchar *out = nullptr, *err = nullptr;
  gint wait_status = 0;
  Exit e;
  if (g_spawn_sync(nullptr, cargv.data(), nullptr, G_SPAWN_DEFAULT, nullptr, nullptr, &out, &err, &wait_status,
                   nullptr) &&
      WIFEXITED(wait_status))
    e.status = WEXITSTATUS(wait_status);
  e.out = out ? out : "";
  e.err = err ? err : "";
  g_free(out);
  g_free(err);
  return e;
}

void expect_rig_error_within_targets(const std::string& out) {
  static const std::regex last_line(R"(rig error: max ([0-9.]+) cm, max ([0-9.]+) deg, floor ([0-9.]+) deg\n$)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, last_line)) << out;
  EXPECT_LE(std::stod(m[1]), 1.0) << out;
  EXPECT_LE(std::stod(m[2]), 0.3) << out;
  EXPECT_LE(std::stod(m[3]), 0.5) << out;
}

std::string small_classroom_rig(const TempDir& dir, int width, int height) {
  vclassroom::Rig rig = vclassroom::default_classroom_rig();
  for (auto& c : rig.cameras) c = vclassroom::scale_camera(c, width, height);
  const std::string path = dir / "rig.yaml";
  vclassroom::save_rig(rig, path);
  return path;
}

std::vector<int16_t> read_s16_samples(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<int16_t> samples;
  for (int16_t v; in.read(reinterpret_cast<char*>(&v), sizeof v);) samples.push_back(v);
  return samples;
}

}  // namespace vctest
