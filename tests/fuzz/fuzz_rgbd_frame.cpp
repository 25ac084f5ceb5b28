// libFuzzer target: the RGB-D frame decoder (rgbddec's decode_rgbd_frame), as
// packets from the network reach it. Never crashes, never overflows (UBSan),
// and says why whenever it refuses a frame.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/net/rgbd_codec.h>

namespace {

uint32_t le32(const uint8_t* p) { return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24; }

// Each section carries a CRC-32 the fuzzer would almost never guess, so the
// section decoders behind it would go unexplored: unless bit 0 of the header's
// reserved byte 7 is set, the target writes the right CRCs into its copy first.
void fix_checksums(std::vector<uint8_t>* frame) {
  std::vector<uint8_t>& f = *frame;
  if (f.size() < 16 || (f[7] & 1)) return;
  size_t at = 16;
  for (int i = 0; i < f[5] && f.size() - at >= 12; ++i) {
    const uint32_t len = le32(&f[at + 4]);
    if (len > f.size() - at - 12) return;
    const uint32_t crc = vclassroom::crc32(&f[at + 12], len);
    for (int b = 0; b < 4; ++b) f[at + 8 + b] = static_cast<uint8_t>(crc >> (8 * b));
    at += 12 + len;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> frame(data, data + size);
  fix_checksums(&frame);
  // The caps' size: the one the frame declares when small (so the fuzzer gets
  // past the size check quickly), else 16x16. Large sizes only cost time here;
  // the decoder's own limit on sides is tested in test_codec.
  int width = 16, height = 16;
  if (size >= 16) {
    const uint32_t w = le32(data + 8), h = le32(data + 12);
    if (w >= 1 && w <= 256 && h >= 1 && h <= 256) width = static_cast<int>(w), height = static_cast<int>(h);
  }
  vclassroom::RgbdCodedFrame out;
  std::string error;
  // An empty vector's data() may be null: the decoder must cope with that too.
  const bool ok = vclassroom::decode_rgbd_frame(frame.data(), frame.size(), width, height, &out, &error);
  if (ok) {
    if (out.color.cols != width || out.color.rows != height || out.color.type() != CV_8UC3) std::abort();
    if (out.depth.cols != width || out.depth.rows != height || out.depth.type() != CV_16UC1) std::abort();
    if (!out.label.empty() && (out.label.cols != width || out.label.rows != height)) std::abort();
  } else if (error.empty()) {
    std::abort();  // a refused frame always says why (rgbddec posts it)
  }
  return 0;
}
