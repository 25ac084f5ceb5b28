// Little-endian integers in byte buffers: what the project's wire formats (rgbdenc frames, the camera link's
// depth frames) write and read, whatever the host's byte order.
#pragma once

#include <cstdint>

namespace vclassroom {

inline void write_le16(uint8_t* p, uint32_t v) {
  p[0] = uint8_t(v);
  p[1] = uint8_t(v >> 8);
}
inline void write_le32(uint8_t* p, uint32_t v) {
  write_le16(p, v & 0xffff);
  write_le16(p + 2, v >> 16);
}
inline uint32_t read_le16(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8; }
inline uint32_t read_le32(const uint8_t* p) { return read_le16(p) | read_le16(p + 2) << 16; }

}  // namespace vclassroom
