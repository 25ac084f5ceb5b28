// vclassroom-measure-link: one camera link at MTU 1400 over UDP on loopback with seeded packet loss, as
// pipelines/classroom.sh and server.sh run it, before (plain rtpgstpay) and after (NACK retransmission):
// frames delivered whole, link latency p50/p99 and bitrate on the wire, for each loss rate. The camera's
// coded frames (960x540, rgbdtestsrc ! rgbdenc) are recorded first and replayed at 30 fps.
//
// Latency: from the frame entering the payloader to its last packet leaving the jitter buffer into the
// depayloader (the frame complete), matched by RTP timestamp; both on this process's monotonic clock.
#include <gst/gst.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gio/gio.h>
#include <gst/app/gstappsrc.h>
#include <gst/rtp/gstrtpbuffer.h>

#include "free_port.h"
#include "tool_options.h"
#include "tool_support.h"

namespace {

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t i = s.find(from); i != std::string::npos; i = s.find(from, i + to.size())) s.replace(i, from.size(), to);
  return s;
}

struct Scheme {
  const char* name;
  std::string sender, sender_rtcp, receiver, receiver_rtcp;
};

// The same elements and settings as pipelines/classroom.sh and server.sh (RTX=1 and RTX=0).
const Scheme kSchemes[] = {
    {"before: plain rtpgstpay", "", "", "rtpjitterbuffer latency=50 drop-on-latency=true !", ""},
    {"after: NACK retransmission",
     "rtprtxsend payload-type-map=application/x-rtp-pt-map,96=(uint)97 max-size-time=500 max-size-packets=0 ! "
     "tx.send_rtp_sink tx.send_rtp_src !",
     "rtpsession name=tx rtp-profile=avpf udpsrc port={NACK_PORT} caps=application/x-rtcp ! "
     "senderfilter lock-ssrc=false allow=127.0.0.1 ! tx.recv_rtcp_sink",
     "senderfilter allow=127.0.0.1 ! rx.recv_rtp_sink rx.recv_rtp_src ! "
     "rtprtxreceive payload-type-map=application/x-rtp-pt-map,96=(uint)97 ! rtpssrcdemux ! "
     "rtpjitterbuffer latency=300 do-retransmission=true rtx-min-retry-timeout=40 drop-on-latency=true !",
     "rtpsession name=rx probation=0 rtp-profile=avpf rtcp-min-interval=10000000 bandwidth=20000000 "
     "rx.send_rtcp_src ! udpsink host=127.0.0.1 port={NACK_PORT} sync=false async=false"},
};

struct Probes {
  std::mutex lock;
  std::mt19937 rng;
  double loss = 0;
  guint64 wire_bytes = 0;
  std::map<guint32, gint64> sent_at;   // RTP timestamp -> when the frame entered the payloader
  std::vector<double> latency_ms;      // per frame completed at the depayloader
  guint32 last_marker_ts = 0;
  bool have_marker = false;
  GMutex done_lock;
  GCond done_cond;
  bool sender_done = false;
};

guint32 rtp_ts(GstBuffer* b) {
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  guint32 ts = 0;
  if (gst_rtp_buffer_map(b, GST_MAP_READ, &rtp)) {
    ts = gst_rtp_buffer_get_timestamp(&rtp);
    gst_rtp_buffer_unmap(&rtp);
  }
  return ts;
}

GstBuffer* first_buffer(GstPadProbeInfo* info) {
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) return GST_PAD_PROBE_INFO_BUFFER(info);
  GstBufferList* l = GST_PAD_PROBE_INFO_BUFFER_LIST(info);
  return gst_buffer_list_length(l) ? gst_buffer_list_get(l, 0) : nullptr;
}

// Payloader output: the frame's send time by RTP timestamp.
GstPadProbeReturn on_payloaded(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probes*>(data);
  if (GstBuffer* b = first_buffer(info)) {
    std::lock_guard<std::mutex> g(p->lock);
    p->sent_at.emplace(rtp_ts(b), g_get_monotonic_time());
  }
  return GST_PAD_PROBE_OK;
}

// Before udpsink: seeded loss, one decision per packet, and the bytes that reach the wire.
GstPadProbeReturn on_wire(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probes*>(data);
  std::lock_guard<std::mutex> g(p->lock);
  auto lose = [&] { return std::uniform_real_distribution<double>(0, 1)(p->rng) < p->loss; };
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
    if (lose()) return GST_PAD_PROBE_DROP;
    p->wire_bytes += gst_buffer_get_size(GST_PAD_PROBE_INFO_BUFFER(info)) + 28;  // + IPv4 and UDP headers
    return GST_PAD_PROBE_OK;
  }
  GstBufferList* list = gst_buffer_list_make_writable(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
  for (guint i = gst_buffer_list_length(list); i-- > 0;) {
    if (lose())
      gst_buffer_list_remove(list, i, 1);
    else
      p->wire_bytes += gst_buffer_get_size(gst_buffer_list_get(list, i)) + 28;
  }
  GST_PAD_PROBE_INFO_DATA(info) = list;
  return GST_PAD_PROBE_OK;
}

