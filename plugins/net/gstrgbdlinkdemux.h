#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_LINK_DEMUX (gst_rgbd_link_demux_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdLinkDemux, gst_rgbd_link_demux, GST, RGBD_LINK_DEMUX, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(rgbdlinkdemux);

G_END_DECLS
