// Sound against picture at the lecturer's page (ITU-R BT.1359: sound at most 45 ms before its picture or
// 125 ms after it goes unnoticed). A server in this process (whepviewsink, the synthetic cameras live with
// a flash every 2 s: rgbdtestsrc flash-interval; the classroom's sound a tick every 2 s: audiotestsrc
// wave=ticks tick-interval) and one lecturer's page in headless Chromium (tests/browser/measure-sync.mjs), which times each
// flash as shown and each tick as played. Probes here see each flash's first frame leave its camera and each
// tick's first loud sample (at its timestamp: the tone keeps time); with the pipeline's clock (monotonic) and the page's (its time origin, the
// epoch) on one timeline, each clap gives the picture's latency and the sound's, source to page, and their
// difference is what the path did to sound against picture (the sources' own offset cancels). Prints per
// clap and the medians.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include <gio/gio.h>
#include <glib.h>
#include <gst/gst.h>

#include "browser_driver.h"
#include "flow_harness.h"
#include "free_port.h"
#include "tool_options.h"

using namespace vclassroom_tools;

namespace {

struct SourceClaps {
  std::mutex lock;
  std::vector<double> flashes_ms;  // when each flash's first frame left the camera (monotonic ms)
  std::vector<double> flash_pts_ms;  // and its timestamp (running time ms), which names its tick
  std::vector<double> ticks_ms;    // each tick's onset (running time ms: the test tone keeps time)
  double quiet_until_ms = -1e9;               // the last loud sample's time
  bool white = false;                         // the last camera frame was
};

double ms(GstClockTime t) { return double(t) / 1e6; }

// The first camera's frames: the first of each run of white colour planes (the first pixel is enough: the
// whole frame is white).
GstPadProbeReturn on_camera_frame(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* claps = static_cast<SourceClaps*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstMapInfo map;
  if (!buf || !GST_BUFFER_PTS_IS_VALID(buf) || !gst_buffer_map(buf, &map, GST_MAP_READ)) return GST_PAD_PROBE_OK;
  const bool white = map.size >= 3 && map.data[0] == 255 && map.data[1] == 255 && map.data[2] == 255;
  gst_buffer_unmap(buf, &map);
  // When the frame leaves the camera (the monotonic clock, the pipeline's): a synthetic camera that falls
  // behind its timestamps on a loaded machine must not count as the path's delay (a real camera delivers
  // each frame about one frame after its exposure).
  std::lock_guard<std::mutex> g(claps->lock);
  if (white && !claps->white) {
    claps->flashes_ms.push_back(double(g_get_monotonic_time()) / 1000.0);
    claps->flash_pts_ms.push_back(ms(GST_BUFFER_PTS(buf)));
  }
  claps->white = white;
  return GST_PAD_PROBE_OK;
}

// The tick's sound (S16LE mono from audioconvert): the first sample above a tenth of full scale after a
// second of quiet.
GstPadProbeReturn on_sound(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* claps = static_cast<SourceClaps*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstCaps* caps = gst_pad_get_current_caps(pad);
  int rate = 0;
  if (caps) gst_structure_get_int(gst_caps_get_structure(caps, 0), "rate", &rate);
  if (caps) gst_caps_unref(caps);
  GstMapInfo map;
  if (!buf || rate <= 0 || !GST_BUFFER_PTS_IS_VALID(buf) || !gst_buffer_map(buf, &map, GST_MAP_READ))
    return GST_PAD_PROBE_OK;
  const auto* s = reinterpret_cast<const int16_t*>(map.data);
  std::lock_guard<std::mutex> g(claps->lock);
  for (size_t i = 0; i < map.size / 2; ++i) {
    if (std::abs(int(s[i])) < 3277) continue;
    const double t = ms(GST_BUFFER_PTS(buf)) + 1000.0 * double(i) / rate;
    if (t - claps->quiet_until_ms > 1000) claps->ticks_ms.push_back(t);
    claps->quiet_until_ms = t;
  }
  gst_buffer_unmap(buf, &map);
  return GST_PAD_PROBE_OK;
}

// For each source event, the first page event after it and before the next source event: its latency (page
// minus source), or NaN when the page did not see it.
std::vector<double> latencies(const std::vector<double>& source, const std::vector<double>& page) {
  std::vector<double> out;
  for (size_t i = 0; i < source.size(); ++i) {
    const double next = i + 1 < source.size() ? source[i + 1] : source[i] + 1e9;
    double found = NAN;
    for (double t : page)
      if (t >= source[i] && t < next) {
        found = t - source[i];
        break;
      }
    out.push_back(found);
  }
  return out;
}

double median_of(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  return v.empty() ? NAN : percentile(v, 0.5);
}

}  // namespace

