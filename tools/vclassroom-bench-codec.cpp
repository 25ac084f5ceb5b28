// Speed and size of rgbdenc's codec at 960x540 on the synthetic classroom
// (sensor model on), against PNG (OpenCV) and FFV1 (libav, when installed):
// milliseconds per frame on one thread, bytes per frame, Mbit/s per camera.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <opencv2/imgcodecs.hpp>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/net/rgbd_codec.h>

#include "tool_options.h"

using namespace vclassroom;
using Clock = std::chrono::steady_clock;

namespace {

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

struct Stats {
  double enc_ms = 0, dec_ms = 0, bytes = 0;
  int n = 0;
  void add(double e, double d, size_t b) {
    enc_ms += e;
    dec_ms += d;
    bytes += static_cast<double>(b);
    ++n;
  }
  void print(const char* name, double fps) const {
    if (!n) return;
    std::printf("%-28s %8.2f %8.2f %10.0f %9.2f\n", name, enc_ms / n, dec_ms / n, bytes / n,
                bytes / n * 8 * fps / 1e6);
  }
};

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// FFV1 through GStreamer's libav wrapper: encode all frames, then decode them.
bool bench_ffv1(const std::vector<cv::Mat>& depths, Stats* st) {
  if (!gst_element_factory_find("avenc_ffv1") || !gst_element_factory_find("avdec_ffv1")) return false;
  const int w = depths[0].cols, h = depths[0].rows;
  GstElement* enc = gst_parse_launch(
      "appsrc name=src format=time ! avenc_ffv1 ! appsink name=out sync=false", nullptr);
  GstElement *src = gst_bin_get_by_name(GST_BIN(enc), "src"), *out = gst_bin_get_by_name(GST_BIN(enc), "out");
  GstCaps* caps = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "GRAY16_LE", "width", G_TYPE_INT, w,
                                      "height", G_TYPE_INT, h, "framerate", GST_TYPE_FRACTION, 30, 1, nullptr);
  gst_app_src_set_caps(GST_APP_SRC(src), caps);
  gst_element_set_state(enc, GST_STATE_PLAYING);
  std::vector<GstSample*> coded;
  double enc_ms = 0;
  for (size_t i = 0; i < depths.size(); ++i) {
    GstBuffer* b = gst_buffer_new_allocate(nullptr, depths[i].total() * 2, nullptr);
    gst_buffer_fill(b, 0, depths[i].data, depths[i].total() * 2);
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    const auto t0 = Clock::now();
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
    GstSample* s = gst_app_sink_pull_sample(GST_APP_SINK(out));  // intra-only: one out per in
    enc_ms += ms_since(t0);
    coded.push_back(s);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  gst_element_set_state(enc, GST_STATE_NULL);
  GstCaps* coded_caps = gst_caps_copy(gst_sample_get_caps(coded[0]));
  GstElement* dec = gst_parse_launch("appsrc name=src format=time ! avdec_ffv1 ! appsink name=out sync=false", nullptr);
  GstElement *dsrc = gst_bin_get_by_name(GST_BIN(dec), "src"), *dout = gst_bin_get_by_name(GST_BIN(dec), "out");
  gst_app_src_set_caps(GST_APP_SRC(dsrc), coded_caps);
  gst_element_set_state(dec, GST_STATE_PLAYING);
  double dec_ms = 0;
  for (GstSample* s : coded) {
    GstBuffer* b = gst_buffer_ref(gst_sample_get_buffer(s));
    const size_t size = gst_buffer_get_size(b);
    const auto t0 = Clock::now();
    gst_app_src_push_buffer(GST_APP_SRC(dsrc), b);
    GstSample* d = gst_app_sink_pull_sample(GST_APP_SINK(dout));
    dec_ms += ms_since(t0);
    if (d) gst_sample_unref(d);
    st->add(0, 0, size);
    gst_sample_unref(s);
  }
  st->enc_ms = enc_ms;
  st->dec_ms = dec_ms;
  gst_app_src_end_of_stream(GST_APP_SRC(dsrc));
  gst_element_set_state(dec, GST_STATE_NULL);
  for (GstElement* e : {src, out, dsrc, dout, enc, dec}) gst_object_unref(e);
  gst_caps_unref(caps);
  gst_caps_unref(coded_caps);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 30;
  int quality = 90;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per camera (default 30)", "N"},
      {"quality", 0, 0, G_OPTION_ARG_INT, &quality, "JPEG quality of the colour, 1 to 100 (default 90)", "Q"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Codes N frames of each of the 3 synthetic cameras (960x540, sensor model on) and prints ms per frame\n"
      "(one thread), bytes per frame and Mbit/s per camera at 30 fps.",
      entries, gst_init_get_option_group());
  if (frames < 1 || quality < 1 || quality > 100)
    vclassroom_tools::usage_error("--frames must be at least 1, --quality 1 to 100");
  Classroom room;
  const Rig rig = default_classroom_rig();
  std::vector<cv::Mat> colors, depths;
  vclassroom_tools::Progress rendering("rendering", static_cast<long>(rig.cameras.size()) * frames);
  for (const auto& cam : rig.cameras)
    for (int i = 0; i < frames; ++i) {
      rendering.step(static_cast<long>(depths.size()) + 1);
      RenderOutput clean = render(room, i / 30.0, cam);
      cv::Mat depth, color;
      apply_sensor_model(clean, cam, SensorParams(), 1, static_cast<uint64_t>(i), &depth, &color);
      colors.push_back(color);
      depths.push_back(depth);
    }
  Stats ours, png1, png3, jpeg, frame_stats, ffv1;
  std::vector<uint8_t> bytes;
  cv::Mat back;
  double crc_s = 0, crc_bytes = 0;
  uint32_t crc_seen = 0;  // keeps the checksums from being optimised away
  vclassroom_tools::Progress coding("coding", static_cast<long>(depths.size()));
  for (size_t i = 0; i < depths.size(); ++i) {
    coding.step(static_cast<long>(i) + 1);
    auto t0 = Clock::now();
    crc_seen ^= crc32(depths[i].data, depths[i].total() * depths[i].elemSize());
    crc_s += ms_since(t0) / 1e3;
    crc_bytes += static_cast<double>(depths[i].total() * depths[i].elemSize());
    t0 = Clock::now();
    encode_depth_lossless(depths[i], &bytes);
    const double e = ms_since(t0);
    t0 = Clock::now();
    if (!decode_depth_lossless(bytes.data(), bytes.size(), depths[i].cols, depths[i].rows, &back)) return 1;
    ours.add(e, ms_since(t0), bytes.size());
    if (cv::norm(back, depths[i], cv::NORM_INF) != 0) {
      std::fprintf(stderr, "depth codec is not lossless!\n");
      return 1;
    }
    for (int level : {1, 3}) {
      std::vector<uchar> png;
      t0 = Clock::now();
      cv::imencode(".png", depths[i], png, {cv::IMWRITE_PNG_COMPRESSION, level});
      const double pe = ms_since(t0);
      t0 = Clock::now();
      cv::Mat pd = cv::imdecode(png, cv::IMREAD_UNCHANGED);
      (level == 1 ? png1 : png3).add(pe, ms_since(t0), png.size());
    }
    t0 = Clock::now();
    encode_jpeg(colors[i], quality, &bytes);
    const double je = ms_since(t0);
    t0 = Clock::now();
    cv::Mat rgb;
    decode_jpeg(bytes.data(), bytes.size(), colors[i].cols, colors[i].rows, &rgb, nullptr);
    jpeg.add(je, ms_since(t0), bytes.size());
    t0 = Clock::now();
    encode_rgbd_frame({colors[i], depths[i], cv::Mat()}, quality, &bytes);
    const double fe = ms_since(t0);
    t0 = Clock::now();
    RgbdCodedFrame f;
    decode_rgbd_frame(bytes.data(), bytes.size(), colors[i].cols, colors[i].rows, &f, nullptr);
    frame_stats.add(fe, ms_since(t0), bytes.size());
  }
  const bool have_ffv1 = bench_ffv1(depths, &ffv1);
  std::printf("machine: %s; input: %zu frames of the synthetic classroom (3 cameras, 960x540, sensor model on, seed 1)\n",
              cpu_model().c_str(), depths.size());
  std::printf("%-28s %8s %8s %10s %9s\n", "codec", "enc ms", "dec ms", "bytes", "Mbit/s@30");
  std::printf("%-28s %8s %8s %10.0f %9.2f\n", "depth raw (16 bit)", "-", "-", depths[0].total() * 2.0,
              depths[0].total() * 2.0 * 8 * 30 / 1e6);
  ours.print("depth rgbdenc (lossless)", 30);
  png1.print("depth PNG level 1", 30);
  png3.print("depth PNG level 3", 30);
  if (have_ffv1) ffv1.print("depth FFV1 (libav)", 30);
  else std::printf("%-28s n/a: install gstreamer1.0-libav to compare\n", "depth FFV1");
  char name[64];
  std::snprintf(name, sizeof name, "colour JPEG q%d", quality);
  jpeg.print(name, 30);
  frame_stats.print("whole rgbdenc frame", 30);
  std::printf("CRC-32 (zlib crc32_z) over the raw depth: %.2f GB/s (check %08x)\n", crc_bytes / crc_s / 1e9, crc_seen);
  return 0;
}
