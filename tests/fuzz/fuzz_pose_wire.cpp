// libFuzzer target: the pose back channel's wire format (pose_from_wire), as
// any host on the network can send it. A pose it accepts is valid and reads
// back the same after pose_to_wire.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <gst/vclassroom/checksum.h>
#include <gst/vclassroom/pose.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // A packet ends in a CRC-32 the fuzzer would almost never guess: an input one
  // byte longer than a packet is taken as a packet whose CRC the target writes
  // (the extra byte dropped), so the checks behind it are explored too.
  std::vector<uint8_t> packet(data, data + size);
  if (size == kPoseWireSize + 1) {
    packet.resize(kPoseWireSize);
    const uint32_t crc = crc32(packet.data(), kPoseWireSize - 4);
    for (int b = 0; b < 4; ++b) packet[kPoseWireSize - 4 + b] = static_cast<uint8_t>(crc >> (8 * b));
  }
  Pose pose;
  std::string error;
  if (!pose_from_wire(packet.data(), packet.size(), &pose, &error)) {
    if (error.empty()) std::abort();
    return 0;
  }
  try {
    validate_pose(pose);
  } catch (const Error&) {
    std::abort();  // accepted from the wire but invalid
  }
  uint8_t again[kPoseWireSize];
  pose_to_wire(pose, again);
  Pose back;
  if (!pose_from_wire(again, sizeof again, &back, &error) || back.seq != pose.seq ||
      back.viewer_time_ns != pose.viewer_time_ns || !(back.position == pose.position))
    std::abort();
  return 0;
}
