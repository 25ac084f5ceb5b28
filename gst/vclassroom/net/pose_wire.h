// The pose back channel's RTP payload and its key (docs/network.md, "Wire payload, version 3").
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

// The pose on the wire: the RTP payload of the back channel, version 3
// (docs/network.md), little-endian:
//   "VCP3", flags u32 (bit 0: a tag follows), session u64 (the sender's
//   random number for this run: a restarted lecturer is a new session),
//   packet u64 (numbers every packet of the session, repeats included),
//   sent-time i64 (the sender's monotonic clock when it sent the packet, ns;
//   -1 none), seq u64, viewer-time i64, x y z qw qx qy qz fov as IEEE doubles
//   (fov NaN = none), CRC-32 of all before it; then, with flag bit 0, a
//   16-byte tag: HMAC-SHA256 (key from a file) of all before it, truncated.
//   The tag covers session, packet number and times, so a receiver's replay
//   window (net/pose_session.h) can trust them.
inline constexpr size_t kPoseWireSize = 4 + 4 + 8 + 8 + 8 + 8 + 8 + 8 * 8 + 4;  // untagged
inline constexpr size_t kPoseTagSize = 16;
inline constexpr size_t kPoseWireMaxSize = kPoseWireSize + kPoseTagSize;  // tagged
inline constexpr uint32_t kPoseWireFlagTagged = 1u;

// What a packet says of its sending apart from the pose. Built from a bare
// session number where the rest does not matter (tests, untagged senders).
struct PoseWireStamp {
  uint64_t session = 0;
  uint64_t packet = 0;
  int64_t sent_ns = -1;
  PoseWireStamp(uint64_t session_ = 0, uint64_t packet_ = 0, int64_t sent_ns_ = -1)  // NOLINT: implicit on purpose
      : session(session_), packet(packet_), sent_ns(sent_ns_) {}
};

// The shared secret that authenticates poses: a file's whole content, raw
// bytes (e.g. `head -c 32 /dev/urandom > pose.key`).
inline constexpr size_t kPoseKeyMinSize = 16;
inline constexpr size_t kPoseKeyMaxSize = 1024;
struct PoseKey {
  std::vector<uint8_t> bytes;
  bool empty() const { return bytes.empty(); }
};
// Throws Error naming the file when it is missing, unreadable, shorter than
// kPoseKeyMinSize or longer than kPoseKeyMaxSize bytes.
PoseKey load_pose_key(const std::string& path);

// Why pose_from_wire() refused a packet.
enum class PoseWireError {
  kNone,
  kDamaged,          // wrong size, version, flags or checksum
  kUnauthenticated,  // a key is set and the tag is missing or wrong
  kInvalid,          // well-formed but a pose validate_pose() rejects (NaN, not a unit quaternion, ...)
};
struct PoseWireInfo {
  PoseWireStamp stamp;   // the sender's session number, packet number and sending time
  bool tagged = false;   // whether the packet carried a tag (checked only when a key is given)
  PoseWireError error = PoseWireError::kNone;
};

// Writes the packet into `out` (room for kPoseWireMaxSize bytes); returns its
// size: kPoseWireSize, or kPoseWireMaxSize when a non-empty key tags it.
size_t pose_to_wire(const Pose& pose, uint8_t* out, const PoseWireStamp& stamp = {}, const PoseKey* key = nullptr);
// False with a message on a wrong size, version, flags or checksum, a pose
// validate_pose() rejects, or, when `key` is non-empty, a missing or wrong
// tag (without a key a tag is not checked: anyone can steer, docs/network.md).
// `info` (optional) receives the stamp and why the packet was refused.
bool pose_from_wire(const uint8_t* data, size_t size, Pose* pose, std::string* error, const PoseKey* key = nullptr,
                    PoseWireInfo* info = nullptr);

}  // namespace vclassroom
