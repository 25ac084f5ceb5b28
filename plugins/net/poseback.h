// The pose back channel's RTP stream, shared by posesend and poserecv.
#pragma once

#include <gst/gst.h>

#include <mutex>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/net/pose_wire.h>

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

// Loads the pose key of the element's key-file property ("" = none) into
// *key when the element starts; `lock` guards both. False after posting an
// error naming the file (the state change must then fail).
inline bool load_key_file(GstElement* element, std::mutex& lock, const std::string& key_file,
                          vclassroom::PoseKey* key) {
  std::string error;
  {
    std::lock_guard<std::mutex> g(lock);
    *key = vclassroom::PoseKey();
    try {
      if (!key_file.empty()) *key = vclassroom::load_pose_key(key_file);
    } catch (const vclassroom::Error& e) {
      error = e.what();
    }
  }
  if (error.empty()) return true;
  // Nothing of ours is locked while the message is posted.
  GST_ELEMENT_ERROR(element, RESOURCE, OPEN_READ, ("%s", error.c_str()), ("property key-file"));
  return false;
}
