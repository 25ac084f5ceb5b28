// The RGB-D stream family: bridges to video/x-raw and recorded datasets.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstdepthcolorize.h"
#include "gstrgbddemux.h"
#include "gstrgbdfilesink.h"
#include "gstrgbdfilesrc.h"
#include "gstrgbdmux.h"
#include "gstrgbdtestsrc.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= gst_element_register(plugin, "rgbdmux", GST_RANK_NONE, GST_TYPE_RGBD_MUX);
  ok &= gst_element_register(plugin, "rgbddemux", GST_RANK_NONE, GST_TYPE_RGBD_DEMUX);
  ok &= gst_element_register(plugin, "rgbdfilesrc", GST_RANK_NONE, GST_TYPE_RGBD_FILE_SRC);
  ok &= gst_element_register(plugin, "rgbdfilesink", GST_RANK_NONE, GST_TYPE_RGBD_FILE_SINK);
  ok &= gst_element_register(plugin, "rgbdtestsrc", GST_RANK_NONE, GST_TYPE_RGBD_TEST_SRC);
  ok &= gst_element_register(plugin, "depthcolorize", GST_RANK_NONE, GST_TYPE_DEPTH_COLORIZE);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomrgbd,
                  "gst-vclassroom RGB-D streams: mux/demux to video/x-raw, recorded datasets", plugin_init,
                  PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
