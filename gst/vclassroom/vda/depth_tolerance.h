// The depth tolerance max(min_mm, ratio * depth) of V-DA's row passes, in
// integer lanes (they vectorise better than float ones): the ratio in 1/65536
// steps. Internal to the library (not installed).
#pragma once

#include <algorithm>
#include <cstdint>

namespace vclassroom::detail {

inline uint32_t ratio_q16(double ratio) {
  return static_cast<uint32_t>(std::clamp(ratio, 0.0, 65535.0 / 65536.0) * 65536.0 + 0.5);
}

inline uint32_t depth_tolerance(uint32_t depth_mm, uint32_t min_mm, uint32_t ratio_q16) {
  return std::max(min_mm, (depth_mm * ratio_q16 + 32768u) >> 16);
}

}  // namespace vclassroom::detail
