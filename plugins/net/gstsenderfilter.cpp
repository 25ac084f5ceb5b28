/**
 * SECTION:element-senderfilter
 * @title: senderfilter
 *
 * Put it right after udpsrc: passes RTP (or RTCP, with lock-ssrc=false) only from the allowed source
 * addresses, of the configured payload types and, with lock-ssrc, one SSRC per payload type; counts and
 * drops the rest (vclassroom-sender-stats messages, rate-limited warnings).
 *
 * ## Properties
 *
 * allow: IPv4 or IPv6 addresses, or host names resolved at start. payload-types: e.g. 96,97 for video and
 * its retransmissions; packets of other types are dropped and counted, never locked onto; leave it empty
 * for RTCP ports. ssrcs: e.g. 96=0x56430001, a camera's fixed SSRC (pipelines/classroom.sh SSRC); from the
 * first packet on, no other stream of that payload type passes, whatever lock-ssrc says.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 udpsrc port=5000 caps=application/x-rtp ! senderfilter allow=127.0.0.1,10.0.0.7 payload-types=96,97 ! fakesink
 * ]|
 */
// The decisions live in net/sender_filter.h; a packet's source address is udpsrc's GstNetAddressMeta.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsenderfilter.h"

#include <gst/net/gstnetaddressmeta.h>

#include <memory>
#include <mutex>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/net/sender_filter.h>
#include <gst/vclassroom/core/warning_limiter.h>

GST_DEBUG_CATEGORY_STATIC(sender_filter_debug);
#define GST_CAT_DEFAULT sender_filter_debug

using namespace vclassroom;

enum { PROP_0, PROP_ALLOW, PROP_LOCK_SSRC, PROP_TAKEOVER_MS, PROP_ACCEPTED, PROP_DROPPED, PROP_PAYLOAD_TYPES, PROP_SSRCS };

namespace {
struct FilterState {
  std::mutex lock;
  std::string allow;
  std::string payload_types;
  std::string ssrcs;
  bool lock_ssrc = true;
  guint takeover_ms = 1000;
  std::unique_ptr<SenderFilter> filter;
  WarningLimiter address_warnings, ssrc_warnings, malformed_warnings, payload_type_warnings;
};
}  // namespace

struct _GstSenderFilter {
  GstBaseTransform parent;
  FilterState* st;
};

G_DEFINE_TYPE(GstSenderFilter, gst_sender_filter, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(senderfilter, "senderfilter", GST_RANK_NONE, GST_TYPE_SENDER_FILTER)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-rtp; application/x-rtcp; application/x-srtp; application/x-srtcp"));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-rtp; application/x-rtcp; application/x-srtp; application/x-srtcp"));

static GstMessage* stats_message(GstSenderFilter* self, const SenderFilter& f) {
  return gst_message_new_element(
      GST_OBJECT(self),
      gst_structure_new("vclassroom-sender-stats", "accepted", G_TYPE_UINT64, guint64(f.accepted()),
                        "dropped-address", G_TYPE_UINT64, guint64(f.dropped_address()), "dropped-ssrc",
                        G_TYPE_UINT64, guint64(f.dropped_ssrc()), "dropped-malformed", G_TYPE_UINT64,
                        guint64(f.dropped_not_rtp()), "dropped-payload-type", G_TYPE_UINT64,
                        guint64(f.dropped_payload_type()), nullptr));
}

static gboolean gst_sender_filter_start(GstBaseTransform* trans) {
  GstSenderFilter* self = GST_SENDER_FILTER(trans);
  FilterState* st = self->st;
  std::lock_guard<std::mutex> g(st->lock);
  try {
    st->filter = std::make_unique<SenderFilter>(parse_allowed_senders(st->allow), st->lock_ssrc,
                                                gint64(st->takeover_ms) * GST_MSECOND);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("senderfilter allow=\"%s\": %s", st->allow.c_str(), e.what()),
                      (nullptr));
    return FALSE;
  }
  try {
    st->filter->set_payload_types(parse_payload_types(st->payload_types));
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS,
                      ("senderfilter payload-types=\"%s\": %s", st->payload_types.c_str(), e.what()), (nullptr));
    st->filter.reset();
    return FALSE;
  }
  try {
    st->filter->set_fixed_ssrcs(parse_fixed_ssrcs(st->ssrcs));
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("senderfilter ssrcs=\"%s\": %s", st->ssrcs.c_str(), e.what()),
                      (nullptr));
    st->filter.reset();
    return FALSE;
  }
  st->payload_type_warnings.reset();
  st->address_warnings.reset();
  st->ssrc_warnings.reset();
  st->malformed_warnings.reset();
  return TRUE;
}

