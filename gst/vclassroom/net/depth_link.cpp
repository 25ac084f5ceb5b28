#include <gst/vclassroom/net/depth_link.h>

#include <gst/vclassroom/net/range_coder.h>

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <memory>

#include <gst/vclassroom/core/byte_order.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

uint32_t depth_frame_crc(const uint8_t* frame, size_t size) {
  uLong crc = ::crc32(0, frame, 28);
  crc = ::crc32_z(crc, frame + kDepthLinkHeaderBytes, size - kDepthLinkHeaderBytes);
  return uint32_t(crc);
}

namespace {

constexpr uint8_t kVersion = 2;
constexpr uint8_t kFlagKey = 1, kFlagLabels = 2;

// The bins of one tolerance: bin_of[z] for every 16-bit depth, and each bin's centre (bin 0: no measurement).
struct DepthBins {
  uint16_t tolerance = 0;
  std::vector<uint16_t> bin_of;
  std::vector<uint16_t> center;
  std::vector<uint16_t> bound;  // e(z)
};

void build_bins(uint16_t tolerance, DepthBins* b) {
  if (!b->bin_of.empty() && b->tolerance == tolerance) return;
  b->tolerance = tolerance;
  b->bin_of.assign(65536, 0);
  b->bound.assign(65536, 0);
  b->center.assign(1, 0);
  for (uint32_t z = 0; z < 65536; ++z) b->bound[z] = depth_error_bound(uint16_t(z), tolerance);
  uint32_t a = 1;
  while (a < 65536) {
    const uint32_t e = b->bound[a];
    const uint32_t end = std::min<uint32_t>(a + 2 * e + 1, 65536);
    const auto bin = uint16_t(b->center.size());
    // Every z in [a, end) is within e(a) <= e(z) of the centre a + e(a) (e grows with z).
    b->center.push_back(uint16_t(std::min<uint32_t>(a + e, 65535)));
    for (uint32_t z = a; z < end; ++z) b->bin_of[z] = bin;
    a = end;
  }
}


// `rle`: run-length matches only (Z_RLE). Within a tolerance the bit planes' redundancy is runs of zero bytes:
// on the synthetic classroom at 960x540 10 % smaller and a third faster than the default strategy; lossless,
// the values repeat in longer strings, which the default finds (docs/network.md).
void deflate_into(const uint8_t* data, size_t size, int level, bool rle, std::vector<uint8_t>* out) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15, 8, rle ? Z_RLE : Z_DEFAULT_STRATEGY) != Z_OK)
    throw Error("zlib: deflateInit failed");
  const size_t start = out->size();
  out->resize(start + deflateBound(&zs, uLong(size)));
  zs.next_in = const_cast<Bytef*>(data);
  zs.avail_in = uInt(size);
  zs.next_out = out->data() + start;
  zs.avail_out = uInt(out->size() - start);
  const int rc = deflate(&zs, Z_FINISH);
  const size_t produced = zs.total_out;
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate did not finish");
  out->resize(start + produced);
}

// Inflates into `out`, at most `capacity` bytes; false unless the stream ends there and uses all its input.
// The buffer grows with what actually inflates (from 64 KiB, doubling), not with what the header declares.
bool inflate_bounded(const uint8_t* data, size_t size, size_t capacity, std::vector<uint8_t>* out) {
  z_stream zs{};
  if (inflateInit(&zs) != Z_OK) return false;
  zs.next_in = const_cast<Bytef*>(data);
  zs.avail_in = uInt(size);
  out->resize(std::min<size_t>(capacity, 65536));
  int rc = Z_OK;
  for (;;) {
    zs.next_out = out->data() + zs.total_out;
    zs.avail_out = uInt(out->size() - zs.total_out);
    rc = inflate(&zs, Z_FINISH);
    if (rc == Z_STREAM_END || (rc != Z_OK && rc != Z_BUF_ERROR) || zs.avail_out != 0 || out->size() == capacity) break;
    out->resize(std::min(capacity, out->size() * 2));  // the output was full: room for more
  }
  const size_t produced = zs.total_out;
  const bool all_in = zs.avail_in == 0;
  inflateEnd(&zs);
  if (rc != Z_STREAM_END || !all_in) return false;
  out->resize(produced);
  return true;
}

