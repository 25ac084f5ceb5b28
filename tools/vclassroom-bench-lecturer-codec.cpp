// Which codec for the browser lecturer (docs/lecturer.md): H.264 constrained
// baseline (x264enc, as whepserversink and whepviewsink run it) against VP8
// (vp8enc in real-time mode, two speeds) on the synthetic classroom's camera
// view at 960x540, 30 fps, at the same target bitrates. For each: the bitrate
// reached, the PSNR of the decoded frames against the frames encoded, and the
// encoder's wall time per frame (a probe before and after it; one frame in,
// one out with these settings).
#include <cstdio>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>

#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/synthetic/classroom.h>

#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
using namespace vclassroom_tools;

namespace {

struct Codec {
  const char* name;
  std::string encoder;  // the encoder is named enc; {KBIT} or {BIT} stands for the bitrate
  const char* decoder;
};

// Frames leave these encoders in the order they came (no B-frames, no lag), but with other timestamps
// (x264enc shifts them): matched in order.
struct Timing {
  std::mutex lock;
  std::deque<gint64> in_us;
  std::vector<double> ms;
};

GstPadProbeReturn note_in(GstPad*, GstPadProbeInfo*, gpointer data) {
  auto* t = static_cast<Timing*>(data);
  std::lock_guard<std::mutex> g(t->lock);
  t->in_us.push_back(g_get_monotonic_time());
  return GST_PAD_PROBE_OK;
}

GstPadProbeReturn note_out(GstPad*, GstPadProbeInfo*, gpointer data) {
  auto* t = static_cast<Timing*>(data);
  std::lock_guard<std::mutex> g(t->lock);
  if (t->in_us.empty()) return GST_PAD_PROBE_OK;
  t->ms.push_back((g_get_monotonic_time() - t->in_us.front()) / 1000.0);
  t->in_us.pop_front();
  return GST_PAD_PROBE_OK;
}

struct Result {
  double kbps = 0, psnr = 0, encode_ms = 0;
  size_t frames = 0;
  std::string error;
};

Result run_codec(const Codec& codec, int kbit, const std::vector<cv::Mat>& frames, int width, int height) {
  Result r;
  // x264enc takes kbit/s ({KBIT}), vp8enc bit/s ({BIT}).
  std::string enc = codec.encoder;
  if (size_t at = enc.find("{KBIT}"); at != std::string::npos) enc.replace(at, 6, std::to_string(kbit));
  if (size_t at = enc.find("{BIT}"); at != std::string::npos) enc.replace(at, 5, std::to_string(kbit * 1000));
  const std::string desc =
      "appsrc name=src format=time caps=video/x-raw,format=RGB,width=" + std::to_string(width) +
      ",height=" + std::to_string(height) + ",framerate=30/1 ! videoconvert ! video/x-raw,format=I420 ! " + enc +
      " ! tee name=t ! queue ! appsink name=bits sync=false t. ! queue ! " + codec.decoder +
      " ! videoconvert ! video/x-raw,format=RGB ! appsink name=out sync=false";
  GError* err = nullptr;
  GstElement* pipe = gst_parse_launch(desc.c_str(), &err);
  if (!pipe) {
    r.error = err ? err->message : "cannot build";
    g_clear_error(&err);
    return r;
  }
  GstElement *src = gst_bin_get_by_name(GST_BIN(pipe), "src"), *bits = gst_bin_get_by_name(GST_BIN(pipe), "bits"),
             *out = gst_bin_get_by_name(GST_BIN(pipe), "out"), *encoder = gst_bin_get_by_name(GST_BIN(pipe), "enc");
  Timing timing;
  GstPad* enc_sink = gst_element_get_static_pad(encoder, "sink");
  GstPad* enc_src = gst_element_get_static_pad(encoder, "src");
  gst_pad_add_probe(enc_sink, GST_PAD_PROBE_TYPE_BUFFER, note_in, &timing, nullptr);
  gst_pad_add_probe(enc_src, GST_PAD_PROBE_TYPE_BUFFER, note_out, &timing, nullptr);
  gst_object_unref(enc_sink);
  gst_object_unref(enc_src);
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  size_t bytes = 0;
  double psnr_sum = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    GstBuffer* b = gst_buffer_new_memdup(frames[i].data, frames[i].total() * frames[i].elemSize());
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    GST_BUFFER_DURATION(b) = GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
    // One frame at a time through both branches (these encoders hold no frame back), so encode time is
    // the encoder's alone.
    GstSample* coded = gst_app_sink_try_pull_sample(GST_APP_SINK(bits), 10 * GST_SECOND);
    GstSample* decoded = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 10 * GST_SECOND);
    if (!coded || !decoded) {
      r.error = "frame " + std::to_string(i) + " did not come through";
      if (coded) gst_sample_unref(coded);
      if (decoded) gst_sample_unref(decoded);
      break;
    }
    bytes += gst_buffer_get_size(gst_sample_get_buffer(coded));
    GstMapInfo map;
    GstBuffer* db = gst_sample_get_buffer(decoded);
    if (gst_buffer_map(db, &map, GST_MAP_READ)) {
      // videoconvert's RGB rows are 4-byte aligned: 960 * 3 already is.
      const cv::Mat got(height, width, CV_8UC3, map.data, GST_ROUND_UP_4(width * 3));
      psnr_sum += psnr_rgb(frames[i], got);
      gst_buffer_unmap(db, &map);
    }
    gst_sample_unref(coded);
    gst_sample_unref(decoded);
    r.frames = i + 1;
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  gst_element_set_state(pipe, GST_STATE_NULL);
  for (GstElement* e : {src, bits, out, encoder}) gst_object_unref(e);
  gst_object_unref(pipe);
  if (r.frames) {
    r.kbps = bytes * 8.0 / 1000.0 / (r.frames / 30.0);
    r.psnr = psnr_sum / r.frames;
    double sum = 0;
    for (double ms : timing.ms) sum += ms;
    r.encode_ms = timing.ms.empty() ? 0 : sum / timing.ms.size();
  }
  return r;
}

