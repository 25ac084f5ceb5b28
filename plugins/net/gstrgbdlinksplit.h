#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_LINK_SPLIT (gst_rgbd_link_split_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdLinkSplit, gst_rgbd_link_split, GST, RGBD_LINK_SPLIT, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(rgbdlinksplit);

G_END_DECLS
