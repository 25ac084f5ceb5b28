#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_ENC (gst_rgbd_enc_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdEnc, gst_rgbd_enc, GST, RGBD_ENC, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(rgbdenc);

G_END_DECLS
