// libFuzzer target: the pose back channel's wire format (pose_from_wire,
// version 2 with its optional HMAC tag), as any host on the network can send
// it. A pose it accepts is valid and reads back the same after pose_to_wire;
// with a key, only a packet tagged with that key is accepted.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/net/pose_wire.h>

using namespace vclassroom;

namespace {

const PoseKey& fuzz_key() {
  static const PoseKey key{std::vector<uint8_t>(32, 0x5a)};
  return key;
}

// Writes the packet's CRC-32 over its untagged part, which the fuzzer would
// almost never guess.
void fix_crc(std::vector<uint8_t>* packet) {
  const uint32_t crc = crc32(packet->data(), kPoseWireSize - 4);
  for (int b = 0; b < 4; ++b) (*packet)[kPoseWireSize - 4 + b] = static_cast<uint8_t>(crc >> (8 * b));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // An input one byte longer than an untagged or a tagged packet is taken as
  // that packet with its CRC written by the target (the extra byte dropped),
  // so the checks behind the CRC are explored too.
  std::vector<uint8_t> packet(data, data + size);
  if (size == kPoseWireSize + 1 || size == kPoseWireMaxSize + 1) {
    packet.resize(size - 1);
    fix_crc(&packet);
  }
  Pose pose;
  std::string error;
  PoseWireInfo info;
  const bool open = pose_from_wire(packet.data(), packet.size(), &pose, &error, nullptr, &info);
  if (!open && (error.empty() || info.error == PoseWireError::kNone)) std::abort();
  Pose keyed;
  PoseWireInfo keyed_info;
  const bool authenticated = pose_from_wire(packet.data(), packet.size(), &keyed, &error, &fuzz_key(), &keyed_info);
  // A key only ever refuses more; what it accepts was tagged and reads the same.
  if (authenticated && (!open || !keyed_info.tagged || keyed.seq != pose.seq)) std::abort();
  if (!open) return 0;
  try {
    validate_pose(pose);
  } catch (const Error&) {
    std::abort();  // accepted from the wire but invalid
  }
  uint8_t again[kPoseWireMaxSize];
  const size_t n = pose_to_wire(pose, again, info.stamp, info.tagged ? &fuzz_key() : nullptr);
  Pose back;
  PoseWireInfo back_info;
  if (!pose_from_wire(again, n, &back, &error, info.tagged ? &fuzz_key() : nullptr, &back_info) ||
      back.seq != pose.seq || back.viewer_time_ns != pose.viewer_time_ns || !(back.position == pose.position) ||
      back_info.stamp.session != info.stamp.session || back_info.stamp.packet != info.stamp.packet ||
      back_info.stamp.sent_ns != info.stamp.sent_ns)
    std::abort();
  return 0;
}
