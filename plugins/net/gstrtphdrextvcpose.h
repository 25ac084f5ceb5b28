#pragma once

#include <gst/rtp/gstrtphdrext.h>

G_BEGIN_DECLS

#define GST_TYPE_RTP_HEADER_EXTENSION_VC_POSE (gst_rtp_header_extension_vc_pose_get_type())
G_DECLARE_FINAL_TYPE(GstRTPHeaderExtensionVcPose, gst_rtp_header_extension_vc_pose, GST,
                     RTP_HEADER_EXTENSION_VC_POSE, GstRTPHeaderExtension)

// Negotiated by this URI in the caps (extmap-N) or an SDP.
#define VCLASSROOM_RTP_HDREXT_POSE_URI "urn:gst-vclassroom:rtp-hdrext:pose"

GST_ELEMENT_REGISTER_DECLARE(rtphdrextvcpose);

G_END_DECLS
