// The playout-delay RTP header extension (webrtc.org's
// http://www.webrtc.org/experiments/rtp-hdrext/playout-delay): the sender
// tells the receiver how long it may buffer a frame before showing it. Three
// bytes, a 12-bit minimum and a 12-bit maximum in 10 ms units; min = max = 0
// asks a browser to show each frame as soon as it is decoded, which is what a
// lecturer steering the view by head pose wants (a jitter buffer that grows to
// smooth the server's uneven frame times adds its whole depth to
// pose-to-photon latency).
#pragma once

#include <cstddef>
#include <cstdint>

namespace vclassroom {

inline constexpr const char* kPlayoutDelayUri = "http://www.webrtc.org/experiments/rtp-hdrext/playout-delay";
inline constexpr size_t kPlayoutDelayBytes = 3;
inline constexpr int kPlayoutDelayMaxMs = 4095 * 10;

struct PlayoutDelay {
  int min_ms = 0;
  int max_ms = 0;
};

// Writes `delay` (each bound clamped to 0..kPlayoutDelayMaxMs and rounded down to 10 ms; a maximum below the
// minimum is raised to it) into out[0..2].
void write_playout_delay(const PlayoutDelay& delay, uint8_t out[kPlayoutDelayBytes]);
// False unless `size` is kPlayoutDelayBytes and the maximum is not below the minimum.
bool read_playout_delay(const uint8_t* data, size_t size, PlayoutDelay* delay);

}  // namespace vclassroom
