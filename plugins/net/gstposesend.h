#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_POSE_SEND (gst_pose_send_get_type())
G_DECLARE_FINAL_TYPE(GstPoseSend, gst_pose_send, GST, POSE_SEND, GstElement)

GST_ELEMENT_REGISTER_DECLARE(posesend);

G_END_DECLS
