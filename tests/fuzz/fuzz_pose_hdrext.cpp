// libFuzzer target: the pose RTP header extension's payload (rtphdrextvcpose's
// read vfunc parses it with pose_stamp_from_wire, at any alignment): short and long forms.
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
  const size_t n = size - 1;
  const bool ok = pose_stamp_from_wire(packet.data() + shift, n, &stamp);
  if (ok && n != kPoseStampSize && n != kPoseStampWithPoseSize) std::abort();
  if (ok != (n == kPoseStampSize) && n == kPoseStampSize) std::abort();  // any 16 bytes are a stamp
  if (ok) {
    uint8_t again[kPoseStampWithPoseSize];
    if (pose_stamp_to_wire(stamp, again, sizeof again) != n) std::abort();
    if (std::memcmp(again, data + 1, n) != 0) std::abort();  // the wire form round-trips exactly
    if (stamp.rendered.known && !rendered_pose_is_valid(stamp.rendered)) std::abort();
  }
  return 0;
}
