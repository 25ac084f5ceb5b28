// Real cameras: rgbdsrc, a consumer RGB-D camera through V4L2.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrgbddeviceprovider.h"
#include "gstrgbdsrc.h"

static gboolean plugin_init(GstPlugin* plugin) {
  return gst_element_register(plugin, "rgbdsrc", GST_RANK_NONE, GST_TYPE_RGBD_SRC) &&
         gst_device_provider_register(plugin, "rgbddeviceprovider", GST_RANK_PRIMARY, GST_TYPE_RGBD_DEVICE_PROVIDER);
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomcapture,
                  "gst-vclassroom capture: consumer RGB-D cameras through V4L2", plugin_init, PACKAGE_VERSION,
                  GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