GstPadProbeReturn on_sender_eos(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probes*>(data);
  if (GST_EVENT_TYPE(GST_PAD_PROBE_INFO_EVENT(info)) == GST_EVENT_EOS) {
    g_mutex_lock(&p->done_lock);
    p->sender_done = true;
    g_cond_broadcast(&p->done_cond);
    g_mutex_unlock(&p->done_lock);
  }
  return GST_PAD_PROBE_OK;
}

// Depayloader input: remember the timestamp of the frame whose last packet (marker) is being handled.
GstPadProbeReturn on_depay_in(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probes*>(data);
  GstBuffer* b = GST_PAD_PROBE_INFO_BUFFER(info);
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (gst_rtp_buffer_map(b, GST_MAP_READ, &rtp)) {
    if (gst_rtp_buffer_get_marker(&rtp)) {
      std::lock_guard<std::mutex> g(p->lock);
      p->last_marker_ts = gst_rtp_buffer_get_timestamp(&rtp);
      p->have_marker = true;
    }
    gst_rtp_buffer_unmap(&rtp);
  }
  return GST_PAD_PROBE_OK;
}

// Depayloader output: a whole frame, pushed while its last packet is handled.
GstPadProbeReturn on_frame(GstPad*, GstPadProbeInfo*, gpointer data) {
  auto* p = static_cast<Probes*>(data);
  std::lock_guard<std::mutex> g(p->lock);
  if (!p->have_marker) return GST_PAD_PROBE_OK;
  auto it = p->sent_at.find(p->last_marker_ts);
  if (it != p->sent_at.end()) p->latency_ms.push_back((g_get_monotonic_time() - it->second) / 1000.0);
  return GST_PAD_PROBE_OK;
}

struct Row {
  size_t sent = 0, delivered = 0, frames_timed = 0;
  double p50 = 0, p99 = 0, mbit = 0;
  bool ok = true;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * (v.size() - 1) + 0.5))];
}

