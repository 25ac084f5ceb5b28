// V-DA, the paper's depth algorithm: depth completion and planar refinement
// against a static classroom model (docs/vda.md).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstdepthcomplete.h"
#include "gstplanerefine.h"

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = TRUE;
  ok &= GST_ELEMENT_REGISTER(depthcomplete, plugin);
  ok &= GST_ELEMENT_REGISTER(planerefine, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vclassroomvda,
                  "gst-vclassroom V-DA: depth completion and planar refinement with a static classroom model",
                  plugin_init, PACKAGE_VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
