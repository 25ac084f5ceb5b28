// The camera link, old against new (docs/network.md, "The H.264 camera link"): each synthetic camera's
// frames are recorded into memory first, then sent through the old link (rgbdenc: JPEG q90 + lossless
// depth, rtpgstpay) and the new one (x264enc + depth coded across time in SEI, rtph264pay), MTU 1400; the
// camera side and the server side run as separate pipelines so each one's CPU is measured alone. Reports
// Mbit/s on the wire (RTP + 28 bytes of IPv4/UDP headers per packet), CPU ms per frame on each side,
// colour PSNR against the camera's own image, and the depth error against the sensor's depth (p99, max,
// and the pixels beyond the documented bound). With --redwood, the depth coder alone on the Redwood
// sequence as well.
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/video/video.h>
#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/image_io.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/depth_link.h>

#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;

namespace {

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Pushes `in` (with `caps`) through `chain` into an appsink; returns what came out and the CPU it took.
std::vector<GstSample*> run_chain(const std::string& chain, GstCaps* caps, const std::vector<GstBuffer*>& in,
                                  double* cpu_s) {
  const std::string desc = "appsrc name=src format=time block=true max-bytes=50000000 ! " + chain +
                           " ! appsink name=out sync=false";
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {
    std::fprintf(stderr, "cannot build '%s': %s\n", desc.c_str(), err ? err->message : "?");
    std::exit(1);
  }
  GstElement* src = gst_bin_get_by_name(GST_BIN(p), "src");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  g_object_set(src, "caps", caps, nullptr);
  std::vector<GstSample*> out;
  const double t0 = cpu_seconds();
  gst_element_set_state(p, GST_STATE_PLAYING);
  size_t next = 0;
  GstBus* bus = gst_element_get_bus(p);
  for (;;) {
    // Feed a few ahead, take what came out, until the end.
    while (next < in.size() && gst_app_src_get_current_level_bytes(GST_APP_SRC(src)) < 20000000) {
      gst_app_src_push_buffer(GST_APP_SRC(src), gst_buffer_ref(in[next++]));
      if (next == in.size()) gst_app_src_end_of_stream(GST_APP_SRC(src));
    }
    if (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 10 * GST_MSECOND)) {
      out.push_back(s);
      continue;
    }
    if (gst_app_sink_is_eos(GST_APP_SINK(sink))) break;
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      std::fprintf(stderr, "'%s' failed: %s\n", chain.c_str(), e ? e->message : "?");
      std::exit(1);
    }
  }
  *cpu_s = cpu_seconds() - t0;
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(src);
  gst_object_unref(sink);
  gst_object_unref(p);
  return out;
}

struct LinkResult {
  double mbit = 0, enc_ms = 0, dec_ms = 0, psnr = 0, p99 = 0, max_err = 0;
  size_t frames = 0, beyond_bound = 0, holes_changed = 0;
};

double percentile(std::vector<uint16_t>* v, double q) {
  if (v->empty()) return 0;
  const size_t k = std::min(v->size() - 1, size_t(q * double(v->size())));
  std::nth_element(v->begin(), v->begin() + long(k), v->end());
  return (*v)[k];
}

