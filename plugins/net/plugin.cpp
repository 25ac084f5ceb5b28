// The network family: what carries RGB-D frames and poses between the three worlds.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstrgbddec.h"
#include "gstrgbdenc.h"
#include "gstposerecv.h"
#include "gstposesend.h"
#include "gstrtphdrextvcpose.h"
#include "gstsenderfilter.h"
#include "gstsrtpfiledec.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= gst_element_register(plugin, "rgbdenc", GST_RANK_NONE, GST_TYPE_RGBD_ENC);
  ok &= gst_element_register(plugin, "rgbddec", GST_RANK_NONE, GST_TYPE_RGBD_DEC);
  ok &= gst_element_register(plugin, "posesend", GST_RANK_NONE, GST_TYPE_POSE_SEND);
  ok &= gst_element_register(plugin, "poserecv", GST_RANK_NONE, GST_TYPE_POSE_RECV);
  ok &= gst_element_register(plugin, "rtphdrextvcpose", GST_RANK_MARGINAL, GST_TYPE_RTP_HEADER_EXTENSION_VC_POSE);
  ok &= gst_element_register(plugin, "senderfilter", GST_RANK_NONE, GST_TYPE_SENDER_FILTER);
  ok &= gst_element_register(plugin, "srtpfiledec", GST_RANK_NONE, GST_TYPE_SRTP_FILE_DEC);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomnet,
                  "gst-vclassroom network: RGB-D compression, pose back channel", plugin_init, PACKAGE_VERSION,
                  GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
