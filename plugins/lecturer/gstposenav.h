#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_POSE_NAV (gst_pose_nav_get_type())
G_DECLARE_FINAL_TYPE(GstPoseNav, gst_pose_nav, GST, POSE_NAV, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(posenav);

G_END_DECLS
