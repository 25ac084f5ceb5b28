#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_VIEW_WARP (gst_view_warp_get_type())
G_DECLARE_FINAL_TYPE(GstViewWarp, gst_view_warp, GST, VIEW_WARP, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(viewwarp);

G_END_DECLS
