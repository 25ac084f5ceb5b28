// libFuzzer target: what a browser sends the WHEP endpoint and its data
// channel, as anyone with the join token (or a page on a hostile network) can
// send it: pose messages (parse_pose_message), playout-delay extension bytes
// (read_playout_delay), frame echoes (parse_frame_echo, which the page parses)
// and STUN/TURN URIs. The first byte picks the parser. What each accepts must
// be well-formed: a pose it returns is valid and formats back to a message that
// parses the same; a playout delay is within its bounds.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include <gst/vclassroom/webrtc/playout_delay.h>
#include <gst/vclassroom/webrtc/whep.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 4) {
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
