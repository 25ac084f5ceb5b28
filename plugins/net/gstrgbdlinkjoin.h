#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_LINK_JOIN (gst_rgbd_link_join_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdLinkJoin, gst_rgbd_link_join, GST, RGBD_LINK_JOIN, GstElement)

GST_ELEMENT_REGISTER_DECLARE(rgbdlinkjoin);

G_END_DECLS
