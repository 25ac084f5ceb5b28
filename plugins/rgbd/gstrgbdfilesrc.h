#pragma once

#include <gst/base/gstpushsrc.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_FILE_SRC (gst_rgbd_file_src_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdFileSrc, gst_rgbd_file_src, GST, RGBD_FILE_SRC, GstPushSrc)

GST_ELEMENT_REGISTER_DECLARE(rgbdfilesrc);

G_END_DECLS
