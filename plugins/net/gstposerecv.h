#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_POSE_RECV (gst_pose_recv_get_type())
G_DECLARE_FINAL_TYPE(GstPoseRecv, gst_pose_recv, GST, POSE_RECV, GstElement)

GST_ELEMENT_REGISTER_DECLARE(poserecv);

G_END_DECLS
