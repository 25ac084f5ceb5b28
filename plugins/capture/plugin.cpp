// Real cameras: rgbdsrc, a consumer RGB-D camera through V4L2.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrgbddeviceprovider.h"
#include "gstrgbdsrc.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= GST_ELEMENT_REGISTER(rgbdsrc, plugin);
  ok &= GST_DEVICE_PROVIDER_REGISTER(rgbddeviceprovider, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomcapture,
                  "gst-vclassroom capture: consumer RGB-D cameras through V4L2", plugin_init, PACKAGE_VERSION,
                  GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