LinkResult measure(const vclassroom_tools::Recording& rec, const std::string& camera_chain,
                   const std::string& server_chain, uint16_t tolerance, int fps) {
  LinkResult r;
  double enc_s = 0, dec_s = 0;
  std::vector<GstSample*> rtp = run_chain(camera_chain, rec.caps, rec.frames, &enc_s);
  std::vector<GstBuffer*> packets;
  double wire_bytes = 0;
  for (GstSample* s : rtp) {
    packets.push_back(gst_sample_get_buffer(s));
    wire_bytes += double(gst_buffer_get_size(gst_sample_get_buffer(s)) + 28);
  }
  GstCaps* rtp_caps = gst_sample_get_caps(rtp.front());
  std::vector<GstSample*> out = run_chain(server_chain, rtp_caps, packets, &dec_s);
  const double n = double(rec.frames.size());
  r.mbit = wire_bytes * 8 / (n / fps) / 1e6;
  r.enc_ms = 1000 * enc_s / n;
  r.dec_ms = 1000 * dec_s / n;
  r.frames = out.size();
  RgbdInfo ti;
  std::string err;
  rgbd_info_from_caps(rec.caps, &ti, &err);
  std::vector<uint16_t> errors;
  double psnr_sum = 0;
  size_t next = 0;  // outputs come in order; a dropped frame is skipped
  for (GstSample* s : out) {
    GstBuffer* b = gst_sample_get_buffer(s);
    RgbdInfo oi;
    rgbd_info_from_caps(gst_sample_get_caps(s), &oi, &err);
    RgbdFrame o, t;
    if (!o.map(b, oi, GST_MAP_READ, &err)) continue;
    // The frame it came from: of the next three not yet matched, the one whose depth it is nearest to (the
    // sensor's noise is drawn anew for every frame, so another frame's depth is far off).
    size_t i = next;
    double best = 1e300;
    for (size_t c = next; c < std::min(next + 3, rec.frames.size()); ++c) {
      RgbdFrame tc;
      if (!tc.map(rec.frames[c], ti, GST_MAP_READ, &err)) continue;
      const double d = cv::norm(tc.depth(), o.depth(), cv::NORM_L1);
      if (d < best) {
        best = d;
        i = c;
      }
    }
    next = i + 1;
    if (i >= rec.frames.size() || !t.map(rec.frames[i], ti, GST_MAP_READ, &err)) continue;
    psnr_sum += cv::PSNR(t.color(), o.color(), 255.0);
    const cv::Mat td = t.depth(), od = o.depth();
    for (int y = 0; y < td.rows; ++y)
      for (int x = 0; x < td.cols; ++x) {
        const uint16_t z = td.at<uint16_t>(y, x), c = od.at<uint16_t>(y, x);
        if ((z == 0) != (c == 0)) {
          ++r.holes_changed;
          continue;
        }
        if (!z) continue;
        const auto e = uint16_t(std::abs(int(z) - int(c)));
        errors.push_back(e);
        if (e > depth_error_bound(z, tolerance)) ++r.beyond_bound;
      }
  }
  r.psnr = out.empty() ? 0 : psnr_sum / double(out.size());
  r.max_err = errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end());
  r.p99 = percentile(&errors, 0.99);
  for (GstSample* s : rtp) gst_sample_unref(s);
  for (GstSample* s : out) gst_sample_unref(s);
  return r;
}

// The lecturer's view along `trace` rendered from the 3 cameras coded by `coding` (non-live, so every run
// renders the same frames at the same poses): learnerseg, viewwarp and viewfuse as server.sh runs them.
std::vector<cv::Mat> views(const std::string& coding, const std::string& trace, int frames) {
  std::string desc = "viewfuse name=fuse pose-trace=" + trace + " ! videoconvert ! video/x-raw,format=RGB ! "
                     "appsink name=out sync=false ";
  for (int k = 0; k < 3; ++k)
    desc += "rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 ground-truth=false num-buffers=" +
            std::to_string(frames) + " ! " + coding + " ! learnerseg ! viewwarp ! fuse.cam_" + std::to_string(k) + " ";
  std::vector<cv::Mat> out;
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {
    std::fprintf(stderr, "cannot build the view pipeline: %s\n", err ? err->message : "?");
    std::exit(1);
  }
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  gst_element_set_state(p, GST_STATE_PLAYING);
  while (GstSample* s = gst_app_sink_pull_sample(GST_APP_SINK(sink))) {
    GstVideoInfo vi;
    gst_video_info_from_caps(&vi, gst_sample_get_caps(s));
    GstMapInfo map;
    gst_buffer_map(gst_sample_get_buffer(s), &map, GST_MAP_READ);
    out.push_back(cv::Mat(vi.height, vi.width, CV_8UC3, map.data, size_t(GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0))).clone());
    gst_buffer_unmap(gst_sample_get_buffer(s), &map);
    gst_sample_unref(s);
  }
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(sink);
  gst_object_unref(p);
  return out;
}

// Mean PSNR of `a` against `b`, frame by frame.
double mean_psnr(const std::vector<cv::Mat>& a, const std::vector<cv::Mat>& b) {
  double sum = 0;
  const size_t n = std::min(a.size(), b.size()), skip = 5;
  for (size_t i = skip; i < n; ++i) sum += cv::PSNR(a[i], b[i], 255.0);
  return n > skip ? sum / double(n - skip) : 0;
}

