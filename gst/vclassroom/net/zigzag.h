// Signed values as unsigned codes, small magnitudes first (0, -1, 1, -2, 2, ... -> 0, 1, 2, 3, 4, ...): what
// the depth coders (rgbd_codec's residuals, depth_link's steps and bins) hand their entropy codes.
// GStreamer-free.
#pragma once

#include <cstdint>

namespace vclassroom {

inline uint32_t zigzag(int32_t v) { return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31); }
inline int32_t unzigzag(uint32_t u) { return static_cast<int32_t>(u >> 1) ^ -static_cast<int32_t>(u & 1); }

}  // namespace vclassroom
