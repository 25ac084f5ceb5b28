#pragma once

#include <gst/base/gstaggregator.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_MUX (gst_rgbd_mux_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdMux, gst_rgbd_mux, GST, RGBD_MUX, GstAggregator)

GST_ELEMENT_REGISTER_DECLARE(rgbdmux);

G_END_DECLS
