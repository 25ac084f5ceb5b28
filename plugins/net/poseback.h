// The pose back channel's RTP stream, shared by posesend and poserecv.
#pragma once

#include <gst/gst.h>

inline constexpr const char* kPoseRtpCaps =
    "application/x-rtp, media = (string) application, clock-rate = (int) 90000, "
    "encoding-name = (string) X-VCLASSROOM-POSE";

// Internal links of the pass-through video pads only: events and queries of
// the video path must never leak onto the RTP pad (its caps differ).
inline GstIterator* iterate_video_link(GstPad* pad, GstPad* other) {
  (void)pad;
  GValue v = G_VALUE_INIT;
  g_value_init(&v, GST_TYPE_PAD);
  g_value_set_object(&v, other);
  GstIterator* it = gst_iterator_new_single(GST_TYPE_PAD, &v);
  g_value_unset(&v);
  return it;
}
