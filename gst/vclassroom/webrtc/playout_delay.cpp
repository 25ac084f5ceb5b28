#include "playout_delay.h"

#include <algorithm>

namespace vclassroom {

void write_playout_delay(const PlayoutDelay& delay, uint8_t out[kPlayoutDelayBytes]) {
  const int min_units = std::clamp(delay.min_ms, 0, kPlayoutDelayMaxMs) / 10;
  const int max_units = std::max(min_units, std::clamp(delay.max_ms, 0, kPlayoutDelayMaxMs) / 10);
  out[0] = uint8_t(min_units >> 4);
  out[1] = uint8_t(((min_units & 0xf) << 4) | (max_units >> 8));
  out[2] = uint8_t(max_units & 0xff);
}

bool read_playout_delay(const uint8_t* data, size_t size, PlayoutDelay* delay) {
  if (!data || size != kPlayoutDelayBytes) return false;
  const int min_units = (data[0] << 4) | (data[1] >> 4);
  const int max_units = ((data[1] & 0xf) << 8) | data[2];
  if (max_units < min_units) return false;
  delay->min_ms = min_units * 10;
  delay->max_ms = max_units * 10;
  return true;
}

}  // namespace vclassroom