DepthBins& bins_for(uint16_t tolerance) {
  thread_local DepthBins bins;
  build_bins(tolerance, &bins);
  return bins;
}

// The contexts both sides start every frame with (docs/network.md, "The depth frame", lists them).
struct DepthModels {
  BitModel measured[2][64];         // [key][history << 4 | measured neighbours]
  BitModel changed[2][18];          // [key][measured the frame before * 9 + left's state * 3 + upper's state]
  BitModel sign[2];                 // [key]
  BitModel escape;                  // delta frames: a changed pixel's value is a bin, not a step
  BitModel length[4][17];           // [kind: 0 step, 1 key difference, 2 bin, 3 delta's row difference][i]
  BitModel mantissa[4][17][17];     // [kind][length][bit]
};

// A pixel codes at most 36 bits (measured, changed, escape, sign, 16 of length, 16 of mantissa), each costing
// at most 7.05 bits of output (a probability never falls below 31/4096): 31.7 bytes, rounded up.
constexpr size_t kWorstBytesPerPixel = 32;

enum PixelState : uint8_t { kHole = 0, kSame = 1, kChanged = 2 };
enum MagnitudeKind { kDeltaDifference = 0, kKeyDifference = 1, kNoPrediction = 2, kRowDifference = 3 };

// n = floor(log2 v): what a magnitude's cost grows with.
inline int magnitude_length(uint32_t v) {
  int n = 0;
  while ((v >> (n + 1)) != 0) ++n;
  return n;
}

// A magnitude v in 1..131071: its length n = floor(log2 v) in unary (n ones, then a zero unless n = 16), then
// v's n bits below its leading one, most significant first.
inline void put_magnitude(RangeEncoder& rc, DepthModels& m, int kind, uint32_t v) {
  const int n = magnitude_length(v);
  for (int i = 0; i < n; ++i) rc.put(m.length[kind][i], true);
  if (n < 16) rc.put(m.length[kind][n], false);
  for (int b = n - 1; b >= 0; --b) rc.put(m.mantissa[kind][n][b], (v >> b) & 1);
}

inline uint32_t zigzag(int32_t d) { return (uint32_t(d) << 1) ^ uint32_t(d >> 31); }
inline int32_t unzigzag(uint32_t v) { return int32_t(v >> 1) ^ -int32_t(v & 1); }

inline uint32_t get_magnitude(RangeDecoder& rc, DepthModels& m, int kind) {
  int n = 0;
  while (n < 16 && rc.get(m.length[kind][n])) ++n;
  uint32_t v = 1;
  for (int b = n - 1; b >= 0; --b) v = v << 1 | uint32_t(rc.get(m.mantissa[kind][n][b]));
  return v;
}

// Which of a pixel's four causal neighbours (left, upper, upper left, upper right) are measured; `cur` and
// `up` hold the row's and the row above's states at x + 1 (a hole on either side of the image).
inline int neighbours(const uint8_t* cur, const uint8_t* up, int x) {
  return int(cur[x] != kHole) | int(up[x + 1] != kHole) << 1 | int(up[x] != kHole) << 2 | int(up[x + 2] != kHole) << 3;
}

