#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_DEC (gst_rgbd_dec_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdDec, gst_rgbd_dec, GST, RGBD_DEC, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(rgbddec);

G_END_DECLS
