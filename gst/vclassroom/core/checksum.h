// Integrity checks for what crosses the network.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vclassroom {

// CRC-32 (IEEE 802.3 polynomial, as zlib and PNG use).
uint32_t crc32(const uint8_t* data, size_t size);

}  // namespace vclassroom