// A delta frame's new value for a measured depth z that left its prediction p (|z - p| > e(z)): on the grid
// p + k (e(p) / 2 + 1), k != 0, the point within e(z) of z nearest to `target` (the encoder's estimate of the
// true depth, which the noise scatters z around: a value near it is kept longer); 0 when the grid has no
// point within the bound (z much nearer than p).
inline int32_t delta_step(uint16_t z, uint16_t p, int32_t target, const DepthBins& b) {
  const int32_t e = b.bound[z], q = int32_t(b.bound[p]) / 2 + 1;
  const bool below = z < p;
  const int32_t num = std::clamp(target, int32_t(z) - e, int32_t(z) + e) - int32_t(p);
  int32_t k = num >= 0 ? (num + q / 2) / q : -((-num + q / 2) / q);
  if (k == 0) k = below ? -1 : 1;
  for (int32_t c : {k, k + 1, k - 1}) {
    const int64_t v = int64_t(p) + int64_t(c) * q;
    if (c != 0 && (c < 0) == below && v >= 1 && v <= 65535 && std::abs(v - int64_t(z)) <= e) return c;
  }
  return 0;
}

// Codes one measured pixel against its prediction `p` (mm, 0: none); returns the value the decoder will
// reconstruct, and its state for the neighbours' contexts in `state`.
inline uint16_t put_pixel(RangeEncoder& rc, DepthModels& m, bool key, int changed_ctx, uint16_t z, uint16_t p,
                          uint16_t left, float target, const DepthBins& b, uint8_t* state) {
  *state = kChanged;
  if (p == 0) {
    const uint16_t bin = b.bin_of[z];
    put_magnitude(rc, m, kNoPrediction, bin);
    return b.center[bin];
  }
  const bool changed = std::abs(int32_t(z) - int32_t(p)) > int32_t(b.bound[z]);
  rc.put(m.changed[key][changed_ctx], changed);
  if (!changed) {
    *state = kSame;
    return p;
  }
  if (key) {  // p is a bin's centre, z in another bin
    const int32_t bin = b.bin_of[z], pb = b.bin_of[p];
    rc.put(m.sign[1], bin < pb);
    put_magnitude(rc, m, kKeyDifference, uint32_t(std::abs(bin - pb)));
    return b.center[bin];
  }
  // The step from p, or (escape) the bin coded against the bin of the depth decoded last on the row, `left`
  // (its bin alone where there is none), whichever is shorter: where the camera or something in view moved,
  // the row is the better prediction.
  const int32_t k = delta_step(z, p, int32_t(target + 0.5f), b);  // target >= 0: rounded
  const int32_t bin = b.bin_of[z];
  const uint32_t row = left != 0 ? zigzag(bin - int32_t(b.bin_of[left])) + 1 : 0;
  const bool escape = k == 0 || (left != 0 && magnitude_length(row) < magnitude_length(uint32_t(std::abs(k))));
  rc.put(m.escape, escape);
  if (escape) {
    put_magnitude(rc, m, left != 0 ? kRowDifference : kNoPrediction, left != 0 ? row : uint32_t(bin));
    return b.center[bin];
  }
  rc.put(m.sign[0], k < 0);
  put_magnitude(rc, m, kDeltaDifference, uint32_t(std::abs(k)));
  return uint16_t(int32_t(p) + k * (int32_t(b.bound[p]) / 2 + 1));
}

// Decodes what put_pixel() coded; 0 when it names a depth beyond the scale.
inline uint16_t get_pixel(RangeDecoder& rc, DepthModels& m, bool key, int changed_ctx, uint16_t p, uint16_t left,
                          const DepthBins& b, uint8_t* state) {
  const auto nbins = int64_t(b.center.size());
  *state = kChanged;
  int64_t bin;
  if (p == 0) {
    bin = get_magnitude(rc, m, kNoPrediction);
  } else if (!rc.get(m.changed[key][changed_ctx])) {
    *state = kSame;
    return p;
  } else if (key) {
    const bool below = rc.get(m.sign[1]);
    const int64_t d = get_magnitude(rc, m, kKeyDifference);
    bin = below ? int64_t(b.bin_of[p]) - d : int64_t(b.bin_of[p]) + d;
  } else if (rc.get(m.escape)) {
    bin = left != 0 ? int64_t(b.bin_of[left]) + unzigzag(get_magnitude(rc, m, kRowDifference) - 1)
                    : int64_t(get_magnitude(rc, m, kNoPrediction));
  } else {
    const bool below = rc.get(m.sign[0]);
    const int64_t k = get_magnitude(rc, m, kDeltaDifference);
    const int64_t v = int64_t(p) + (below ? -k : k) * (int64_t(b.bound[p]) / 2 + 1);
    return v >= 1 && v <= 65535 ? uint16_t(v) : 0;
  }
  return bin >= 1 && bin < nbins ? b.center[size_t(bin)] : 0;
}

}  // namespace

