#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_LINK_MUX (gst_rgbd_link_mux_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdLinkMux, gst_rgbd_link_mux, GST, RGBD_LINK_MUX, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(rgbdlinkmux);

G_END_DECLS
