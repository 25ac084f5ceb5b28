// The payload of the pose RTP header extension (plugins/net/gstrtphdrextvcpose):
// the seq and viewer time of the pose a video frame was rendered for. Kept
// apart from GStreamer so it can be unit-tested and fuzzed alone.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vclassroom {

// 16 bytes, big-endian: seq (u64), viewer time in ns (i64, -1 = none).
inline constexpr size_t kPoseStampSize = 16;

struct PoseStamp {
  uint64_t seq = 0;
  int64_t viewer_time_ns = -1;
};

// Byte by byte: packet data has no alignment (GStreamer's GST_READ_UINT64_BE
// is a plain 64-bit load on x86, which UBSan reports as misaligned).
void pose_stamp_to_wire(const PoseStamp& stamp, uint8_t out[kPoseStampSize]);
// False unless `size` is exactly kPoseStampSize. Any 16 bytes are a stamp:
// the receiver only reports it (latency), it steers nothing.
bool pose_stamp_from_wire(const uint8_t* data, size_t size, PoseStamp* stamp);

}  // namespace vclassroom
