// How much of the lecturer's voice, played on the classroom's loudspeaker, the classroom's microphone still
// sends back to the lecturer, with and without the echo canceller server.sh puts on the microphone
// (webrtcdsp with a webrtcechoprobe on the loudspeaker; CLASSROOM_SOUND with CLASSROOM_SPEAKER). A room
// stand-in: the voice (pink noise, or a sine) reaches the microphone --delay ms later and --gain weaker,
// beside a quiet class; the energy of what leaves the microphone's chain is compared over the last
// --seconds, after the canceller had time to adapt. Prints the echo's level with the canceller off and on,
// and the difference (the echo return loss enhancement).
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>

#include <glib.h>
#include <gst/gst.h>

#include "tool_options.h"

using namespace vclassroom_tools;

namespace {

struct Energy {
  std::mutex lock;
  double sum = 0;
  long samples = 0;
  GstClockTime from = 0;  // running time from which samples count
};

GstPadProbeReturn on_out(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* e = static_cast<Energy*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstMapInfo map;
  if (!buf || !GST_BUFFER_PTS_IS_VALID(buf) || GST_BUFFER_PTS(buf) < e->from || !gst_buffer_map(buf, &map, GST_MAP_READ))
    return GST_PAD_PROBE_OK;
  const auto* s = reinterpret_cast<const int16_t*>(map.data);
  double sum = 0;
  for (size_t i = 0; i < map.size / 2; ++i) sum += double(s[i]) * s[i];
  gst_buffer_unmap(buf, &map);
  std::lock_guard<std::mutex> g(e->lock);
  e->sum += sum;
  e->samples += long(map.size / 2);
  return GST_PAD_PROBE_OK;
}

// One run: the mean power (dB full scale) of what leaves the microphone's chain.
double run(bool cancel, const std::string& dsp_settings, const std::string& voice, int delay_ms, double gain,
           int adapt_s, int seconds) {
  const std::string format = "audio/x-raw,format=S16LE,rate=48000,channels=1";
  const std::string desc =
      "audiotestsrc is-live=true " + voice + " ! " + format + " ! tee name=voice "
      // The loudspeaker, heard by the probe.
      "voice. ! queue ! webrtcechoprobe name=classroom_echo ! fakesink sync=true "
      // The room: the voice reaches the microphone later and weaker, beside a quiet class.
      "voice. ! queue ! identity ts-offset=" + std::to_string(int64_t(delay_ms) * 1000000) + " ! volume volume=" +
      std::to_string(gain) + " ! mix. "
      "audiotestsrc is-live=true wave=silence ! " + format + " ! mix. "
      "audiomixer name=mix ! " + format + " ! webrtcdsp probe=classroom_echo echo-cancel=" + (cancel ? "true" : "false") +
      " " + dsp_settings + " ! identity name=out ! fakesink sync=true";
  GError* err = nullptr;
  GstElement* pipe = gst_parse_launch(desc.c_str(), &err);
  if (!pipe) {
    std::fprintf(stderr, "%s: %s\n", g_get_prgname(), err ? err->message : "cannot build the room");
    std::exit(1);
  }
  Energy energy;
  energy.from = GstClockTime(adapt_s) * GST_SECOND;
  GstElement* out = gst_bin_get_by_name(GST_BIN(pipe), "out");
  GstPad* pad = gst_element_get_static_pad(out, "src");
  gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, on_out, &energy, nullptr);
  gst_object_unref(pad);
  gst_object_unref(out);
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(pipe);
  GstMessage* m = gst_bus_timed_pop_filtered(bus, GstClockTime(adapt_s + seconds) * GST_SECOND, GST_MESSAGE_ERROR);
  if (m) {
    GError* e = nullptr;
    gst_message_parse_error(m, &e, nullptr);
    std::fprintf(stderr, "%s: %s\n", g_get_prgname(), e ? e->message : "error");
    std::exit(1);
  }
  gst_object_unref(bus);
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(pipe);
  std::lock_guard<std::mutex> g(energy.lock);
  if (energy.samples == 0) {
    std::fprintf(stderr, "%s: nothing left the microphone's chain\n", g_get_prgname());
    std::exit(1);
  }
  const double power = energy.sum / double(energy.samples) / (32768.0 * 32768.0);
  return 10 * std::log10(std::max(power, 1e-12));
}

}  // namespace

int main(int argc, char** argv) {
  gint seconds = 10, adapt = 5, delay_ms = 40;
  gdouble gain = 0.5;
  g_autofree gchar* voice_text = nullptr;
  g_autofree gchar* dsp_text = nullptr;
  const GOptionEntry entries[] = {
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "Measured window per run (default 10)", "S"},
      {"adapt", 0, 0, G_OPTION_ARG_INT, &adapt, "Seconds the canceller adapts before the window (default 5)", "S"},
      {"delay", 0, 0, G_OPTION_ARG_INT, &delay_ms, "Loudspeaker to microphone, ms (default 40)", "MS"},
      {"gain", 0, 0, G_OPTION_ARG_DOUBLE, &gain, "The echo's strength at the microphone, 0..1 (default 0.5)", "G"},
      {"voice", 0, 0, G_OPTION_ARG_STRING, &voice_text, "The lecturer's voice: pink-noise (default) or sine", "W"},
      {"dsp", 0, 0, G_OPTION_ARG_STRING, &dsp_text,
       "webrtcdsp's settings for both runs, in place of server.sh's (the default, \"delay-agnostic=true "
       "extended-filter=true\"); e.g. those and \"noise-suppression=false gain-control=false\" for the canceller "
       "alone",
       "SETTINGS"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "The lecturer's voice sent back from the classroom's microphone, with and without the echo "
                     "canceller (webrtcdsp and webrtcechoprobe, as server.sh chains them); runs in real time.",
                     entries, gst_init_get_option_group());
  if (seconds < 2 || seconds > 600 || adapt < 0 || adapt > 60) usage_error("--seconds 2..600, --adapt 0..60");
  if (delay_ms < 0 || delay_ms > 500) usage_error("--delay must be 0 to 500 ms");
  if (!(gain > 0 && gain <= 1)) usage_error("--gain must be above 0 and at most 1");
  const std::string wave = voice_text ? voice_text : "pink-noise";
  if (wave != "pink-noise" && wave != "sine") usage_error("--voice is pink-noise or sine");
  const std::string voice = "wave=" + wave + " volume=0.3";
  const std::string dsp = dsp_text ? dsp_text : "delay-agnostic=true extended-filter=true";
  const double off = run(false, dsp, voice, delay_ms, gain, adapt, seconds);
  const double on = run(true, dsp, voice, delay_ms, gain, adapt, seconds);
  std::printf("echo (the lecturer's voice %s, %d ms and x%.2f from loudspeaker to microphone), what leaves the "
              "microphone's chain over %d s after %d s: canceller off %.1f dBFS, on %.1f dBFS: %.1f dB weaker\n",
              wave.c_str(), delay_ms, gain, seconds, adapt, off, on, off - on);
  return 0;
}