Row run(const Scheme& scheme, const vclassroom_tools::Recording& rec, double loss, size_t frames, guint32 seed) {
  Row row;
  const std::string rtp_port = std::to_string(vclassroom_tools::free_loopback_port(false)),
                    nack_port = std::to_string(vclassroom_tools::free_loopback_port(false));
  auto ports = [&](const std::string& s) { return replace_all(s, "{NACK_PORT}", nack_port); };
  const std::string tx_desc =
      ports(scheme.sender_rtcp + " appsrc name=src is-live=true format=time ! identity sync=true ! "
                                 "rtpgstpay name=pay config-interval=1 mtu=1400 pt=96 ! " +
            scheme.sender + " udpsink name=net host=127.0.0.1 port=" + rtp_port + " sync=false");
  const std::string rx_desc =
      ports(scheme.receiver_rtcp + " udpsrc port=" + rtp_port +
            " buffer-size=33554432 mtu=1500 caps=\"application/x-rtp,media=application,clock-rate=90000,"
            "encoding-name=X-GST,payload=96\" ! " +
            scheme.receiver + " rtpgstdepay name=depay ! rgbddec name=dec ! fakesink sync=false");
  GError* err = nullptr;
  GstElement* tx = gst_parse_launch(tx_desc.c_str(), &err);
  GstElement* rx = tx ? gst_parse_launch(rx_desc.c_str(), &err) : nullptr;
  if (!tx || !rx) {
    std::fprintf(stderr, "cannot build the link: %s\n", err ? err->message : "?");
    g_clear_error(&err);
    row.ok = false;
    return row;
  }
  Probes probes;
  probes.rng.seed(seed);
  probes.loss = loss;
  g_mutex_init(&probes.done_lock);
  g_cond_init(&probes.done_cond);
  auto probe = [](GstElement* bin, const char* element, const char* pad, GstPadProbeType type,
                  GstPadProbeCallback cb, Probes* p) {
    GstElement* e = gst_bin_get_by_name(GST_BIN(bin), element);
    GstPad* q = gst_element_get_static_pad(e, pad);
    gst_pad_add_probe(q, type, cb, p, nullptr);
    gst_object_unref(q);
    gst_object_unref(e);
  };
  const auto data = GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST);
  probe(tx, "pay", "src", data, on_payloaded, &probes);
  probe(tx, "net", "sink", data, on_wire, &probes);
  probe(tx, "net", "sink", GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM, on_sender_eos, &probes);
  probe(rx, "depay", "sink", GST_PAD_PROBE_TYPE_BUFFER, on_depay_in, &probes);
  probe(rx, "dec", "sink", GST_PAD_PROBE_TYPE_BUFFER, on_frame, &probes);

  GstElement* src = gst_bin_get_by_name(GST_BIN(tx), "src");
  g_object_set(src, "caps", rec.caps, "max-bytes", guint64(0), nullptr);
  for (size_t i = 0; i < frames; ++i) {
    GstBuffer* b = gst_buffer_copy(rec.frames[i % rec.frames.size()]);
    GST_BUFFER_PTS(b) = i * GST_SECOND / 30;
    GST_BUFFER_DTS(b) = GST_CLOCK_TIME_NONE;
    GST_BUFFER_DURATION(b) = GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(src), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  gst_object_unref(src);
  gst_element_set_state(rx, GST_STATE_PLAYING);
  gst_element_set_state(tx, GST_STATE_PLAYING);
  const gint64 started = g_get_monotonic_time();
  const gint64 deadline = started + gint64(frames / 30 + 60) * G_TIME_SPAN_SECOND;
  g_mutex_lock(&probes.done_lock);
  while (!probes.sender_done && g_cond_wait_until(&probes.done_cond, &probes.done_lock, deadline)) {
  }
  const bool done = probes.sender_done;
  g_mutex_unlock(&probes.done_lock);
  const double seconds = (g_get_monotonic_time() - started) / 1e6;
  if (!done) {
    std::fprintf(stderr, "the sender did not finish\n");
    row.ok = false;
  }
  // The receiver drains: end-of-stream to its sources, and the end of the stream at its sink.
  gst_element_send_event(rx, gst_event_new_eos());
  GstBus* bus = gst_element_get_bus(rx);
  GstMessage* m = gst_bus_timed_pop_filtered(bus, 30 * GST_SECOND, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
  if (m) gst_message_unref(m);
  gst_object_unref(bus);
  GstElement* dec = gst_bin_get_by_name(GST_BIN(rx), "dec");
  guint64 decoded = 0;
  g_object_get(dec, "frames", &decoded, nullptr);
  gst_object_unref(dec);
  gst_element_set_state(rx, GST_STATE_NULL);
  gst_element_set_state(tx, GST_STATE_NULL);
  gst_object_unref(tx);
  gst_object_unref(rx);
  row.sent = frames;
  row.delivered = decoded;
  row.frames_timed = probes.latency_ms.size();
  row.p50 = percentile(probes.latency_ms, 0.5);
  row.p99 = percentile(probes.latency_ms, 0.99);
  row.mbit = probes.wire_bytes * 8 / 1e6 / std::max(seconds, 1e-3);
  g_mutex_clear(&probes.done_lock);
  g_cond_clear(&probes.done_cond);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  gint seconds = 10, seed = 1;
  g_autofree gchar* losses_text = nullptr;
  const GOptionEntry entries[] = {
      {"seconds", 's', 0, G_OPTION_ARG_INT, &seconds, "Seconds of camera frames (30 fps) per run, default 10", "N"},
      {"loss", 'l', 0, G_OPTION_ARG_STRING, &losses_text, "Loss rates in percent, default 0,1,5,30", "LIST"},
      {"seed", 0, 0, G_OPTION_ARG_INT, &seed, "Seed of the packet dropper, default 1", "N"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  vclassroom_tools::parse_command_line(&argc, &argv, "", "One camera link at MTU 1400 under packet loss, before and after.",
                                       entries, gst_init_get_option_group());
  if (seconds < 1 || seconds > 600) vclassroom_tools::usage_error("--seconds must be 1 to 600");
  std::vector<double> losses;
  std::stringstream list(losses_text ? losses_text : "0,1,5,30");
  for (std::string item; std::getline(list, item, ',');) {
    char* end = nullptr;
    const double v = g_ascii_strtod(item.c_str(), &end);
    if (end == item.c_str() || *end != '\0' || v < 0 || v > 100)
      vclassroom_tools::usage_error("--loss: '" + item + "' is not a percentage");
    losses.push_back(v);
  }

  vclassroom_tools::Recording rec;
  std::fprintf(stderr, "recording 30 coded 960x540 camera frames...\n");
  if (!vclassroom_tools::record_stream("rgbdtestsrc camera-id=0 num-buffers=30 ground-truth=false ! rgbdenc", 30,
                                       &rec))
    return 1;
  const size_t frames = size_t(seconds) * 30;
  std::printf("| scheme | loss | frames delivered | latency p50 / p99 ms | Mbit/s on the wire |\n");
  std::printf("|---|---|---|---|---|\n");
  int status = 0;
  for (const Scheme& scheme : kSchemes)
    for (double loss : losses) {
      std::fprintf(stderr, "%s, %g %% loss, %d s...\n", scheme.name, loss, seconds);
      Row r = run(scheme, rec, loss / 100, frames, guint32(seed));
      if (!r.ok) status = 1;
      char latency[64] = "–";
      if (r.frames_timed > 0) std::snprintf(latency, sizeof latency, "%.1f / %.1f", r.p50, r.p99);
      std::printf("| %s | %g %% | %zu / %zu (%.0f %%) | %s | %.1f |\n", scheme.name, loss, r.delivered, r.sent,
                  100.0 * r.delivered / std::max<size_t>(r.sent, 1), latency, r.mbit);
      std::fflush(stdout);
    }
  return status;
}
