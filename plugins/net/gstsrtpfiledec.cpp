/**
 * SECTION:element-srtpfiledec
 * @title: srtpfiledec
 *
 * srtpdec whose every stream (SSRC) gets the key from key-file; packets failing authentication (another
 * key, tampering) are dropped. srtpdec asks for each new SSRC's key through its request-key signal, which a
 * gst-launch-1.0 line cannot answer, and a camera link has two SSRCs (the camera's and its
 * retransmissions'): this bin answers every one with the same key, AES_CM_128_HMAC_SHA1_80. The key: 30
 * bytes, made with head -c 30 /dev/urandom > srtp.key and given to both ends.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 udpsrc port=5000 caps="application/x-srtp,media=application,clock-rate=90000,encoding-name=X-GST,payload=96" ! srtpfiledec key-file=srtp.key ! rtpgstdepay ! fakesink
 * ]|
 */
// The key file: net/srtp_key.h.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsrtpfiledec.h"

#include <mutex>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/net/srtp_key.h>

GST_DEBUG_CATEGORY_STATIC(srtp_file_dec_debug);
#define GST_CAT_DEFAULT srtp_file_dec_debug

enum { PROP_0, PROP_KEY_FILE };

namespace {
struct KeyState {
  std::mutex lock;
  std::string key_file;
  GstBuffer* key = nullptr;
};
}  // namespace

struct _GstSrtpFileDec {
  GstBin parent;
  GstElement* dec;
  KeyState* st;
};

G_DEFINE_TYPE(GstSrtpFileDec, gst_srtp_file_dec, GST_TYPE_BIN)
GST_ELEMENT_REGISTER_DEFINE(srtpfiledec, "srtpfiledec", GST_RANK_NONE, GST_TYPE_SRTP_FILE_DEC)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-srtp; application/x-rtp"));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-rtp"));

static GstCaps* on_request_key(GstElement*, guint ssrc, gpointer data) {
  KeyState* st = static_cast<KeyState*>(data);
  std::lock_guard<std::mutex> g(st->lock);
  if (!st->key) return nullptr;
  return gst_caps_new_simple("application/x-srtp", "ssrc", G_TYPE_UINT, ssrc, "srtp-key", GST_TYPE_BUFFER, st->key,
                             "srtp-cipher", G_TYPE_STRING, "aes-128-icm", "srtp-auth", G_TYPE_STRING,
                             "hmac-sha1-80", "srtcp-cipher", G_TYPE_STRING, "aes-128-icm", "srtcp-auth",
                             G_TYPE_STRING, "hmac-sha1-80", nullptr);
}

static GstStateChangeReturn gst_srtp_file_dec_change_state(GstElement* element, GstStateChange transition) {
  GstSrtpFileDec* self = GST_SRTP_FILE_DEC(element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    KeyState* st = self->st;
    std::string path;
    {
      std::lock_guard<std::mutex> g(st->lock);
      path = st->key_file;
    }
    try {
      const std::vector<uint8_t> key = vclassroom::read_srtp_key(path);
      std::lock_guard<std::mutex> g(st->lock);
      if (st->key) gst_buffer_unref(st->key);
      st->key = gst_buffer_new_memdup(key.data(), key.size());
    } catch (const vclassroom::Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), (nullptr));
      return GST_STATE_CHANGE_FAILURE;
    }
  }
  return GST_ELEMENT_CLASS(gst_srtp_file_dec_parent_class)->change_state(element, transition);
}

static void gst_srtp_file_dec_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  KeyState* st = GST_SRTP_FILE_DEC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  if (prop_id == PROP_KEY_FILE) {
    const gchar* s = g_value_get_string(value);
    st->key_file = s ? s : "";
  } else {
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_srtp_file_dec_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  KeyState* st = GST_SRTP_FILE_DEC(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  if (prop_id == PROP_KEY_FILE)
    g_value_set_string(value, st->key_file.c_str());
  else
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
}

static void gst_srtp_file_dec_finalize(GObject* object) {
  KeyState* st = GST_SRTP_FILE_DEC(object)->st;
  if (st->key) gst_buffer_unref(st->key);
  delete st;
  G_OBJECT_CLASS(gst_srtp_file_dec_parent_class)->finalize(object);
}

static void gst_srtp_file_dec_class_init(GstSrtpFileDecClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->set_property = gst_srtp_file_dec_set_property;
  gobject_class->get_property = gst_srtp_file_dec_get_property;
  gobject_class->finalize = gst_srtp_file_dec_finalize;
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_srtp_file_dec_change_state);
  g_object_class_install_property(
      gobject_class, PROP_KEY_FILE,
      g_param_spec_string("key-file", "Key file",
                          "File holding the 30-byte SRTP master key (AES_CM_128_HMAC_SHA1_80) of every stream", "",
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "SRTP decoder with a key file", "Filter/Network/SRTP",
      "Decrypts SRTP with the key of every stream from a key file", "gst-vclassroom developers");
  GST_DEBUG_CATEGORY_INIT(srtp_file_dec_debug, "srtpfiledec", 0, "SRTP decoder with a key file");
}

static void gst_srtp_file_dec_init(GstSrtpFileDec* self) {
  self->st = new KeyState();
  self->dec = gst_element_factory_make("srtpdec", "dec");
  GstPad* sink = gst_ghost_pad_new_no_target_from_template("sink", gst_static_pad_template_get(&sink_template));
  GstPad* src = gst_ghost_pad_new_no_target_from_template("src", gst_static_pad_template_get(&src_template));
  if (self->dec) {
    gst_bin_add(GST_BIN(self), self->dec);
    g_signal_connect(self->dec, "request-key", G_CALLBACK(on_request_key), self->st);
    GstPad* target = gst_element_get_static_pad(self->dec, "rtp_sink");
    gst_ghost_pad_set_target(GST_GHOST_PAD(sink), target);
    gst_object_unref(target);
    target = gst_element_get_static_pad(self->dec, "rtp_src");
    gst_ghost_pad_set_target(GST_GHOST_PAD(src), target);
    gst_object_unref(target);
  }
  gst_element_add_pad(GST_ELEMENT(self), sink);
  gst_element_add_pad(GST_ELEMENT(self), src);
}
