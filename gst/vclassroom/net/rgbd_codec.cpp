#include <gst/vclassroom/net/rgbd_codec.h>

#include <gst/vclassroom/core/byte_order.h>
#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/net/zigzag.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>


namespace vclassroom {

namespace {


// ---- 4-bit variable-length integers: 3 value bits + 1 "more" bit per nibble.
class NibbleWriter {
 public:
  explicit NibbleWriter(std::vector<uint8_t>* out) : out_(out) {}
  void put(uint32_t v) {
    while (v >= 8) {
      nibble((v & 7) | 8);
      v >>= 3;
    }
    nibble(v);
  }
  void flush() {
    if (half_) out_->push_back(static_cast<uint8_t>(pending_));
    half_ = false;
  }

 private:
  void nibble(uint32_t n) {
    if (half_) {
      out_->push_back(static_cast<uint8_t>(pending_ | (n << 4)));
      half_ = false;
    } else {
      pending_ = n;
      half_ = true;
    }
  }
  std::vector<uint8_t>* out_;
  uint32_t pending_ = 0;
  bool half_ = false;
};

class NibbleReader {
 public:
  NibbleReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  // False on running out of data or a value longer than 32 bits.
  bool get(uint32_t* v) {
    // The next nibbles wait in a register: a value costs a mask, a count of
    // trailing zeros and a shift, with a load only every few values (the
    // decoder's speed is this chain's length). The first nibble without the
    // "more" bit ends the value, within its first 11 (33 bits).
    if (avail_ < 11) refill();
    uint64_t ends = ~bits_ & 0x88888888888ull;
    if (avail_ < 11) ends &= (uint64_t(1) << (4 * avail_)) - 1;  // the data ends within the value's reach
    if (!ends) return false;  // running out, or over 11 nibbles
    const int nibbles = (__builtin_ctzll(ends) >> 2) + 1;
    // The 3 value bits of each nibble packed together in four shift-and-mask steps.
    uint64_t x = bits_ & 0x77777777777ull;
    x = (x & 0x0707070707070707ull) | ((x >> 1) & 0x3838383838383838ull);
    x = (x & 0x003F003F003F003Full) | ((x >> 2) & 0x0FC00FC00FC00FC0ull);
    x = (x & 0x00000FFF00000FFFull) | ((x >> 4) & 0x00FFF00000FFF000ull);
    x = (x & 0xFFFFFFull) | ((x >> 8) & 0xFFFFFF000000ull);
    if (nibbles == 11 && ((x >> 32) & 1)) return false;  // bit 32 set: over 32 bits
    *v = static_cast<uint32_t>(x & ((uint64_t(1) << (3 * nibbles)) - 1));
    bits_ >>= 4 * nibbles;
    avail_ -= nibbles;
    pos_ += static_cast<size_t>(nibbles);
    return true;
  }

