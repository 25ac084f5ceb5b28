// libFuzzer target: the pose RTP header extension's payload (rtphdrextvcpose's
// read vfunc parses it with pose_stamp_from_wire, at any alignment).
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <gst/vclassroom/net/pose_stamp.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The first byte shifts the payload off alignment, as inside an RTP packet.
  if (size == 0) return 0;
  const size_t shift = data[0] % 8;
  std::vector<uint8_t> packet(shift + size - 1);
  if (size > 1) std::memcpy(packet.data() + shift, data + 1, size - 1);
  PoseStamp stamp;
  const bool ok = pose_stamp_from_wire(packet.data() + shift, size - 1, &stamp);
  if (ok != (size - 1 == kPoseStampSize)) std::abort();
  if (ok) {
    uint8_t again[kPoseStampSize];
    pose_stamp_to_wire(stamp, again);
    if (std::memcmp(again, data + 1, kPoseStampSize) != 0) std::abort();  // the wire form round-trips exactly
  }
  return 0;
}