// Up to `count` frames, as RGB at width x height, from `source` (a launch description ending in raw video;
// record_stream runs it). Empty when it failed (record_stream said why).
std::vector<cv::Mat> read_frames(const std::string& source, int count, int width, int height) {
  std::vector<cv::Mat> frames;
  Recording rec;
  if (!record_stream(source + " ! identity eos-after=" + std::to_string(count) +
                         " ! videoconvert ! videoscale ! video/x-raw,format=RGB,width=" + std::to_string(width) +
                         ",height=" + std::to_string(height),
                     1, &rec))
    return frames;
  for (GstBuffer* b : rec.frames) {
    GstMapInfo map;
    if (!gst_buffer_map(b, &map, GST_MAP_READ)) continue;
    if (map.size >= size_t(GST_ROUND_UP_4(width * 3)) * height)
      frames.push_back(cv::Mat(height, width, CV_8UC3, map.data, GST_ROUND_UP_4(width * 3)).clone());
    gst_buffer_unmap(b, &map);
  }
  return frames;
}

// `path` as a quoted value of a launch description (any name).
std::string launch_quoted(const std::string& path) {
  std::string q = "\"";
  for (char c : path) q += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return q + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  gint count = 150;
  gchar* bitrates_text = nullptr;
  gchar* input = nullptr;
  gboolean all_in_one = FALSE;
  const GOptionEntry entries[] = {
      {"all-in-one", 0, 0, G_OPTION_ARG_NONE, &all_in_one,
       "Code the lecturer's view as the all-in-one chain renders it (3 synthetic cameras, learnerseg, viewwarp "
       "along pipelines/lecturer-walk.csv, viewfuse; no V-DA) instead of the centre camera",
       nullptr},
      {"input", 0, 0, G_OPTION_ARG_FILENAME, &input,
       "A video file to code instead (needs a GStreamer decoder for it)", "FILE"},
      {"frames", 0, 0, G_OPTION_ARG_INT, &count, "Frames of the classroom's centre camera at 30 fps (default 150)", "N"},
      {"bitrates", 0, 0, G_OPTION_ARG_STRING, &bitrates_text, "Target bitrates in kbit/s (default 2000,4000,8000)",
       "K,K"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "H.264 (x264enc as whepserversink runs it) against VP8 (vp8enc real-time) on the synthetic "
                     "classroom at 960x540: bitrate reached, PSNR of what the browser decodes, encode ms per frame.",
                     entries, gst_init_get_option_group());
  if (count < 30 || count > 3000) usage_error("--frames must be 30 to 3000");
  std::vector<int> bitrates;
  gchar** parts = g_strsplit(bitrates_text ? bitrates_text : "2000,4000,8000", ",", -1);
  for (gchar** it = parts; *it; ++it) bitrates.push_back(std::atoi(*it));
  g_strfreev(parts);
  for (int k : bitrates)
    if (k < 100 || k > 50000) usage_error("--bitrates: each 100 to 50000 kbit/s");
  const int width = 960, height = 540;
  std::vector<cv::Mat> frames;
  if (input || all_in_one) {
    std::string chain;
    if (all_in_one) {
      const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
      const std::string trace = std::string(source_dir ? source_dir : ".") + "/pipelines/lecturer-walk.csv";
      chain = "viewfuse name=fuse";
      for (int k = 0; k < 3; ++k)
        chain += " rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 learners=6 num-buffers=" +
                 std::to_string(count) + " ground-truth=false ! learnerseg ! viewwarp pose-trace=\"" + trace +
                 "\" ! queue max-size-buffers=2 ! fuse.cam_" + std::to_string(k);
      chain += " fuse.";
    }
    if (input) chain = "filesrc location=" + launch_quoted(input) + " ! decodebin";
    frames = read_frames(chain, count, width, height);
    if (frames.empty()) {
      std::fprintf(stderr, "%s: no frames from %s\n", g_get_prgname(), input ? input : "the all-in-one chain");
      return 1;
    }
    std::fprintf(stderr, "%zu frames of %s\n", frames.size(), input ? input : "the all-in-one chain");
  } else {
    const Rig rig = default_classroom_rig();
    const Classroom room;
    std::fprintf(stderr, "rendering %d frames\n", count);
    for (int i = 0; i < count; ++i) frames.push_back(render(room, i / 30.0, rig.camera(0)).color);
  }
  const std::vector<Codec> codecs = {
      {"H.264 CB x264 ultrafast zerolatency",
       "x264enc name=enc tune=zerolatency speed-preset=ultrafast key-int-max=60 bitrate={KBIT} ! "
       "video/x-h264,profile=constrained-baseline,stream-format=byte-stream",
       "h264parse ! openh264dec"},
      {"VP8 realtime cpu-used=4",
       "vp8enc name=enc deadline=1 cpu-used=4 end-usage=cbr lag-in-frames=0 keyframe-max-dist=60 threads=2 target-bitrate={BIT}",
       "vp8dec"},
      {"VP8 realtime cpu-used=16",
       "vp8enc name=enc deadline=1 cpu-used=16 end-usage=cbr lag-in-frames=0 keyframe-max-dist=60 threads=2 "
       "target-bitrate={BIT}",
       "vp8dec"},
  };
  std::printf("| codec | target kbit/s | reached kbit/s | PSNR dB | encode ms/frame |\n|---|---|---|---|---|\n");
  for (const Codec& c : codecs)
    for (int k : bitrates) {
      const Result r = run_codec(c, k, frames, width, height);
      if (!r.error.empty()) {
        std::printf("| %s | %d | failed: %s | | |\n", c.name, k, r.error.c_str());
        continue;
      }
      std::printf("| %s | %d | %.0f | %.2f | %.2f |\n", c.name, k, r.kbps, r.psnr, r.encode_ms);
    }
  return 0;
}