 private:
  // bits_ from nibble pos_ on: 15 or 16 nibbles, fewer only at the data's end.
  void refill() {
    const size_t byte = pos_ >> 1;
    uint64_t w = 0;
    if (byte + 8 <= size_) {
      std::memcpy(&w, data_ + byte, 8);
#if !defined(__BYTE_ORDER__) || !defined(__ORDER_BIG_ENDIAN__)
#error "the depth codec needs the compiler's __BYTE_ORDER__"
#elif __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
      w = __builtin_bswap64(w);
#endif
      avail_ = 16;
    } else {
      const size_t left = byte < size_ ? size_ - byte : 0;
      for (size_t i = 0; i < left; ++i) w |= uint64_t(data_[byte + i]) << (8 * i);
      avail_ = static_cast<int>(2 * left);
    }
    const int odd = static_cast<int>(pos_ & 1);
    bits_ = w >> (4 * odd);
    avail_ = std::max(0, avail_ - odd);
  }

  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;     // in nibbles: the first of bits_
  uint64_t bits_ = 0;  // the next avail_ nibbles, the rest zero
  int avail_ = 0;
};

// LOCO-I's median edge detector from the left (a), upper (b) and upper-left
// (c) neighbours: a + b - c clamped to [min(a, b), max(a, b)].
inline int median_edge(int a, int b, int c) { return std::min(std::max(a + b - c, std::min(a, b)), std::max(a, b)); }

// Prediction of a valid pixel from its decoded neighbours (the median edge
// detector where all three are valid, else the nearest valid one).
inline int predict(const uint16_t* row, const uint16_t* up, int x, int last) {
  const int a = x > 0 ? row[x - 1] : 0;
  const int b = up ? up[x] : 0;
  const int c = (up && x > 0) ? up[x - 1] : 0;
  // Written as selects, not branches: which case applies changes from pixel
  // to pixel in noisy depth.
  const int med = median_edge(a, b, c);
  int p = b ? b : last;
  p = a ? a : p;
  return (a && b && c) ? med : p;
}

void put_u32(std::vector<uint8_t>* out, uint32_t v) {
  out->resize(out->size() + 4);
  write_le32(out->data() + out->size() - 4, v);
}

enum : uint8_t { kPlaneColor = 0, kPlaneDepth = 1, kPlaneLabel = 2 };
enum : uint8_t { kCodecJpeg = 1, kCodecDepthMed = 2, kCodecLabelRuns = 3 };
constexpr uint8_t kVersion = 1;
constexpr size_t kHeaderSize = 16, kSectionHeaderSize = 12;


}  // namespace

void encode_depth_lossless(const cv::Mat& depth, std::vector<uint8_t>* out) {
  CV_Assert(depth.type() == CV_16UC1);
  out->clear();
  out->reserve(depth.total());
  NibbleWriter w(out);
  uint32_t zeros = 0;
  std::vector<uint32_t> residuals;  // of the current run of valid pixels
  residuals.reserve(depth.cols);
  int last = 0;
  auto flush_run = [&]() {
    w.put(zeros);
    w.put(static_cast<uint32_t>(residuals.size()));
    for (uint32_t r : residuals) w.put(r);
    zeros = 0;
    residuals.clear();
  };
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    const uint16_t* up = y > 0 ? depth.ptr<uint16_t>(y - 1) : nullptr;
    for (int x = 0; x < depth.cols; ++x) {
      const int v = row[x];
      if (!v) {
        if (!residuals.empty()) flush_run();
        ++zeros;
        continue;
      }
      residuals.push_back(zigzag(v - predict(row, up, x, last)));
      last = v;
    }
  }
  if (zeros || !residuals.empty()) flush_run();
  w.flush();
}

bool decode_depth_lossless(const uint8_t* data, size_t size, int width, int height, cv::Mat* depth) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) return false;
  depth->create(height, width, CV_16UC1);  // freshly created: continuous
  uint16_t* base = depth->ptr<uint16_t>(0);
  NibbleReader r(data, size);
  const size_t total = static_cast<size_t>(width) * height;
  size_t i = 0;
  int x = 0, y = 0, last = 0;
  while (i < total) {
    uint32_t zeros, valid;
    if (!r.get(&zeros) || !r.get(&valid)) return false;
    if (zeros > total - i || valid > total - i - zeros) return false;
    std::memset(base + i, 0, zeros * sizeof(uint16_t));
    i += zeros;
    x += static_cast<int>(zeros % static_cast<uint32_t>(width));
    y += static_cast<int>(zeros / static_cast<uint32_t>(width));
    if (x >= width) {
      x -= width;
      ++y;
    }
    // The run a row at a time. Only a row's first pixel of the run needs the
    // whole predict(): the others' left neighbour is the pixel just decoded,
    // kept in a register (the decoder's speed is this chain's length).
    for (uint32_t left = valid; left;) {
      uint16_t* row = base + static_cast<size_t>(y) * width;
      const uint16_t* up = y > 0 ? row - width : nullptr;
      const int end = x + static_cast<int>(std::min(left, static_cast<uint32_t>(width - x)));
      left -= static_cast<uint32_t>(end - x);
      uint32_t u;
      if (!r.get(&u)) return false;
      // In 64 bits: a residual may be anything up to +-2^31 in damaged data, and
      // the sum must not overflow before it is checked.
      int64_t v = int64_t{predict(row, up, x, last)} + unzigzag(u);
      if (v < 1 || v > 65535) return false;  // a valid pixel is never 0: damaged data
      row[x] = static_cast<uint16_t>(v);
      int a = static_cast<int>(v);
      for (++x; x < end; ++x) {
        if (!r.get(&u)) return false;
        // predict() with a known left neighbour a: the median edge detector where
        // the pixels above are known too, else a.
        const int b = up ? up[x] : 0, c = up ? up[x - 1] : 0, med = median_edge(a, b, c);
        v = int64_t{(b && c) ? med : a} + unzigzag(u);
        if (v < 1 || v > 65535) return false;
        row[x] = static_cast<uint16_t>(v);
        a = static_cast<int>(v);
      }
      last = a;
      if (x == width) {
        x = 0;
        ++y;
      }
    }
    i += valid;
  }
  return true;
}