void redwood(const std::string& dir, uint16_t tolerance) {
  std::vector<cv::Mat> depths;
  for (int i = 0; i < 5; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/depth/%05d.png", i);
    depths.push_back(read_depth_mm(dir + name, 1.0));
  }
  for (uint16_t tol : {uint16_t(0), tolerance}) {
    DepthLinkEncoder enc;
    DepthLinkDecoder dec;
    size_t bytes = 0, beyond = 0;
    std::vector<uint16_t> errors;
    for (size_t i = 0; i < depths.size(); ++i) {
      std::vector<uint8_t> wire;
      enc.encode(depths[i], cv::Mat(), "", i == 0, tol, &wire);
      bytes += wire.size();
      DepthLinkFrame f;
      std::string err;
      if (!dec.decode(wire.data(), wire.size(), &f, &err)) std::fprintf(stderr, "redwood: %s\n", err.c_str());
      for (int y = 0; y < f.depth.rows; ++y)
        for (int x = 0; x < f.depth.cols; ++x) {
          const uint16_t z = depths[i].at<uint16_t>(y, x), c = f.depth.at<uint16_t>(y, x);
          if (!z) continue;
          errors.push_back(uint16_t(std::abs(int(z) - int(c))));
          if (errors.back() > depth_error_bound(z, tol)) ++beyond;
        }
    }
    std::printf("redwood depth, tolerance %.2f mm at 1 m: %.1f kB/frame (%.1f Mbit/s at 30 fps), error p99 %.0f mm, "
                "max %d mm, pixels beyond the bound %zu\n",
                tol / 100.0, bytes / 1000.0 / double(depths.size()), bytes * 8.0 * 30 / double(depths.size()) / 1e6,
                percentile(&errors, 0.99), errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end()), beyond);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 60, cameras = 3, bitrate = 4000;
  double tolerance = kDefaultDepthTolerance / 100.0;
  gchar* redwood_dir = nullptr;
  gchar* trace = nullptr;
  gboolean view = FALSE;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per camera (default 60: 2 s at 30 fps)", "N"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "synthetic cameras 0..N-1 (default 3)", "N"},
      {"bitrate", 0, 0, G_OPTION_ARG_INT, &bitrate, "x264enc bitrate in kbit/s (default 4000, classroom.sh's)", "K"},
      {"tolerance", 0, 0, G_OPTION_ARG_DOUBLE, &tolerance, "depth tolerance, mm at 1 m (default 2.8; 0: lossless)", "T"},
      {"redwood", 0, 0, G_OPTION_ARG_FILENAME, &redwood_dir, "also code the Redwood sequence's depth in DIR", "DIR"},
      {"view", 0, 0, G_OPTION_ARG_NONE, &view, "also render the lecturer's view from the 3 cameras through each link "
       "and compare it with the view from the uncoded frames (PSNR loss)", nullptr},
      {"trace", 0, 0, G_OPTION_ARG_FILENAME, &trace, "the view's pose trace (default: one pose, the first of "
       "pipelines/lecturer-walk.csv, held)", "CSV"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Sends each synthetic camera (960x540 at 30 fps, sensor model on, seed 1) through the old camera link and\n"
      "the new one and prints Mbit/s on the wire, CPU per frame, colour PSNR and depth error.",
      entries, gst_init_get_option_group());
  if (frames < 2 || cameras < 1 || cameras > 3 || bitrate < 100 || tolerance < 0 || tolerance > 655)
    vclassroom_tools::usage_error("--frames >= 2, --cameras 1 to 3, --bitrate >= 100, --tolerance 0 to 655");
  const auto tol = uint16_t(std::lround(tolerance * 100));
  char tol_text[32];
  std::snprintf(tol_text, sizeof tol_text, "%.2f", tolerance);
  const std::string old_cam = "rgbdenc quality=90 ! rtpgstpay config-interval=1 mtu=1400 pt=96";
  const std::string old_srv = "rtpgstdepay ! rgbddec";
  const std::string new_cam =
      "rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast "
      "key-int-max=60 bitrate=" + std::to_string(bitrate) + " ! video/x-h264,profile=constrained-baseline ! "
      "rgbdlinkmux depth-tolerance=" + tol_text + " ! rtph264pay mtu=1400 pt=96";
  const std::string new_srv = "rtph264depay ! rgbdlinkdemux ! openh264dec ! videoconvert ! rgbdlinkjoin";
  LinkResult sum_old, sum_new;
  for (int k = 0; k < cameras; ++k) {
    vclassroom_tools::Recording rec;
    if (!vclassroom_tools::record_stream("rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 ground-truth=false "
                                         "num-buffers=" + std::to_string(frames), frames, &rec))
      return 1;
    for (int link = 0; link < 2; ++link) {
      const LinkResult r = link == 0 ? measure(rec, old_cam, old_srv, 0, 30) : measure(rec, new_cam, new_srv, tol, 30);
      std::printf("camera %d, %s: %zu/%d frames, %.1f Mbit/s, camera CPU %.1f ms/frame, server CPU %.1f ms/frame, "
                  "colour PSNR %.2f dB, depth error p99 %.0f mm, max %.0f mm, beyond the bound %zu, holes changed %zu\n",
                  k, link == 0 ? "old link (rgbdenc, rtpgstpay)" : "new link (H.264 + depth SEI, rtph264pay)",
                  r.frames, frames, r.mbit, r.enc_ms, r.dec_ms, r.psnr, r.p99, r.max_err, r.beyond_bound,
                  r.holes_changed);
      LinkResult& s = link == 0 ? sum_old : sum_new;
      s.mbit += r.mbit / cameras;
      s.enc_ms += r.enc_ms / cameras;
      s.dec_ms += r.dec_ms / cameras;
      s.psnr += r.psnr / cameras;
      s.p99 = std::max(s.p99, r.p99);
      s.beyond_bound += r.beyond_bound;
    }
  }
  if (redwood_dir) redwood(redwood_dir, tol);
  double view_old = 0, view_new = 0;
  if (view) {
    // One pose held (a pose reaches the warps a frame or two after it is sent, on their own threads, so a
    // moving pose would make runs differ by when it arrived, not by the link); the first frames, rendered
    // before it arrived, are not compared.
    std::string t = trace ? trace : "";
    if (t.empty()) {
      t = vclassroom_tools::make_temp_dir("camlink") + "/pose.csv";
      FILE* f = std::fopen(t.c_str(), "w");
      std::fprintf(f, "t,x,y,z,qw,qx,qy,qz,fov\n0.0000,-0.80000,-0.25,-0.3,0.173648178,0.984807753,0,0,90\n");
      std::fclose(f);
    }
    const std::vector<cv::Mat> clean = views("identity", t, frames);
    const std::vector<cv::Mat> old_v = views("rgbdenc quality=90 ! rgbddec", t, frames);
    const std::vector<cv::Mat> new_v = views(
        new_cam.substr(0, new_cam.find(" ! rtph264pay")) + " ! rgbdlinkdemux ! openh264dec ! videoconvert ! "
        "video/x-raw,format=RGB ! rgbdlinkjoin", t, frames);
    view_old = mean_psnr(old_v, clean);
    view_new = mean_psnr(new_v, clean);
    std::printf("view along %s, %zu / %zu / %zu frames: PSNR against the view from the uncoded frames: old link "
                "%.2f dB, new link %.2f dB\n", t.c_str(), clean.size(), old_v.size(), new_v.size(), view_old, view_new);
  }
  std::printf("old link: %.1f Mbit/s per camera, camera %.1f ms, server %.1f ms per frame, colour PSNR %.2f dB\n",
              sum_old.mbit, sum_old.enc_ms, sum_old.dec_ms, sum_old.psnr);
  std::printf("camera link: %.1f Mbit/s per camera, camera %.1f ms, server %.1f ms per frame, colour PSNR %.2f dB "
              "(%.2f dB below the old link's), depth error p99 %.0f mm, %zu pixels beyond the bound\n",
              sum_new.mbit, sum_new.enc_ms, sum_new.dec_ms, sum_new.psnr, sum_old.psnr - sum_new.psnr, sum_new.p99,
              sum_new.beyond_bound);
  if (view)
    std::printf("camera link: %.1f Mbit/s per camera, view PSNR against the uncoded frames' view %.2f dB (old link "
                "%.2f dB), depth error p99 %.0f mm\n", sum_new.mbit, view_new, view_old, sum_new.p99);
  g_free(redwood_dir);
  g_free(trace);
  return sum_new.beyond_bound == 0 ? 0 : 1;
}