static GstFlowReturn gst_sender_filter_transform_ip(GstBaseTransform* trans, GstBuffer* buf) {
  GstSenderFilter* self = GST_SENDER_FILTER(trans);
  FilterState* st = self->st;
  NetAddress source{};
  bool have_source = false;
  std::string source_text = "an unknown address";
  if (GstNetAddressMeta* meta = gst_buffer_get_net_address_meta(buf)) {
    if (G_IS_INET_SOCKET_ADDRESS(meta->addr)) {
      GInetAddress* ia = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(meta->addr));
      const gsize n = g_inet_address_get_native_size(ia);
      const guint8* bytes = g_inet_address_to_bytes(ia);
      if (n == 4) {
        source[10] = source[11] = 0xff;
        std::copy(bytes, bytes + 4, source.begin() + 12);
        have_source = true;
      } else if (n == 16) {
        std::copy(bytes, bytes + 16, source.begin());
        have_source = true;
      }
      if (have_source) source_text = address_to_string(source);
    }
  }
  GstMapInfo map;
  if (!gst_buffer_map(buf, &map, GST_MAP_READ)) return GST_BASE_TRANSFORM_FLOW_DROPPED;
  const gint64 now = g_get_monotonic_time() * 1000;
  std::string warning;
  GstMessage* stats = nullptr;
  SenderFilter::Verdict verdict;
  {
    std::lock_guard<std::mutex> g(st->lock);
    if (!st->filter) {
      gst_buffer_unmap(buf, &map);
      return GST_FLOW_FLUSHING;
    }
    verdict = st->filter->check(have_source ? &source : nullptr, map.data, map.size, now);
    WarningLimiter* limiter = nullptr;
    const char *one = "", *many = "";
    switch (verdict) {
      case SenderFilter::Verdict::kAccept:
        break;
      case SenderFilter::Verdict::kForeignAddress:
        limiter = &st->address_warnings;
        one = "a packet dropped from a sender not allowed";
        many = "packets dropped from senders not allowed";
        break;
      case SenderFilter::Verdict::kForeignPayloadType:
        limiter = &st->payload_type_warnings;
        one = "a packet dropped of a payload type this port does not carry";
        many = "packets dropped of payload types this port does not carry";
        break;
      case SenderFilter::Verdict::kForeignSsrc:
        limiter = &st->ssrc_warnings;
        one = "a packet dropped as a second RTP stream (another SSRC)";
        many = "packets dropped as a second RTP stream (another SSRC)";
        break;
      case SenderFilter::Verdict::kNotRtp:
        limiter = &st->malformed_warnings;
        one = "a packet dropped as not RTP";
        many = "packets dropped as not RTP";
        break;
    }
    uint64_t count = 0;
    int64_t span = 0;
    if (limiter && limiter->note(now, &count, &span)) {
      warning = std::string(GST_OBJECT_NAME(self)) + ": " + describe_occurrences(count, one, many, "", span) +
                " (the latest from " + source_text + "; allowed: " +
                (st->allow.empty() ? std::string("any") : st->allow) + ")";
      stats = stats_message(self, *st->filter);
    }
  }
  gst_buffer_unmap(buf, &map);
  if (!warning.empty()) {
    GST_ELEMENT_WARNING(self, STREAM, FAILED, ("%s", warning.c_str()), (nullptr));
    gst_element_post_message(GST_ELEMENT(self), stats);
  }
  return verdict == SenderFilter::Verdict::kAccept ? GST_FLOW_OK : GST_BASE_TRANSFORM_FLOW_DROPPED;
}

// The counts at the end of the stream, so a run's totals are on the bus.
static gboolean gst_sender_filter_sink_event(GstBaseTransform* trans, GstEvent* event) {
  GstSenderFilter* self = GST_SENDER_FILTER(trans);
  if (GST_EVENT_TYPE(event) == GST_EVENT_EOS) {
    GstMessage* stats = nullptr;
    {
      std::lock_guard<std::mutex> g(self->st->lock);
      if (self->st->filter) stats = stats_message(self, *self->st->filter);
    }
    if (stats) gst_element_post_message(GST_ELEMENT(self), stats);
  }
  return GST_BASE_TRANSFORM_CLASS(gst_sender_filter_parent_class)->sink_event(trans, event);
}

static gboolean gst_sender_filter_stop(GstBaseTransform* trans) {
  FilterState* st = GST_SENDER_FILTER(trans)->st;
  std::lock_guard<std::mutex> g(st->lock);
  st->filter.reset();
  return TRUE;
}

