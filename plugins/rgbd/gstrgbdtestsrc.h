#pragma once

#include <gst/base/gstpushsrc.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_TEST_SRC (gst_rgbd_test_src_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdTestSrc, gst_rgbd_test_src, GST, RGBD_TEST_SRC, GstPushSrc)

GST_ELEMENT_REGISTER_DECLARE(rgbdtestsrc);

G_END_DECLS
