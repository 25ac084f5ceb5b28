#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_DEPTH_COMPLETE (gst_depth_complete_get_type())
G_DECLARE_FINAL_TYPE(GstDepthComplete, gst_depth_complete, GST, DEPTH_COMPLETE, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(depthcomplete);

G_END_DECLS