uint16_t depth_error_bound(uint16_t z_mm, uint16_t tolerance_centi_mm) {
  const uint64_t e = uint64_t(tolerance_centi_mm) * z_mm * z_mm / 100000000ull;
  return uint16_t(std::min<uint64_t>(e, 65535));
}

void DepthLinkEncoder::encode(const cv::Mat& depth, const cv::Mat& label, const std::string& caps, bool key,
                              uint16_t tolerance, std::vector<uint8_t>* out, int zlib_level) {
  if (depth.type() != CV_16UC1 || depth.empty() || depth.cols > 65535 || depth.rows > 65535)
    throw Error("depth link: depth must be a 16-bit image of at most 65535 x 65535");
  if (!label.empty() && (label.type() != CV_8UC1 || label.size() != depth.size()))
    throw Error("depth link: labels must be an 8-bit image of the depth's size");
  if (!have_ref_ || tolerance != tolerance_ || recon_.size() != depth.size()) key = true;
  const DepthBins& b = bins_for(tolerance);
  const int w = depth.cols, h = depth.rows;
  if (key) {
    mem_ = cv::Mat::zeros(h, w, CV_16UC1);
    history_ = cv::Mat::zeros(h, w, CV_8UC1);
    estimate_ = cv::Mat::zeros(h, w, CV_32FC1);
  }
  recon_.create(h, w, CV_16UC1);
  const size_t start = out->size();
  out->resize(start + kDepthLinkHeaderBytes);
  out->insert(out->end(), caps.begin(), caps.end());
  const size_t depth_start = out->size();
  // Every pixel in raster order: measured or not, then (measured, with a prediction) whether it keeps the
  // prediction, then (it does not) its new value; the prediction is the pixel's last decoded measurement
  // since the key frame (delta frames) or the last depth decoded before it on its row (key frames).
  auto models = std::make_unique<DepthModels>();
  RangeEncoder rc(out);
  const int k = key ? 1 : 0;
  std::vector<uint8_t> state_a(size_t(w) + 2, kHole), state_b(size_t(w) + 2, kHole);
  uint8_t* cur = state_a.data();
  uint8_t* up = state_b.data();
  for (int y = 0; y < h; ++y) {
    rc.reserve(size_t(w) * kWorstBytesPerPixel + 16);
    std::swap(cur, up);
    const uint16_t* zr = depth.ptr<uint16_t>(y);
    uint16_t* br = recon_.ptr<uint16_t>(y);
    uint16_t* mr = mem_.ptr<uint16_t>(y);
    uint8_t* hr = history_.ptr<uint8_t>(y);
    float* er = estimate_.ptr<float>(y);
    uint16_t run = 0;
    for (int x = 0; x < w; ++x) {
      const uint16_t z = zr[x];
      const bool measured = z != 0;
      const int before = hr[x];
      rc.put(models->measured[k][before << 4 | neighbours(cur, up, x)], measured);
      hr[x] = uint8_t((before << 1 | int(measured)) & 3);
      br[x] = 0;
      if (!measured) {
        cur[x + 1] = kHole;
        continue;
      }
      // The estimate of the true depth: the mean of the pixel's last measurements (a quarter of the way
      // towards each new one), restarted where it jumps by more than twice the bound (something moved).
      float& est = er[x];
      est = std::abs(float(z) - est) > 2.0f * float(b.bound[z]) + 1.0f ? float(z) : est + 0.25f * (float(z) - est);
      const uint16_t v = put_pixel(rc, *models, key, (before & 1) * 9 + cur[x] * 3 + up[x + 1], z,
                                   key ? run : mr[x], run, est, b, &cur[x + 1]);
      mr[x] = run = br[x] = v;
    }
  }
  rc.finish();
  const size_t label_start = out->size();
  if (!label.empty()) {
    cv::Mat l = label.isContinuous() ? label : label.clone();
    deflate_into(l.data, l.total(), zlib_level, true, out);
  }
  uint8_t* hdr = out->data() + start;
  std::memcpy(hdr, "VCDL", 4);
  hdr[4] = kVersion;
  hdr[5] = uint8_t((key ? kFlagKey : 0) | (label.empty() ? 0 : kFlagLabels));
  write_le16(hdr + 6, tolerance);
  write_le16(hdr + 8, uint32_t(w));
  write_le16(hdr + 10, uint32_t(h));
  number_ = have_ref_ ? number_ + 1 : 0;
  write_le32(hdr + 12, number_);
  write_le32(hdr + 16, uint32_t(caps.size()));
  write_le32(hdr + 20, uint32_t(label_start - depth_start));
  write_le32(hdr + 24, uint32_t(out->size() - label_start));
  write_le32(hdr + 28, depth_frame_crc(hdr, out->size() - start));
  tolerance_ = tolerance;
  have_ref_ = true;
}

