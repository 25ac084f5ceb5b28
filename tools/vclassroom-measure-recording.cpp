// Does a live recording keep up and keep every frame? Feeds synthetic
// 960x540 cameras at 30 fps in real time (frames rendered into memory first:
// the renderer is slower than a camera, and it is the recorder that is
// measured) through rgbdenc ! queue ! rgbdfilesink for a fixed time, noting
// each frame (running time and a CRC of its depth) and how late it reached
// the disk; then plays the recording back with rgbdfilesrc and compares:
// frames fed, frames recorded, frames whose depth or time differs.
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <map>
#include <thread>
#include <mutex>
#include <string>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <gst/gst.h>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/rgbd.h>

#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;
using namespace vclassroom_tools;

namespace {

constexpr int kLoopFrames = 30;

struct FrameNote {
  GstClockTime running_time = GST_CLOCK_TIME_NONE;
  guint64 offset = 0;
  uint32_t depth_crc = 0;
};

struct Notes {
  std::mutex lock;
  std::map<int, std::vector<FrameNote>> by_camera;
};

struct ProbeContext {
  Notes* notes;
  int camera;
};

// How late frames reach the recording sink: its clock's running time when a
// frame arrives minus the frame's running time.
struct Lateness {
  std::mutex lock;
  std::vector<double> ms;
};

GstPadProbeReturn note_lateness(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  GstElement* sink = GST_PAD_PARENT(pad);
  GstClock* clock = gst_element_get_clock(sink);
  if (!clock) return GST_PAD_PROBE_OK;
  const GstClockTime now = gst_clock_get_time(clock) - gst_element_get_base_time(sink);
  gst_object_unref(clock);
  const GstClockTime pts = GST_BUFFER_PTS(GST_PAD_PROBE_INFO_BUFFER(info));
  auto* late = static_cast<Lateness*>(data);
  std::lock_guard<std::mutex> g(late->lock);
  late->ms.push_back((double(now) - double(pts)) / 1e6);
  return GST_PAD_PROBE_OK;
}

uint32_t depth_crc(GstBuffer* buf, GstCaps* caps) {
  RgbdInfo info;
  RgbdFrame frame;
  if (!caps || !rgbd_info_from_caps(caps, &info, nullptr) || !frame.map(buf, info, GST_MAP_READ, nullptr)) return 0;
  const cv::Mat depth = frame.depth().isContinuous() ? frame.depth() : frame.depth().clone();
  return crc32(depth.data, depth.total() * depth.elemSize());
}

GstPadProbeReturn note_frame(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* ctx = static_cast<ProbeContext*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstCaps* caps = gst_pad_get_current_caps(pad);
  FrameNote note;
  note.depth_crc = depth_crc(buf, caps);
  if (caps) gst_caps_unref(caps);
  note.offset = GST_BUFFER_OFFSET(buf);
  GstEvent* seg_event = gst_pad_get_sticky_event(pad, GST_EVENT_SEGMENT, 0);
  if (seg_event) {
    const GstSegment* segment;
    gst_event_parse_segment(seg_event, &segment);
    note.running_time = gst_segment_to_running_time(segment, GST_FORMAT_TIME, GST_BUFFER_PTS(buf));
    gst_event_unref(seg_event);
  }
  std::lock_guard<std::mutex> g(ctx->notes->lock);
  ctx->notes->by_camera[ctx->camera].push_back(note);
  return GST_PAD_PROBE_OK;
}

// Runs a pipeline until EOS or error; the error text ("" on EOS). With
// `seconds` > 0 it sends EOS after that long (as Ctrl-C with gst-launch -e);
// `progress_seconds` > 0 shows progress towards that many seconds.
std::string run(GstElement* pipeline, int seconds, int progress_seconds = 0) {
  GstBus* bus = gst_element_get_bus(pipeline);
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
  std::string error;
  const gint64 start = g_get_monotonic_time();
  bool eos_sent = false;
  Progress progress("recording (s)", progress_seconds);
  for (;;) {
    GstMessage* msg = gst_bus_timed_pop_filtered(bus, GST_SECOND, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    const long elapsed = long((g_get_monotonic_time() - start) / G_USEC_PER_SEC);
    if (progress_seconds > 0) progress.step(std::min<long>(elapsed, progress_seconds));
    if (!msg) {
      if (seconds > 0 && !eos_sent && elapsed >= seconds) {
        gst_element_send_event(pipeline, gst_event_new_eos());
        eos_sent = true;
      }
      continue;
    }
    if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
      GError* err = nullptr;
      gst_message_parse_error(msg, &err, nullptr);
      error = err->message;
      g_error_free(err);
    }
    gst_message_unref(msg);
    break;
  }
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(bus);
  return error;
}

}  // namespace

