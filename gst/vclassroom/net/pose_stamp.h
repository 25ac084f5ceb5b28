// The payload of the pose RTP header extension (plugins/net/gstrtphdrextvcpose):
// the seq and viewer time of the pose a video frame was rendered for, and the
// pose as rendered (after the server's navigation bounds). Kept apart from
// GStreamer so it can be unit-tested and fuzzed alone.
#pragma once

#include <cstddef>
#include <cstdint>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

// Big-endian. The short form, 16 bytes: seq (u64), viewer time in ns (i64, -1 = none).
inline constexpr size_t kPoseStampSize = 16;
// The long form, 48 bytes: the short form, a flags byte (bit 0: the rendered pose follows, always set;
// bit 1: the server clamped it), three zero bytes, then the position (3 x f32, metres) and the orientation
// (4 x f32, w x y z). It needs RFC 8285's two-byte header (over 16 bytes).
inline constexpr size_t kPoseStampWithPoseSize = 48;

struct PoseStamp {
  uint64_t seq = 0;
  int64_t viewer_time_ns = -1;
  RenderedPose rendered;  // known: written in the long form
};

// Writes the long form when stamp.rendered.known and `room` allows, else the short form; returns the
// size written, 0 when `room` is below kPoseStampSize. Byte by byte: packet data has no alignment
// (GStreamer's GST_READ_UINT64_BE is a plain 64-bit load on x86, which UBSan reports as misaligned).
size_t pose_stamp_to_wire(const PoseStamp& stamp, uint8_t* out, size_t room);
// True for exactly kPoseStampSize bytes (any 16 bytes are a stamp: the receiver only reports them) or
// kPoseStampWithPoseSize bytes whose flags and reserved bytes are as written and whose pose is a usable one
// (rendered_pose_is_valid: the lecturer's side may show it).
bool pose_stamp_from_wire(const uint8_t* data, size_t size, PoseStamp* stamp);

}  // namespace vclassroom
