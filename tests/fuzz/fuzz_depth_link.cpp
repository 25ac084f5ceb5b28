// libFuzzer target: the camera link's depth as it arrives (rgbdlinkdemux, rgbdlinkjoin): an H.264 access unit
// whose depth SEI is found and decoded, and the bytes themselves as a depth frame ("VCDL"), each after a valid
// key frame so that delta frames are explored too, through the decoder and through the server's backlog (checked
// on arrival, decoded when taken). Never crashes, never overflows (UBSan), says why whenever it refuses.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>


#include <opencv2/core.hpp>

#include <gst/vclassroom/core/byte_order.h>
#include <gst/vclassroom/net/depth_link.h>
#include <gst/vclassroom/net/depth_link_backlog.h>
#include <gst/vclassroom/net/h264_sei.h>

namespace {

// A key frame of 8x6 (frame 0) that every run starts from.
const std::vector<uint8_t>& key_frame() {
  static const std::vector<uint8_t> key = [] {
    cv::Mat depth(6, 8, CV_16UC1), label(6, 8, CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 8; ++x) depth.at<uint16_t>(y, x) = uint16_t((x + y) % 5 == 0 ? 0 : 900 + 150 * x + 40 * y);
    std::vector<uint8_t> out;
    vclassroom::DepthLinkEncoder().encode(depth, label, "video/x-rgbd", true, 280, &out);
    return out;
  }();
  return key;
}

// The frame's checksum would stop the fuzzer at once: written right into the copy unless the size is odd.
void fix_checksum(std::vector<uint8_t>* f) {
  if (f->size() < vclassroom::kDepthLinkHeaderBytes || (f->size() & 1)) return;
  vclassroom::write_le32(f->data() + 28, vclassroom::depth_frame_crc(f->data(), f->size()));
}

void decode_after_key(const std::vector<uint8_t>& frame) {
  vclassroom::DepthLinkLimits limits;
  limits.max_width = limits.max_height = 256;  // large sizes only cost time here
  limits.max_pixels = 256 * 256;
  vclassroom::DepthLinkDecoder dec(limits);
  vclassroom::DepthLinkFrame f;
  std::string err;
  if (!dec.decode(key_frame().data(), key_frame().size(), &f, &err)) std::abort();
  err.clear();
  if (!dec.decode(frame.data(), frame.size(), &f, &err) && err.empty()) std::abort();  // a refusal says why
  vclassroom::DepthLinkBacklog backlog(limits);
  vclassroom::DepthLinkHeader h;
  uint64_t id = 0;
  if (!backlog.push(key_frame().data(), key_frame().size(), &h, &id, &err)) std::abort();
  err.clear();
  if (!backlog.push(frame.data(), frame.size(), &h, &id, &err)) {
    if (err.empty()) std::abort();
    return;
  }
  if (!backlog.take(id, &f, &err) && err.empty()) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> frame(data, data + size);
  fix_checksum(&frame);
  decode_after_key(frame);
  std::vector<uint8_t> sei;
  std::string err;
  const auto found = vclassroom::h264_find_user_data(data, size, vclassroom::kDepthLinkSeiUuid, 1 << 20, &sei, &err);
  if (found == vclassroom::SeiFind::kMalformed && err.empty()) std::abort();
  if (found == vclassroom::SeiFind::kFound) {
    fix_checksum(&sei);
    decode_after_key(sei);
  }
  vclassroom::h264_is_idr(data, size);
  return 0;
}
