// libFuzzer target: a WHEP POST's body, as anyone with the join token can send it, through the offer
// inspection that runs before GstSDP and webrtcbin read it (inspect_whep_offer, issue #29). An accepted
// offer's pick must be in range: H.264 on a dynamic payload type (96..127) or none, the playout-delay
// extension id 0 or 1..255; a refusal must say why. The whole input is the offer.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include <gst/vclassroom/webrtc/whep.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view sdp(reinterpret_cast<const char*>(data), size);
  WhepOffer offer;
  std::string why;
  if (inspect_whep_offer(sdp, &offer, &why)) {
    if (offer.h264_payload != -1 && (offer.h264_payload < 96 || offer.h264_payload > 127)) std::abort();
    if (offer.playout_delay_extension_id < 0 || offer.playout_delay_extension_id > 255) std::abort();
    if (offer.h264_payload == -1 && offer.playout_delay_extension_id != 0) std::abort();
  } else if (why.empty()) {
    std::abort();
  }
  return 0;
}