cv::Mat DepthLinkEncoder::reconstructed() const { return recon_.clone(); }

namespace {

struct Header {
  uint8_t flags = 0;
  uint16_t tolerance = 0;
  int w = 0, h = 0;
  uint32_t number = 0;
  uint64_t caps_len = 0, depth_len = 0, label_len = 0;
};

// The fixed header, every field checked against the frame's size, the limits and the checksum; "" or why not.
std::string parse_header(const uint8_t* data, size_t size, const DepthLinkLimits& limits, Header* hd) {
  if (size < kDepthLinkHeaderBytes) return "depth frame shorter than its header";
  if (std::memcmp(data, "VCDL", 4) != 0) return "not a depth frame (magic)";
  if (data[4] != kVersion) return "depth frame version " + std::to_string(data[4]) + " (this reads 2)";
  hd->flags = data[5];
  if (hd->flags & ~(kFlagKey | kFlagLabels)) return "depth frame with unknown flags";
  hd->tolerance = uint16_t(read_le16(data + 6));
  hd->w = int(read_le16(data + 8));
  hd->h = int(read_le16(data + 10));
  hd->number = read_le32(data + 12);
  hd->caps_len = read_le32(data + 16);
  hd->depth_len = read_le32(data + 20);
  hd->label_len = read_le32(data + 24);
  if (hd->w <= 0 || hd->h <= 0 || hd->w > limits.max_width || hd->h > limits.max_height ||
      uint64_t(hd->w) * uint64_t(hd->h) > limits.max_pixels)
    return "depth frame of " + std::to_string(hd->w) + "x" + std::to_string(hd->h) + " beyond the limits";
  if (hd->caps_len > limits.max_caps_bytes) return "depth frame's caps longer than allowed";
  if (hd->caps_len + hd->depth_len + hd->label_len != size - kDepthLinkHeaderBytes)
    return "depth frame's section lengths do not add up to its size";
  if (((hd->flags & kFlagLabels) != 0) != (hd->label_len > 0)) return "depth frame's label flag and section disagree";
  // Every pixel costs the depth coder more than 1/1024 of a byte (its measured bit alone at least 0.011 bit): a
  // shorter section cannot be an image of the declared size, and nothing is allocated for it.
  if (hd->depth_len < uint64_t(hd->w) * uint64_t(hd->h) / 1024 + 5) return "depth section too short for its image";
  if (depth_frame_crc(data, size) != read_le32(data + 28)) return "depth frame checksum";
  return "";
}

// Decodes the depth section into `depth`, updating `mem` and `history` (the state of encode()); "" or why not.
std::string decode_pixels(const uint8_t* data, size_t size, bool key, const DepthBins& b, cv::Mat* depth,
                          cv::Mat* mem, cv::Mat* history) {
  const int w = depth->cols, h = depth->rows;
  auto models = std::make_unique<DepthModels>();
  RangeDecoder rc(data, size);
  const int k = key ? 1 : 0;
  std::vector<uint8_t> state_a(size_t(w) + 2, kHole), state_b(size_t(w) + 2, kHole);
  uint8_t* cur = state_a.data();
  uint8_t* up = state_b.data();
  for (int y = 0; y < h; ++y) {
    std::swap(cur, up);
    uint16_t* zr = depth->ptr<uint16_t>(y);
    uint16_t* mr = mem->ptr<uint16_t>(y);
    uint8_t* hr = history->ptr<uint8_t>(y);
    uint16_t run = 0;
    for (int x = 0; x < w; ++x) {
      const int before = hr[x];
      const bool measured = rc.get(models->measured[k][before << 4 | neighbours(cur, up, x)]);
      hr[x] = uint8_t((before << 1 | int(measured)) & 3);
      zr[x] = 0;
      if (!measured) {
        cur[x + 1] = kHole;
        continue;
      }
      const uint16_t v = get_pixel(rc, *models, key, (before & 1) * 9 + cur[x] * 3 + up[x + 1],
                                   key ? run : mr[x], run, b, &cur[x + 1]);
      if (v == 0) return "depth section names a depth beyond the scale";
      mr[x] = run = zr[x] = v;
    }
    if (rc.overrun() > 0) return "depth section cut short";
  }
  if (rc.left() > 0) return "depth section longer than its image";
  return "";
}

}  // namespace

