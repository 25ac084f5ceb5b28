// The network family: what carries RGB-D frames and poses between the three worlds.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrgbddec.h"
#include "gstrgbdenc.h"
#include "gstrgbdlinkdemux.h"
#include "gstrgbdlinkjoin.h"
#include "gstrgbdlinkmux.h"
#include "gstrgbdlinksplit.h"
#include "gstposerecv.h"
#include "gstposesend.h"
#include "gstrtphdrextvcpose.h"
#include "gstsenderfilter.h"
#include "gstsrtpfiledec.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= GST_ELEMENT_REGISTER(rgbdenc, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbddec, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdlinksplit, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdlinkmux, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdlinkdemux, plugin);
  ok &= GST_ELEMENT_REGISTER(rgbdlinkjoin, plugin);
  ok &= GST_ELEMENT_REGISTER(posesend, plugin);
  ok &= GST_ELEMENT_REGISTER(poserecv, plugin);
  ok &= GST_ELEMENT_REGISTER(rtphdrextvcpose, plugin);
  ok &= GST_ELEMENT_REGISTER(senderfilter, plugin);
  ok &= GST_ELEMENT_REGISTER(srtpfiledec, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomnet,
                  "gst-vclassroom network: RGB-D compression, pose back channel", plugin_init, PACKAGE_VERSION,
                  GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
