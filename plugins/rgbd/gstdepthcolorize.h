#pragma once

#include <gst/video/gstvideofilter.h>

G_BEGIN_DECLS

#define GST_TYPE_DEPTH_COLORIZE (gst_depth_colorize_get_type())
G_DECLARE_FINAL_TYPE(GstDepthColorize, gst_depth_colorize, GST, DEPTH_COLORIZE, GstVideoFilter)

GST_ELEMENT_REGISTER_DECLARE(depthcolorize);

G_END_DECLS
