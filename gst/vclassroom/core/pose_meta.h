// The pose a frame was rendered for (DESIGN.md §2.3): a GstMeta with the pose
// event's seq and viewer time, so motion-to-photon latency can be measured.
#pragma once

#include <cstdint>

#include <gst/gst.h>

namespace vclassroom {

struct PoseMeta {
  GstMeta meta;
  uint64_t seq;
  int64_t viewer_time_ns;  // -1: the pose carried none
};

GType pose_meta_api_get_type();
const GstMetaInfo* pose_meta_get_info();
// Adds (or replaces) the meta on a writable buffer.
PoseMeta* buffer_add_pose_meta(GstBuffer* buf, uint64_t seq, int64_t viewer_time_ns);
// The buffer's pose meta, or nullptr.
PoseMeta* buffer_get_pose_meta(GstBuffer* buf);

}  // namespace vclassroom