static void gst_sender_filter_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  FilterState* st = GST_SENDER_FILTER(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_ALLOW: {
      const gchar* s = g_value_get_string(value);
      st->allow = s ? s : "";
      break;
    }
    case PROP_LOCK_SSRC: st->lock_ssrc = g_value_get_boolean(value); break;
    case PROP_TAKEOVER_MS: st->takeover_ms = g_value_get_uint(value); break;
    case PROP_PAYLOAD_TYPES: {
      const gchar* s = g_value_get_string(value);
      st->payload_types = s ? s : "";
      break;
    }
    case PROP_SSRCS: {
      const gchar* s = g_value_get_string(value);
      st->ssrcs = s ? s : "";
      break;
    }
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_sender_filter_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  FilterState* st = GST_SENDER_FILTER(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_ALLOW: g_value_set_string(value, st->allow.c_str()); break;
    case PROP_LOCK_SSRC: g_value_set_boolean(value, st->lock_ssrc); break;
    case PROP_TAKEOVER_MS: g_value_set_uint(value, st->takeover_ms); break;
    case PROP_PAYLOAD_TYPES: g_value_set_string(value, st->payload_types.c_str()); break;
    case PROP_SSRCS: g_value_set_string(value, st->ssrcs.c_str()); break;
    case PROP_ACCEPTED: g_value_set_uint64(value, st->filter ? st->filter->accepted() : 0); break;
    case PROP_DROPPED:
      g_value_set_uint64(value, st->filter ? st->filter->dropped_address() + st->filter->dropped_ssrc() +
                                                 st->filter->dropped_not_rtp() + st->filter->dropped_payload_type()
                                           : 0);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_sender_filter_finalize(GObject* object) {
  delete GST_SENDER_FILTER(object)->st;
  G_OBJECT_CLASS(gst_sender_filter_parent_class)->finalize(object);
}

static void gst_sender_filter_class_init(GstSenderFilterClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_sender_filter_set_property;
  gobject_class->get_property = gst_sender_filter_get_property;
  gobject_class->finalize = gst_sender_filter_finalize;
  trans_class->start = GST_DEBUG_FUNCPTR(gst_sender_filter_start);
  trans_class->stop = GST_DEBUG_FUNCPTR(gst_sender_filter_stop);
  trans_class->transform_ip = GST_DEBUG_FUNCPTR(gst_sender_filter_transform_ip);
  trans_class->sink_event = GST_DEBUG_FUNCPTR(gst_sender_filter_sink_event);
  trans_class->passthrough_on_same_caps = FALSE;
  const auto rw = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto ro = GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  g_object_class_install_property(
      gobject_class, PROP_ALLOW,
      g_param_spec_string("allow", "Allowed senders",
                          "Comma-separated source addresses or host names accepted (empty = any)",
                          "", rw));
  g_object_class_install_property(
      gobject_class, PROP_LOCK_SSRC,
      g_param_spec_boolean("lock-ssrc", "Lock SSRC",
                           "Keep the first RTP stream (SSRC) of each payload type and drop others", TRUE, rw));
  g_object_class_install_property(
      gobject_class, PROP_TAKEOVER_MS,
      g_param_spec_uint("takeover-ms", "Takeover time",
                        "A kept SSRC silent this long gives way to a new one (a restarted sender)", 1, 600000,
                        1000, rw));
  g_object_class_install_property(
      gobject_class, PROP_PAYLOAD_TYPES,
      g_param_spec_string("payload-types", "Payload types",
                          "Comma-separated RTP payload types the port carries (empty = any)",
                          "", rw));
  g_object_class_install_property(
      gobject_class, PROP_SSRCS,
      g_param_spec_string("ssrcs", "Fixed SSRCs",
                          "Comma-separated PT=SSRC pairs, the only SSRC each payload type may carry (empty = none fixed)",
                          "", rw));
  g_object_class_install_property(gobject_class, PROP_ACCEPTED,
                                  g_param_spec_uint64("accepted", "Accepted", "Packets passed on since the element started", 0, G_MAXUINT64,
                                                      0, ro));
  g_object_class_install_property(gobject_class, PROP_DROPPED,
                                  g_param_spec_uint64("dropped", "Dropped",
                                                      "Packets dropped (foreign address, payload type not carried, "
                                                      "second SSRC, not RTP)",
                                                      0,
                                                      G_MAXUINT64, 0, ro));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RTP sender filter", "Network/Filter",
      "Passes RTP only from the configured senders", "gst-vclassroom developers");
  GST_DEBUG_CATEGORY_INIT(sender_filter_debug, "senderfilter", 0, "RTP sender filter");
}

static void gst_sender_filter_init(GstSenderFilter* self) {
  self->st = new FilterState();
  gst_base_transform_set_in_place(GST_BASE_TRANSFORM(self), TRUE);
}
