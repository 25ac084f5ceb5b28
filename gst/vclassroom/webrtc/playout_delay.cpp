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

int extmap_id_for(std::string_view value, std::string_view uri) {
  size_t i = 0;
  int id = 0;
  while (i < value.size() && value[i] >= '0' && value[i] <= '9' && id <= 255) id = id * 10 + (value[i++] - '0');
  if (i == 0 || id < 1 || id > 255) return 0;
  if (i < value.size() && value[i] == '/') {  // a direction: sendrecv, sendonly, recvonly, inactive
    ++i;
    while (i < value.size() && value[i] >= 'a' && value[i] <= 'z') ++i;
  }
  if (i >= value.size() || value[i] != ' ') return 0;
  while (i < value.size() && value[i] == ' ') ++i;
  const std::string_view rest = value.substr(i);
  const std::string_view named = rest.substr(0, rest.find(' '));
  return named == uri ? id : 0;
}

}  // namespace vclassroom
