#include <gst/vclassroom/net/pose_stamp.h>

#include <cstring>

namespace vclassroom {

namespace {

constexpr uint8_t kFlagRendered = 1, kFlagClamped = 2;

void put_be64(uint8_t* p, uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<uint8_t>(v);
}

uint64_t get_be64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}

void put_be_float(uint8_t* p, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  for (int i = 3; i >= 0; --i, v >>= 8) p[i] = static_cast<uint8_t>(v);
}

float get_be_float(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | p[i];
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

}  // namespace

size_t pose_stamp_to_wire(const PoseStamp& stamp, uint8_t* out, size_t room) {
  if (!out || room < kPoseStampSize) return 0;
  put_be64(out, stamp.seq);
  put_be64(out + 8, static_cast<uint64_t>(stamp.viewer_time_ns));
  if (!stamp.rendered.known || room < kPoseStampWithPoseSize) return kPoseStampSize;
  out[16] = kFlagRendered | (stamp.rendered.clamped ? kFlagClamped : 0);
  out[17] = out[18] = out[19] = 0;
  for (int i = 0; i < 3; ++i) put_be_float(out + 20 + 4 * i, stamp.rendered.position[i]);
  for (int i = 0; i < 4; ++i) put_be_float(out + 32 + 4 * i, stamp.rendered.orientation[i]);
  return kPoseStampWithPoseSize;
}

bool pose_stamp_from_wire(const uint8_t* data, size_t size, PoseStamp* stamp) {
  if (!data || (size != kPoseStampSize && size != kPoseStampWithPoseSize)) return false;
  PoseStamp s;
  s.seq = get_be64(data);
  s.viewer_time_ns = static_cast<int64_t>(get_be64(data + 8));  // two's complement: -1 stays -1
  if (size == kPoseStampWithPoseSize) {
    const uint8_t flags = data[16];
    if (!(flags & kFlagRendered) || (flags & ~(kFlagRendered | kFlagClamped)) || data[17] || data[18] || data[19])
      return false;
    s.rendered.known = true;
    s.rendered.clamped = flags & kFlagClamped;
    for (int i = 0; i < 3; ++i) s.rendered.position[i] = get_be_float(data + 20 + 4 * i);
    for (int i = 0; i < 4; ++i) s.rendered.orientation[i] = get_be_float(data + 32 + 4 * i);
    if (!rendered_pose_is_valid(s.rendered)) return false;
  }
  *stamp = s;
  return true;
}

}  // namespace vclassroom
