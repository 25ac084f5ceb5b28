// rtphdrextplayoutdelay: writes the playout-delay RTP header extension
// (gst/vclassroom/webrtc/playout_delay.h) on every packet of a payloader.
#pragma once

#include <gst/rtp/rtp.h>

G_BEGIN_DECLS

GType gst_rtp_hdrext_playout_delay_get_type(void);
#define GST_TYPE_RTP_HDREXT_PLAYOUT_DELAY (gst_rtp_hdrext_playout_delay_get_type())

GST_ELEMENT_REGISTER_DECLARE(rtphdrextplayoutdelay);

G_END_DECLS
