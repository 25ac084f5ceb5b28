/**
 * SECTION:element-rtphdrextplayoutdelay
 * @title: rtphdrextplayoutdelay
 *
 * Tells a WebRTC receiver how long it may buffer each frame (webrtc.org playout-delay); a payloader adds it
 * where downstream caps name its URI, on every packet, so a browser joining at any frame learns the delay
 * at once.
 *
 * ## Properties
 *
 * Both delays go in 10 ms steps. max-delay 0 with min-delay 0 asks the receiver to show each frame as soon
 * as it is decoded.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=30 ! x264enc ! rtph264pay ! 'application/x-rtp,extmap-5=(string)http://www.webrtc.org/experiments/rtp-hdrext/playout-delay' ! fakesink
 * ]|
 */
// The bytes are the library's (webrtc/playout_delay.h).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrtphdrextplayoutdelay.h"

#include <atomic>
#include <new>

#include <gst/vclassroom/webrtc/playout_delay.h>

using namespace vclassroom;

GST_DEBUG_CATEGORY_STATIC(playout_delay_debug);
#define GST_CAT_DEFAULT playout_delay_debug

struct GstRtpHdrExtPlayoutDelay {
  GstRTPHeaderExtension parent;
  std::atomic<int> min_ms, max_ms;  // written by the application, read by the payloader's thread
};
struct GstRtpHdrExtPlayoutDelayClass {
  GstRTPHeaderExtensionClass parent_class;
};

G_DEFINE_TYPE(GstRtpHdrExtPlayoutDelay, gst_rtp_hdrext_playout_delay, GST_TYPE_RTP_HEADER_EXTENSION)
GST_ELEMENT_REGISTER_DEFINE(rtphdrextplayoutdelay, "rtphdrextplayoutdelay", GST_RANK_MARGINAL, GST_TYPE_RTP_HDREXT_PLAYOUT_DELAY)
#define GST_RTP_HDREXT_PLAYOUT_DELAY(o) ((GstRtpHdrExtPlayoutDelay*)(o))

enum { PROP_0, PROP_MIN_DELAY, PROP_MAX_DELAY };

static GstRTPHeaderExtensionFlags get_supported_flags(GstRTPHeaderExtension*) {
  return GstRTPHeaderExtensionFlags(GST_RTP_HEADER_EXTENSION_ONE_BYTE | GST_RTP_HEADER_EXTENSION_TWO_BYTE);
}

static gsize get_max_size(GstRTPHeaderExtension*, const GstBuffer*) { return kPlayoutDelayBytes; }

static gssize write(GstRTPHeaderExtension* ext, const GstBuffer*, GstRTPHeaderExtensionFlags, GstBuffer*,
                    guint8* data, gsize size) {
  if (size < kPlayoutDelayBytes) return -1;
  GstRtpHdrExtPlayoutDelay* self = GST_RTP_HDREXT_PLAYOUT_DELAY(ext);
  write_playout_delay(PlayoutDelay{self->min_ms.load(), self->max_ms.load()}, data);
  GST_TRACE_OBJECT(ext, "wrote %02x %02x %02x", data[0], data[1], data[2]);
  return kPlayoutDelayBytes;
}

static gboolean read(GstRTPHeaderExtension* ext, GstRTPHeaderExtensionFlags, const guint8* data, gsize size,
                     GstBuffer*) {
  PlayoutDelay delay;
  if (!read_playout_delay(data, size, &delay)) {
    GST_WARNING_OBJECT(ext, "a malformed playout delay (%" G_GSIZE_FORMAT " bytes) ignored", size);
    return TRUE;  // a peer's bad extension must not fail the packet
  }
  GST_LOG_OBJECT(ext, "playout delay %d..%d ms", delay.min_ms, delay.max_ms);
  return TRUE;
}

static void set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  GstRtpHdrExtPlayoutDelay* self = GST_RTP_HDREXT_PLAYOUT_DELAY(object);
  switch (id) {
    case PROP_MIN_DELAY: self->min_ms = g_value_get_int(value); break;
    case PROP_MAX_DELAY: self->max_ms = g_value_get_int(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  GstRtpHdrExtPlayoutDelay* self = GST_RTP_HDREXT_PLAYOUT_DELAY(object);
  switch (id) {
    case PROP_MIN_DELAY: g_value_set_int(value, self->min_ms); break;
    case PROP_MAX_DELAY: g_value_set_int(value, self->max_ms); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_rtp_hdrext_playout_delay_init(GstRtpHdrExtPlayoutDelay* self) {
  new (&self->min_ms) std::atomic<int>(0);
  new (&self->max_ms) std::atomic<int>(0);
}

static void gst_rtp_hdrext_playout_delay_class_init(GstRtpHdrExtPlayoutDelayClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstRTPHeaderExtensionClass* ext_class = GST_RTP_HEADER_EXTENSION_CLASS(klass);
  GST_DEBUG_CATEGORY_INIT(playout_delay_debug, "rtphdrextplayoutdelay", 0, "Playout-delay RTP header extension");
  gobject_class->set_property = set_property;
  gobject_class->get_property = get_property;
  const GParamFlags rw = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(gobject_class, PROP_MIN_DELAY,
      g_param_spec_int("min-delay", "Minimum delay", "The least the receiver should buffer a frame, in ms (10 ms steps)",
                       0, kPlayoutDelayMaxMs, 0, rw));
  g_object_class_install_property(gobject_class, PROP_MAX_DELAY,
      g_param_spec_int("max-delay", "Maximum delay",
                       "The most the receiver may buffer a frame, in ms (10 ms steps)", 0, kPlayoutDelayMaxMs, 0, rw));
  ext_class->get_supported_flags = get_supported_flags;
  ext_class->get_max_size = get_max_size;
  ext_class->write = write;
  ext_class->read = read;
  gst_rtp_header_extension_class_set_uri(ext_class, kPlayoutDelayUri);
  gst_element_class_set_static_metadata(element_class, "Playout-delay RTP header extension", GST_RTP_HDREXT_ELEMENT_CLASS,
      "Tells a WebRTC receiver how long it may buffer each frame", "gst-vclassroom");
}