bool DepthLinkDecoder::decode(const uint8_t* data, size_t size, DepthLinkFrame* frame, std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  Header hd;
  const std::string bad = parse_header(data, size, limits_, &hd);
  if (!bad.empty()) return fail(bad);
  const bool key = hd.flags & kFlagKey;
  const int w = hd.w, h = hd.h;
  if (!key && !(have_ref_ && hd.number == number_ + 1 && hd.tolerance == tolerance_ && size_ == cv::Size(w, h)))
    return fail("delta depth frame " + std::to_string(hd.number) +
                " without the frame before it (waiting for a key frame)");
  const uint8_t* p = data + kDepthLinkHeaderBytes;
  const size_t pixels = size_t(w) * size_t(h);
  // From here the state is changed in place: a frame refused from here on waits for the next key frame.
  have_ref_ = false;
  if (key) {
    mem_ = cv::Mat::zeros(h, w, CV_16UC1);
    history_ = cv::Mat::zeros(h, w, CV_8UC1);
  }
  cv::Mat depth(h, w, CV_16UC1);
  const std::string why = decode_pixels(p + hd.caps_len, hd.depth_len, key, bins_for(hd.tolerance), &depth, &mem_,
                                        &history_);
  if (!why.empty()) return fail(why);
  cv::Mat label;
  if (hd.label_len > 0) {
    std::vector<uint8_t> l;
    if (!inflate_bounded(p + hd.caps_len + hd.depth_len, hd.label_len, pixels, &l) || l.size() != pixels)
      return fail("label section does not inflate to the image");
    label = cv::Mat(h, w, CV_8UC1);
    std::memcpy(label.data, l.data(), pixels);
  }
  frame->depth = depth;
  frame->label = label;
  frame->caps.assign(reinterpret_cast<const char*>(p), hd.caps_len);
  frame->number = hd.number;
  frame->key = key;
  frame->tolerance = hd.tolerance;
  size_ = cv::Size(w, h);
  tolerance_ = hd.tolerance;
  number_ = hd.number;
  have_ref_ = true;
  return true;
}

}  // namespace vclassroom
