// The pose a frame was rendered for (DESIGN.md §2.3): a GstMeta with the pose
// event's seq and viewer time, so motion-to-photon latency can be measured,
// and the pose as rendered (after the navigation bounds), so the lecturer's
// side learns where its view really is.
#pragma once

#include <cstdint>

#include <gst/gst.h>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

struct PoseMeta {
  GstMeta meta;
  uint64_t seq;
  int64_t viewer_time_ns;  // -1: the pose carried none
  RenderedPose rendered;   // rendered.known false: only seq and time are known (an older sender)
  uint64_t session;        // the pose's session (Pose::session); 0 unnamed, as after RTP (not on the wire)
};

GType pose_meta_api_get_type();
const GstMetaInfo* pose_meta_get_info();
// Adds (or replaces) the meta on a writable buffer.
PoseMeta* buffer_add_pose_meta(GstBuffer* buf, uint64_t seq, int64_t viewer_time_ns,
                               const RenderedPose& rendered = RenderedPose{}, uint64_t session = 0);
// The buffer's pose meta, or nullptr.
PoseMeta* buffer_get_pose_meta(GstBuffer* buf);

}  // namespace vclassroom
