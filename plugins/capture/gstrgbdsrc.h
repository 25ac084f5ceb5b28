#pragma once

#include <gst/base/gstpushsrc.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_SRC (gst_rgbd_src_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdSrc, gst_rgbd_src, GST, RGBD_SRC, GstPushSrc)

GST_ELEMENT_REGISTER_DECLARE(rgbdsrc);

G_END_DECLS