void encode_labels(const cv::Mat& labels, std::vector<uint8_t>* out) {
  CV_Assert(labels.type() == CV_8UC1);
  out->clear();
  NibbleWriter w(out);
  int current = -1;
  uint32_t run = 0;
  for (int y = 0; y < labels.rows; ++y) {
    const uint8_t* row = labels.ptr<uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (row[x] == current) {
        ++run;
        continue;
      }
      if (run) {
        w.put(static_cast<uint32_t>(current));
        w.put(run);
      }
      current = row[x];
      run = 1;
    }
  }
  if (run) {
    w.put(static_cast<uint32_t>(current));
    w.put(run);
  }
  w.flush();
}

bool decode_labels(const uint8_t* data, size_t size, int width, int height, cv::Mat* labels) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) return false;
  labels->create(height, width, CV_8UC1);
  NibbleReader r(data, size);
  const size_t total = static_cast<size_t>(width) * height;
  uint8_t* p = labels->ptr<uint8_t>(0);  // created continuous
  size_t i = 0;
  while (i < total) {
    uint32_t value, run;
    if (!r.get(&value) || !r.get(&run) || value > 255 || run == 0 || run > total - i) return false;
    std::memset(p + i, static_cast<int>(value), run);
    i += run;
  }
  return true;
}


void encode_rgbd_frame(const RgbdCodedFrame& f, int quality, std::vector<uint8_t>* out) {
  CV_Assert(f.color.size() == f.depth.size());
  struct Section {
    uint8_t plane, codec;
    std::vector<uint8_t> payload;
  };
  std::vector<Section> sections(f.label.empty() ? 2 : 3);
  sections[0] = {kPlaneColor, kCodecJpeg, {}};
  encode_jpeg(f.color, quality, &sections[0].payload);
  sections[1] = {kPlaneDepth, kCodecDepthMed, {}};
  encode_depth_lossless(f.depth, &sections[1].payload);
  if (!f.label.empty()) {
    sections[2] = {kPlaneLabel, kCodecLabelRuns, {}};
    encode_labels(f.label, &sections[2].payload);
  }
  out->clear();
  for (char c : {'V', 'C', 'R', 'D'}) out->push_back(static_cast<uint8_t>(c));
  out->push_back(kVersion);
  out->push_back(static_cast<uint8_t>(sections.size()));
  out->push_back(0);
  out->push_back(0);
  put_u32(out, static_cast<uint32_t>(f.color.cols));
  put_u32(out, static_cast<uint32_t>(f.color.rows));
  for (const auto& s : sections) {
    out->push_back(s.plane);
    out->push_back(s.codec);
    out->push_back(0);
    out->push_back(0);
    put_u32(out, static_cast<uint32_t>(s.payload.size()));
    put_u32(out, crc32(s.payload.data(), s.payload.size()));
    out->insert(out->end(), s.payload.begin(), s.payload.end());
  }
}

