#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_DEMUX (gst_rgbd_demux_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdDemux, gst_rgbd_demux, GST, RGBD_DEMUX, GstElement)

GST_ELEMENT_REGISTER_DECLARE(rgbddemux);

G_END_DECLS