int main(int argc, char** argv) {
  gint seconds = 60, cameras = 3;
  gchar* out = nullptr;
  const GOptionEntry entries[] = {
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "How long to record (default 60)", "N"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "Synthetic cameras of the default rig, 1 to 3 (default 3)", "N"},
      {"out", 0, 0, G_OPTION_ARG_FILENAME, &out, "Recording folder (default out/recording; replaced)", "DIR"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "Records synthetic 960x540 cameras live at 30 fps (rgbdenc ! rgbdfilesink) and checks the "
                     "recording: every frame recorded, depth bit for bit, times kept.",
                     entries, gst_init_get_option_group());
  if (seconds < 1 || seconds > 3600) usage_error("--seconds must be 1 to 3600");
  if (cameras < 1 || cameras > 3) usage_error("--cameras must be 1 to 3");
  const std::string folder = out ? out : "out/recording";
  g_free(out);
  if (g_file_test(folder.c_str(), G_FILE_TEST_EXISTS)) {
    const std::string rm = "rm -rf '" + folder + "'";
    if (std::system(rm.c_str()) != 0) usage_error("cannot replace " + folder);
  }
  if (!make_folder(folder)) return 1;

  // One second of each camera, rendered first and fed in a loop.
  std::vector<Recording> frames(static_cast<size_t>(cameras));
  std::vector<std::vector<uint32_t>> crcs(static_cast<size_t>(cameras));
  for (int k = 0; k < cameras; ++k) {
    std::fprintf(stderr, "rendering camera %d\n", k);
    if (!record_stream("rgbdtestsrc camera-id=" + std::to_string(k) + " num-buffers=" + std::to_string(kLoopFrames),
                       kLoopFrames, &frames[size_t(k)]))
      return 1;
    for (GstBuffer* b : frames[size_t(k)].frames) crcs[size_t(k)].push_back(depth_crc(b, frames[size_t(k)].caps));
  }

  std::string desc;
  for (int k = 0; k < cameras; ++k)
    desc += "appsrc name=cam" + std::to_string(k) +
            " is-live=true format=time max-bytes=0 ! rgbdenc ! queue max-size-buffers=0 max-size-bytes=0 "
            "max-size-time=0 ! rgbdfilesink name=rec" + std::to_string(k) + " location=" + folder + "  ";
  GError* err = nullptr;
  GstElement* recorder = gst_parse_launch(desc.c_str(), &err);
  if (!recorder || err) {
    std::fprintf(stderr, "cannot build the recorder: %s\n", err ? err->message : "?");
    return 1;
  }
  Notes notes;
  Lateness lateness;
  std::vector<GstElement*> sources;
  for (int k = 0; k < cameras; ++k) {
    GstElement* src = gst_bin_get_by_name(GST_BIN(recorder), ("cam" + std::to_string(k)).c_str());
    g_object_set(src, "caps", frames[size_t(k)].caps, nullptr);
    sources.push_back(src);
    GstElement* sink = gst_bin_get_by_name(GST_BIN(recorder), ("rec" + std::to_string(k)).c_str());
    GstPad* pad = gst_element_get_static_pad(sink, "sink");
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, note_lateness, &lateness, nullptr);
    gst_object_unref(pad);
    gst_object_unref(sink);
  }
  std::printf("recording %d camera(s) of 960x540 at 30 fps live for %d s into %s\n", cameras, seconds,
              folder.c_str());
  // The feeder: frame n of every camera at running time n/30 s, when the clock gets there.
  std::atomic<bool> stop{false};
  std::thread feeder([&] {
    GstClock* clock = nullptr;
    while (!stop && !(clock = gst_element_get_clock(recorder))) g_usleep(1000);
    if (!clock) return;
    const GstClockTime base = gst_element_get_base_time(recorder);
    const guint64 total = guint64(seconds) * 30;
    for (guint64 n = 0; n < total && !stop; ++n) {
      const GstClockTime pts = gst_util_uint64_scale(n, GST_SECOND, 30);
      GstClockID id = gst_clock_new_single_shot_id(clock, base + pts);
      gst_clock_id_wait(id, nullptr);
      gst_clock_id_unref(id);
      for (int k = 0; k < cameras; ++k) {
        const size_t i = size_t(n % kLoopFrames);
        GstBuffer* buf = gst_buffer_copy(frames[size_t(k)].frames[i]);
        GST_BUFFER_PTS(buf) = pts;
        GST_BUFFER_DTS(buf) = GST_CLOCK_TIME_NONE;
        GST_BUFFER_DURATION(buf) = GST_SECOND / 30;
        GST_BUFFER_OFFSET(buf) = n;
        {
          std::lock_guard<std::mutex> g(notes.lock);
          notes.by_camera[k].push_back({pts, n, crcs[size_t(k)][i]});
        }
        gst_app_src_push_buffer(GST_APP_SRC(sources[size_t(k)]), buf);
      }
    }
    for (GstElement* src : sources) gst_app_src_end_of_stream(GST_APP_SRC(src));
    gst_object_unref(clock);
  });
  const std::string rec_error = run(recorder, 0, seconds);
  stop = true;
  feeder.join();
  for (GstElement* src : sources) gst_object_unref(src);
  gst_object_unref(recorder);
  if (!rec_error.empty()) {
    std::fprintf(stderr, "recording failed: %s\n", rec_error.c_str());
    return 1;
  }

  // The dataset's time origin is the earliest first frame of its cameras.
  GstClockTime origin = GST_CLOCK_TIME_NONE;
  for (auto& [k, frames] : notes.by_camera)
    if (!frames.empty()) origin = std::min(origin, frames.front().running_time);

  int failures = 0;
  std::printf("%-7s %9s %9s %12s %12s\n", "camera", "fed", "recorded", "depth-differ", "time-differ");
  for (int k = 0; k < cameras; ++k) {
    const std::vector<FrameNote>& sent = notes.by_camera[k];
    Notes played;
    ProbeContext ctx{&played, k};
    const std::string play = "rgbdfilesrc name=play location=" + folder + " camera-id=" + std::to_string(k) +
                             " ! fakesink sync=false";
    GstElement* player = gst_parse_launch(play.c_str(), nullptr);
    GstElement* src = gst_bin_get_by_name(GST_BIN(player), "play");
    GstPad* pad = gst_element_get_static_pad(src, "src");
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, note_frame, &ctx, nullptr);
    gst_object_unref(pad);
    gst_object_unref(src);
    const std::string play_error = run(player, 0);
    gst_object_unref(player);
    if (!play_error.empty()) {
      std::fprintf(stderr, "camera %d: playback failed: %s\n", k, play_error.c_str());
      ++failures;
      continue;
    }
    const std::vector<FrameNote>& got = played.by_camera[k];
    size_t depth_differ = 0, time_differ = 0;
    for (size_t i = 0; i < std::min(sent.size(), got.size()); ++i) {
      if (sent[i].depth_crc != got[i].depth_crc) ++depth_differ;
      if (sent[i].running_time - origin != got[i].running_time) ++time_differ;
    }
    std::printf("%-7d %9zu %9zu %12zu %12zu\n", k, sent.size(), got.size(), depth_differ, time_differ);
    if (got.size() != sent.size() || depth_differ || time_differ) ++failures;
  }
  std::sort(lateness.ms.begin(), lateness.ms.end());
  if (!lateness.ms.empty())
    std::printf("frame reaches the recording sink after: p50 %.1f ms, p99 %.1f ms, max %.1f ms\n",
                lateness.ms[lateness.ms.size() / 2], lateness.ms[lateness.ms.size() * 99 / 100], lateness.ms.back());
  std::printf("recording: %s\n", failures ? "FRAMES LOST OR CHANGED" : "every fed frame recorded, depth bit-exact, "
                                                                       "times kept");
  return failures ? 1 : 0;
}
