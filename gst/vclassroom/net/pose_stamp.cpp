#include <gst/vclassroom/net/pose_stamp.h>

namespace vclassroom {

namespace {

void put_be64(uint8_t* p, uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<uint8_t>(v);
}

uint64_t get_be64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

void pose_stamp_to_wire(const PoseStamp& stamp, uint8_t out[kPoseStampSize]) {
  put_be64(out, stamp.seq);
  put_be64(out + 8, static_cast<uint64_t>(stamp.viewer_time_ns));
}

bool pose_stamp_from_wire(const uint8_t* data, size_t size, PoseStamp* stamp) {
  if (!data || size != kPoseStampSize) return false;
  stamp->seq = get_be64(data);
  stamp->viewer_time_ns = static_cast<int64_t>(get_be64(data + 8));  // two's complement: -1 stays -1
  return true;
}

}  // namespace vclassroom
