// V-VA: the view algorithm (learner segmentation, view warping, multi-view fusion).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstlearnerseg.h"
#include "gstviewfuse.h"
#include "gstviewprep.h"
#include "gstviewwarp.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= GST_ELEMENT_REGISTER(learnerseg, plugin);
  ok &= GST_ELEMENT_REGISTER(viewprep, plugin);
  ok &= GST_ELEMENT_REGISTER(viewwarp, plugin);
  ok &= GST_ELEMENT_REGISTER(viewfuse, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomvva,
                  "gst-vclassroom V-VA: learner segmentation, view warping to the lecturer's pose, multi-view fusion",
                  plugin_init, PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
