// The lecturer in a browser: WebRTC output with WHEP signalling (issue 13).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrtphdrextplayoutdelay.h"
#include "gstwhepserversink.h"
#include "gstwhepviewsink.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= GST_ELEMENT_REGISTER(whepserversink, plugin);
  ok &= GST_ELEMENT_REGISTER(whepviewsink, plugin);
  ok &= GST_ELEMENT_REGISTER(rtphdrextplayoutdelay, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomwebrtc,
                  "gst-vclassroom browser lecturer: the rendered view over WebRTC (H.264), WHEP signalling, the pose "
                  "over a data channel, one view for all or a view per lecturer",
                  plugin_init, PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
