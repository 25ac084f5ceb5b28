// What the measuring tools share: a stream recorded into memory before the
// clock starts (so the source costs nothing while they measure), and a
// scratch folder.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/gst.h>

namespace vclassroom_tools {

struct Recording {
  GstCaps* caps = nullptr;
  std::vector<GstBuffer*> frames;

  Recording() = default;
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;
  Recording(Recording&& o) noexcept : caps(o.caps), frames(std::move(o.frames)) { o.caps = nullptr; }
  ~Recording() {
    for (GstBuffer* b : frames) gst_buffer_unref(b);
    if (caps) gst_caps_unref(caps);
  }
};

// Runs `source` (a gst-launch description that ends in the stream to keep)
// into an appsink and keeps every buffer and the caps. False, with a message
// on stderr, when the pipeline cannot be built or gives fewer than `count`
// buffers.
inline bool record_stream(const std::string& source, int count, Recording* rec) {
  const std::string desc = source + " ! appsink name=out sync=false";
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {
    std::fprintf(stderr, "cannot build the recording pipeline '%s': %s\n", desc.c_str(), err ? err->message : "?");
    g_clear_error(&err);
    if (p) gst_object_unref(p);
    return false;
  }
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  GstBus* bus = gst_element_get_bus(p);
  gst_element_set_state(p, GST_STATE_PLAYING);
  // Until the end of the stream, or an error (which would leave the sink waiting for ever).
  bool failed = false;
  while (!failed) {
    if (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 100 * GST_MSECOND)) {
      if (!rec->caps) rec->caps = gst_caps_copy(gst_sample_get_caps(s));
      rec->frames.push_back(gst_buffer_ref(gst_sample_get_buffer(s)));
      gst_sample_unref(s);
      continue;
    }
    if (gst_app_sink_is_eos(GST_APP_SINK(sink))) break;
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      std::fprintf(stderr, "recording '%s' failed in %s: %s\n", source.c_str(), GST_OBJECT_NAME(m->src),
                   e ? e->message : "?");
      g_clear_error(&e);
      gst_message_unref(m);
      failed = true;
    }
  }
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(sink);
  gst_object_unref(p);
  if (failed) return false;
  if (static_cast<int>(rec->frames.size()) < count) {
    std::fprintf(stderr, "'%s' gave %zu buffers, expected %d\n", source.c_str(), rec->frames.size(), count);
    return false;
  }
  return true;
}

// A new folder in the system's temporary folder ($TMPDIR), named
// <prefix>-XXXXXX; "" when it cannot be made.
inline std::string make_temp_dir(const std::string& prefix) {
  std::string path = std::string(g_get_tmp_dir()) + "/" + prefix + "-XXXXXX";
  std::vector<char> buf(path.begin(), path.end());
  buf.push_back('\0');
  return g_mkdtemp(buf.data()) ? std::string(buf.data()) : std::string();
}

}  // namespace vclassroom_tools
