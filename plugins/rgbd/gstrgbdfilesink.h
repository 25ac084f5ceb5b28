#pragma once

#include <gst/base/gstbasesink.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_FILE_SINK (gst_rgbd_file_sink_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdFileSink, gst_rgbd_file_sink, GST, RGBD_FILE_SINK, GstBaseSink)

GST_ELEMENT_REGISTER_DECLARE(rgbdfilesink);

G_END_DECLS
