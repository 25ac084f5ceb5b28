// libFuzzer target: what a browser sends the WHEP endpoint and its data
// channel, as anyone with the join token (or a page on a hostile network) can
// send it: pose messages (parse_pose_message), playout-delay extension bytes
// (read_playout_delay), frame echoes (parse_frame_echo, which the page parses),
// STUN/TURN URIs, and the losses its receiver reports claim (LossBasedRate).
// The first byte picks the parser. What each accepts must be well-formed: a
// pose it returns is valid and formats back to a message that parses the same;
// a playout delay is within its bounds; a rate stays within its own.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include <gst/vclassroom/webrtc/loss_rate.h>
#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/whep.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 5) {
    case 0: {
      Pose pose;
      std::string why;
      if (parse_pose_message(text, &pose, &why)) {
        try {
          validate_pose(pose);
        } catch (...) {
          std::abort();
        }
        Pose again;
        if (!parse_pose_message(format_pose_message(pose), &again, &why) || again.seq != pose.seq) std::abort();
      }
      break;
    }
    case 1: {
      PlayoutDelay delay;
      if (read_playout_delay(data + 1, size - 1, &delay) &&
          (delay.min_ms < 0 || delay.max_ms < delay.min_ms || delay.max_ms > kPlayoutDelayMaxMs))
        std::abort();
      break;
    }
    case 2: {
      uint32_t rtp = 0;
      uint64_t seq = 0;
      double time_ms = 0;
      RenderedPose rendered;
      parse_frame_echo(text, &rtp, &seq, &time_ms, &rendered);
      break;
    }
    case 4: {
      // Reports' losses as any 8 bytes make a double (NaN, infinities, negatives, > 1 included).
      LossBasedRate rate(LossRateParams{4000, 250});
      for (size_t at = 1; at + sizeof(double) <= size; at += sizeof(double)) {
        double lost;
        std::memcpy(&lost, data + at, sizeof lost);
        const int kbit = rate.on_report(lost);
        if (kbit < 250 || kbit > 4000) std::abort();
      }
      break;
    }
    default: {
      IceServer server;
      std::string why;
      if (parse_ice_server(text, &server, &why)) {
        if (server.port < 1 || server.port > 65535) std::abort();
        const std::string link = ice_server_link(server);
        if (link.find('\n') != std::string::npos || link.find('\r') != std::string::npos) std::abort();
      }
      break;
    }
  }
  return 0;
}