int main(int argc, char** argv) {
  gint seconds = 30, cameras = 1;
  g_autofree gchar* size_text = nullptr;
  const GOptionEntry entries[] = {
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "Measured window (default 30: about 15 claps)", "S"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "Synthetic cameras of the default rig, 1 to 3 (default 1)", "N"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size_text, "The lecturer's view (default 960x540)", "WxH"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "Sound against picture at a browser lecturer's page (whepviewsink; needs node, chromium and "
                     "tests/browser/node_modules).",
                     entries, gst_init_get_option_group());
  int width = 960, height = 540;
  if (size_text) parse_size_or_exit("--size", size_text, &width, &height);
  if (cameras < 1 || cameras > 3) usage_error("--cameras must be 1 to 3");
  if (seconds < 5 || seconds > 600) usage_error("--seconds must be 5 to 600");
  const std::string root = browser_driver_root("measure-sync.mjs");
  const int port = free_loopback_port(true);
  std::string launch = "whepviewsink name=w port=" + std::to_string(port) + " token=measure-token width=" +
                       std::to_string(width) + " height=" + std::to_string(height) + " web-root=" + root +
                       "/web/lecturer audiotestsrc is-live=true wave=ticks tick-interval=2000000000 volume=0.8 ! audioconvert ! "
                       "audio/x-raw,format=S16LE,channels=1 ! identity name=sound ! audioconvert ! opusenc ! w.audio";
  for (int k = 0; k < cameras; ++k)
    launch += " rgbdtestsrc name=cam" + std::to_string(k) + " camera-id=" + std::to_string(k) +
              " is-live=true flash-interval=2000000000 ! learnerseg ! queue max-size-buffers=1 leaky=downstream ! w.cam_" +
              std::to_string(k);
  GError* err = nullptr;
  GstElement* server = gst_parse_launch(launch.c_str(), &err);
  if (!server) {
    std::fprintf(stderr, "%s: %s\n", g_get_prgname(), err ? err->message : "cannot build the server");
    return 1;
  }
  SourceClaps claps;
  GstElement* cam = gst_bin_get_by_name(GST_BIN(server), "cam0");
  GstElement* sound_tap = gst_bin_get_by_name(GST_BIN(server), "sound");
  GstPad* cam_src = gst_element_get_static_pad(cam, "src");
  GstPad* sound_src = gst_element_get_static_pad(sound_tap, "src");
  gst_pad_add_probe(cam_src, GST_PAD_PROBE_TYPE_BUFFER, on_camera_frame, &claps, nullptr);
  gst_pad_add_probe(sound_src, GST_PAD_PROBE_TYPE_BUFFER, on_sound, &claps, nullptr);
  for (GstObject* o : {GST_OBJECT(cam_src), GST_OBJECT(sound_src), GST_OBJECT(cam), GST_OBJECT(sound_tap)}) gst_object_unref(o);
  // The pipeline's clock is the system's monotonic one (GstSystemClock's default, as GLib's): its time minus
  // this offset is the epoch, the page's timeline.
  const double epoch_minus_monotonic_ms = double(g_get_real_time() - g_get_monotonic_time()) / 1000.0;
  if (gst_element_set_state(server, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
    std::fprintf(stderr, "%s: the server did not start\n", g_get_prgname());
    return 1;
  }
  const std::string base = "http://127.0.0.1:" + std::to_string(port);
  GSubprocess* browser =
      start_browser_driver(root, "measure-sync.mjs", {base, "measure-token", std::to_string(seconds)});
  std::fprintf(stderr, "joining, then %d s measured\n", seconds);
  std::vector<double> page_flashes, page_clicks;
  long frames = -1, sound_packets = -1;
  GDataInputStream* out = g_data_input_stream_new(g_subprocess_get_stdout_pipe(browser));
  while (gchar* line = g_data_input_stream_read_line(out, nullptr, nullptr, nullptr)) {
    double t = 0;
    if (std::sscanf(line, "flash %lf", &t) == 1) page_flashes.push_back(t);
    else if (std::sscanf(line, "click %lf", &t) == 1) page_clicks.push_back(t);
    else std::sscanf(line, "frames %ld sound-packets %ld", &frames, &sound_packets);
    g_free(line);
  }
  g_object_unref(out);
  g_subprocess_wait(browser, nullptr, nullptr);
  const bool browser_ok = g_subprocess_get_if_exited(browser) && g_subprocess_get_exit_status(browser) == 0;
  g_object_unref(browser);
  if (!browser_ok || frames < 0) {
    std::fprintf(stderr, "%s: the browser did not finish\n", g_get_prgname());
    return 1;
  }
  const double base_ms = double(gst_element_get_base_time(server)) / 1e6 + epoch_minus_monotonic_ms;
  std::vector<double> flashes, ticks, flash_pts, tick_pts;
  {
    std::lock_guard<std::mutex> g(claps.lock);
    for (double t : claps.flashes_ms) flashes.push_back(t + epoch_minus_monotonic_ms);
    for (double t : claps.ticks_ms) ticks.push_back(base_ms + t);
    flash_pts = claps.flash_pts_ms;
    tick_pts = claps.ticks_ms;
  }
  gst_element_set_state(server, GST_STATE_NULL);
  gst_object_unref(server);
  // Only the claps of the page's window (its first event's time on), each flash with its tick.
  const double window_start = std::min(page_flashes.empty() ? 1e300 : page_flashes.front(),
                                       page_clicks.empty() ? 1e300 : page_clicks.front()) - 1000;
  std::vector<double> picture, sound, skew;
  const std::vector<double> picture_all = latencies(flashes, page_flashes), sound_all = latencies(ticks, page_clicks);
  for (size_t i = 0; i < flashes.size(); ++i) {
    if (flashes[i] < window_start) continue;
    double tick_latency = NAN;
    for (size_t j = 0; j < ticks.size(); ++j)
      if (std::abs(tick_pts[j] - flash_pts[i]) < 200) tick_latency = sound_all[j];
    picture.push_back(picture_all[i]);
    sound.push_back(tick_latency);
    skew.push_back(tick_latency - picture_all[i] + 0.0);
    std::printf("clap at %+.0f s: picture %.0f ms, sound %.0f ms after leaving their sources\n",
                (flashes[i] - flashes.front()) / 1000.0, picture_all[i], tick_latency);
  }
  const double p = median_of(picture), a = median_of(sound), d = median_of(skew);
  size_t both = 0;
  for (double x : skew) both += !std::isnan(x);
  std::printf("page: %zu claps, %zu seen and heard (%zu flashes and %zu ticks noticed), %ld frames shown, %ld sound "
              "packets in %d s\n", picture.size(), both, page_flashes.size(), page_clicks.size(), frames, sound_packets,
              seconds);
  if (both < 3) {
    std::fprintf(stderr, "%s: too few claps both seen and heard\n", g_get_prgname());
    return 1;
  }
  std::printf("latency (median): picture %.0f ms, sound %.0f ms\n", p, a);
  std::printf("sound against picture: %+.0f ms (median of %zu claps), positive: sound later; BT.1359 window "
              "-45 .. +125 ms: %s\n",
              d, both, d >= -45 && d <= 125 ? "met" : "not met");
  return 0;
}
