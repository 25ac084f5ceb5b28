// The lecturer in a browser: WebRTC output with WHEP signalling (issue 13).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrtphdrextplayoutdelay.h"

GType gst_whep_server_sink_get_type();
GType gst_whep_view_sink_get_type();

static gboolean plugin_init(GstPlugin* plugin) {
  return gst_element_register(plugin, "whepserversink", GST_RANK_NONE, gst_whep_server_sink_get_type()) &&
         gst_element_register(plugin, "whepviewsink", GST_RANK_NONE, gst_whep_view_sink_get_type()) &&
         gst_element_register(plugin, "rtphdrextplayoutdelay", GST_RANK_MARGINAL, GST_TYPE_RTP_HDREXT_PLAYOUT_DELAY);
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomwebrtc,
                  "gst-vclassroom browser lecturer: the rendered view over WebRTC (H.264), WHEP signalling, the pose "
                  "over a data channel, one view for all or a view per lecturer",
                  plugin_init, PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
