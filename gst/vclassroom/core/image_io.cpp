#include <gst/vclassroom/core/image_io.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/limits.h>

namespace fs = std::filesystem;

namespace vclassroom {

namespace {

uint32_t be32(const uint8_t* p) { return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | p[3]; }
uint32_t be16(const uint8_t* p) { return uint32_t{p[0]} << 8 | p[1]; }

bool png_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  // The signature, then the IHDR chunk: length, "IHDR", width, height (big-endian).
  if (size < 24 || std::memcmp(data, kSignature, 8) != 0 || std::memcmp(data + 12, "IHDR", 4) != 0) return false;
  *w = be32(data + 16);
  *h = be32(data + 20);
  return true;
}

// Walks the JPEG's marker segments to its frame header (SOFn). Each step moves
// forward by the segment's length, so the walk ends.
bool jpeg_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8) return false;
  size_t at = 2;
  while (at + 4 <= size) {
    if (data[at] != 0xFF) return false;
    const uint8_t marker = data[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const size_t length = be16(data + at + 2);
    if (length < 2) return false;
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (at + 9 > size) return false;
      *h = be16(data + at + 5);
      *w = be16(data + at + 7);
      return true;
    }
    if (marker == 0xD9 || marker == 0xDA) return false;  // end of image or scan data before any frame header
    at += 2 + length;
  }
  return false;
}

// Netpbm (P1..P6): magic, then width and height as decimal text, with
// whitespace and '#' comments between.
bool pnm_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  if (size < 3 || data[0] != 'P' || data[1] < '1' || data[1] > '6') return false;
  size_t at = 2;
  uint32_t values[2];
  for (uint32_t& v : values) {
    for (;;) {  // whitespace and comments
      if (at >= size) return false;
      if (data[at] == '#') {
        while (at < size && data[at] != '\n') ++at;
      } else if (std::isspace(data[at])) {
        ++at;
      } else {
        break;
      }
    }
    if (!std::isdigit(data[at])) return false;
    uint64_t x = 0;
    while (at < size && std::isdigit(data[at])) {
      x = x * 10 + (data[at++] - '0');
      if (x > 0xFFFFFFFFu) return false;  // no side is that large: refused below as unknown
    }
    v = static_cast<uint32_t>(x);
  }
  *w = values[0];
  *h = values[1];
  return true;
}

}  // namespace

bool image_header_size(const uint8_t* data, size_t size, uint32_t* width, uint32_t* height) {
  if (!data) return false;
  return png_header(data, size, width, height) || jpeg_header(data, size, width, height) ||
         pnm_header(data, size, width, height);
}

cv::Mat decode_image(const uint8_t* data, size_t size, int flags, const std::string& what, const std::string& name,
                     cv::Size expected, const std::string& expected_from) {
  auto wrong_size = [&](cv::Size got) {
    return Error(name + ": " + what + " image is " + std::to_string(got.width) + "x" + std::to_string(got.height) +
                 ", but " + (expected_from.empty() ? std::string("the expected size") : expected_from) + " is " +
                 std::to_string(expected.width) + "x" + std::to_string(expected.height));
  };
  if (!data || size == 0) throw Error(name + ": cannot decode " + what + " image (empty file)");
  if (size > kMaxImageFileBytes)
    throw Error(name + ": " + what + " image file of " + std::to_string(size) + " bytes (expected at most " +
                std::to_string(kMaxImageFileBytes) + ")");
  // The size from the header, checked before OpenCV decodes and allocates:
  // a few bytes may declare 30000x30000. Only the formats datasets use are read.
  uint32_t w = 0, h = 0;
  if (!image_header_size(data, size, &w, &h))
    throw Error(name + ": cannot decode " + what + " image (not a PNG, JPEG or PNM image, or a damaged header)");
  if (w < 1 || h < 1 || w > static_cast<uint32_t>(kMaxImageSide) || h > static_cast<uint32_t>(kMaxImageSide))
    throw Error(name + ": " + what + " image declares " + std::to_string(w) + "x" + std::to_string(h) +
                " (expected sides 1.." + std::to_string(kMaxImageSide) + ")");
  if (!expected.empty() && cv::Size(int(w), int(h)) != expected) throw wrong_size(cv::Size(int(w), int(h)));
  cv::Mat m;
  try {
    // imdecode takes a Mat header over the bytes: no copy.
    m = cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<uint8_t*>(data)), flags);
  } catch (const cv::Exception& e) {
    throw Error(name + ": cannot decode " + what + " image (" + e.msg + ")");
  }
  if (m.empty()) throw Error(name + ": cannot decode " + what + " image (corrupt, truncated or not an image)");
  if (!expected.empty() && m.size() != expected) throw wrong_size(m.size());
  return m;
}

cv::Mat read_image(const std::string& path, int flags, const std::string& what, cv::Size expected,
                   const std::string& expected_from) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path + ": " + what + " image file is missing");
  const uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw Error(path + ": cannot read " + what + " image (" + ec.message() + ")");
  if (bytes > kMaxImageFileBytes)
    throw Error(path + ": " + what + " image file of " + std::to_string(bytes) + " bytes (expected at most " +
                std::to_string(kMaxImageFileBytes) + ")");
  std::vector<uint8_t> data(static_cast<size_t>(bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size())))
    throw Error(path + ": cannot read " + what + " image");
  return decode_image(data.data(), data.size(), flags, what, path, expected, expected_from);
}

cv::Mat read_color_image(const std::string& path, const std::string& what, cv::Size expected,
                         const std::string& expected_from) {
  cv::Mat m = read_image(path, cv::IMREAD_UNCHANGED, what, expected, expected_from);
  if (m.type() != CV_8UC3) {
    static const char* const depths[] = {"8-bit", "8-bit signed", "16-bit", "16-bit signed", "32-bit integer",
                                         "32-bit float", "64-bit float", "16-bit float"};
    const int channels = m.channels();
    const std::string kind = channels == 1 ? "grey" : channels == 2 ? "grey with alpha" : channels == 4 ? "RGBA"
                                                                                                        : "colour";
    throw Error(path + ": " + what + " image is " + depths[m.depth() & 7] + " " + kind + " (" +
                std::to_string(channels) + " channel" + (channels == 1 ? "" : "s") +
                "); expected 8-bit RGB (3 channels)");
  }
  return m;
}

cv::Mat read_depth_mm(const std::string& path, double depth_scale, cv::Size expected, const std::string& expected_from) {
  cv::Mat raw = read_image(path, cv::IMREAD_UNCHANGED, "depth", expected, expected_from);
  if (raw.type() != CV_16UC1)
    throw Error(path + ": depth image must be single-channel 16-bit (got " + std::to_string(raw.channels()) +
                " channel(s) of " + std::to_string(8 * raw.elemSize1()) + " bit)");
  if (depth_scale == 1.0) return raw;
  cv::Mat mm;
  raw.convertTo(mm, CV_16U, depth_scale);  // rounds and saturates at 65535
  return mm;
}

}  // namespace vclassroom
