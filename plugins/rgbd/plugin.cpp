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
  ok &= GST_ELEMENT_REGISTER(rgbdmux, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbddemux, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdfilesrc, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdfilesink, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdtestsrc, plugin);
  ok &= GST_ELEMENT_REGISTER(depthcolorize, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomrgbd,
                  "gst-vclassroom RGB-D streams: mux/demux to video/x-raw, recorded datasets", plugin_init,
                  PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