bool decode_rgbd_frame(const uint8_t* data, size_t size, int width, int height, RgbdCodedFrame* f,
                       std::string* error, RgbdFrameFault* fault) {
  if (fault) *fault = RgbdFrameFault::kDamaged;
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
    return fail("stream size " + std::to_string(width) + "x" + std::to_string(height) + " out of range (1.." +
                std::to_string(kMaxImageSide) + " per side)");
  if (!data || size < kHeaderSize || std::memcmp(data, "VCRD", 4) != 0) return fail("not an rgbdenc frame (bad magic)");
  if (data[4] != kVersion) return fail("unsupported frame version " + std::to_string(data[4]));
  const int n = data[5];
  if (read_le32(data + 8) != static_cast<uint32_t>(width) || read_le32(data + 12) != static_cast<uint32_t>(height)) {
    if (fault) *fault = RgbdFrameFault::kWrongSize;
    return fail("frame size " + std::to_string(read_le32(data + 8)) + "x" + std::to_string(read_le32(data + 12)) +
                " differs from the caps' " + std::to_string(width) + "x" + std::to_string(height));
  }
  size_t at = kHeaderSize;
  bool have_color = false, have_depth = false;
  unsigned seen = 0;
  f->label.release();
  for (int i = 0; i < n; ++i) {
    if (size - at < kSectionHeaderSize) return fail("truncated frame (section header)");
    const uint8_t plane = data[at], codec = data[at + 1];
    const uint32_t len = read_le32(data + at + 4), crc = read_le32(data + at + 8);
    at += kSectionHeaderSize;
    if (len > size - at) return fail("truncated frame (section " + std::to_string(i) + ")");
    const uint8_t* payload = data + at;
    if (crc32(payload, len) != crc) return fail("damaged frame (checksum of section " + std::to_string(i) + ")");
    at += len;
    // Each plane once: a repeated section would only make the decoder work twice.
    if (plane < 3 && (seen & (1u << plane))) return fail("plane " + std::to_string(plane) + " appears twice");
    if (plane < 3) seen |= 1u << plane;
    std::string why;
    if (plane == kPlaneColor && codec == kCodecJpeg) {
      if (!decode_jpeg(payload, len, width, height, &f->color, &why)) return fail(why);
      have_color = true;
    } else if (plane == kPlaneDepth && codec == kCodecDepthMed) {
      if (!decode_depth_lossless(payload, len, width, height, &f->depth)) return fail("malformed depth section");
      have_depth = true;
    } else if (plane == kPlaneLabel && codec == kCodecLabelRuns) {
      if (!decode_labels(payload, len, width, height, &f->label)) return fail("malformed label section");
    } else {
      return fail("unknown section (plane " + std::to_string(plane) + ", codec " + std::to_string(codec) + ")");
    }
  }
  if (!have_color || !have_depth) return fail("frame lacks its colour or depth section");
  if (fault) *fault = RgbdFrameFault::kNone;
  return true;
}

std::string rgbd_stream_refusal(int camera_id, int w, int h, const RgbdStreamLimits& limits, const Rig* rig,
                                const std::string& rig_path) {
  const std::string size = std::to_string(w) + "x" + std::to_string(h);
  if (w > limits.max_width || h > limits.max_height || uint64_t(w) * uint64_t(h) > limits.max_pixels)
    return "caps declare " + size + ", beyond max-width " + std::to_string(limits.max_width) + ", max-height " +
           std::to_string(limits.max_height) + " or max-pixels " + std::to_string(limits.max_pixels);
  if (rig) {
    const CameraCalib* cam = rig->find(camera_id);
    if (!cam) return "camera " + std::to_string(camera_id) + " is not in the rig " + rig_path;
    if (cam->width != w || cam->height != h)
      return "caps declare " + size + " but the rig " + rig_path + " has camera " + std::to_string(cam->id) +
             " at " + std::to_string(cam->width) + "x" + std::to_string(cam->height);
  }
  return "";
}

}  // namespace vclassroom
