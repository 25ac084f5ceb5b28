#include <gst/vclassroom/net/depth_link.h>

#include <gst/vclassroom/core/simd.h>

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <memory>

#include <gst/vclassroom/core/byte_order.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/net/zigzag.h>

namespace vclassroom {

uint32_t depth_frame_crc(const uint8_t* frame, size_t size) {
  uLong crc = ::crc32(0, frame, 28);
  crc = ::crc32_z(crc, frame + kDepthLinkHeaderBytes, size - kDepthLinkHeaderBytes);
  return uint32_t(crc);
}

namespace {

constexpr uint8_t kVersion = 3;
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

// Deflates the label plane with run-length matches only (Z_RLE): its redundancy is runs of one label.
void deflate_into(const uint8_t* data, size_t size, int level, std::vector<uint8_t>* out) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK)
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

// Bits go out most significant first. The writer keeps its bits in a register and its bytes go through a raw
// pointer into room reserve() made (a vector's push_back, which may reallocate, would cost a check per byte).
class BitWriter {
 public:
  explicit BitWriter(std::vector<uint8_t>* out) : out_(out), start_(out->size()) {}
  // Room for `bits` more: call it before each row with the row's worst case.
  void reserve(size_t bits) {
    const size_t need = used_ + bits / 8 + 16;
    if (out_->size() - start_ < need) out_->resize(start_ + 2 * need);
  }
  // v < 2^bits, bits <= 32. The register holds fewer than 32 bits between calls and goes out four bytes at a
  // time (not a byte per loop).
  void put(uint32_t v, int bits) {
    acc_ = acc_ << bits | v;
    n_ += bits;
    if (n_ >= 32) {
      n_ -= 32;
      const uint32_t word = __builtin_bswap32(uint32_t(acc_ >> n_));
      std::memcpy(out_->data() + start_ + used_, &word, 4);
      used_ += 4;
    }
  }
  // Pads the last byte with zeros and trims `out` to what was written.
  void finish() {
    while (n_ >= 8) {
      n_ -= 8;
      (*out_)[start_ + used_++] = uint8_t(acc_ >> n_);
    }
    if (n_ > 0) (*out_)[start_ + used_++] = uint8_t(acc_ << (8 - n_));
    n_ = 0;
    out_->resize(start_ + used_);
  }

 private:
  std::vector<uint8_t>* out_;
  size_t start_, used_ = 0;
  uint64_t acc_ = 0;
  int n_ = 0;
};

// Reads what BitWriter wrote; past the end it reads zeros, and consumed() then exceeds the section's bits.
class BitReader {
 public:
  BitReader(const uint8_t* data, size_t size) : p_(data), end_(data + size) {}
  // At least 41 bits in the register (a code needs at most 41).
  void refill() {
    if (n_ > 40) return;
    if (end_ - p_ >= 8) {  // eight bytes at once, whole bytes counted (the rest is read again next time)
      uint64_t word;
      std::memcpy(&word, p_, 8);
      acc_ |= __builtin_bswap64(word) >> n_;
      const int bytes = (63 - n_) >> 3;
      p_ += bytes;
      n_ += 8 * bytes;
      return;
    }
    while (n_ <= 56) {
      acc_ |= uint64_t(p_ < end_ ? *p_++ : 0) << (56 - n_);
      n_ += 8;
    }
  }
  // After refill(): the next `bits` (0 to 32).
  uint32_t take(int bits) {
    if (bits == 0) return 0;
    const auto v = uint32_t(acc_ >> (64 - bits));
    acc_ <<= bits;
    n_ -= bits;
    consumed_ += uint64_t(bits);
    return v;
  }
  // After refill(): the number of zero bits before the next one (64 when the register holds none).
  int zeros() const { return acc_ == 0 ? 64 : __builtin_clzll(acc_); }
  uint64_t consumed() const { return consumed_; }

 private:
  const uint8_t* p_;
  const uint8_t* end_;
  uint64_t acc_ = 0;
  int n_ = 0;
  uint64_t consumed_ = 0;
};

// An adaptive Golomb-Rice code (LOCO-I's, Weinberger et al. 2000, docs/references.md): the parameter k follows
// the running mean of the values the context coded (A their sum, N their count, both halved when N reaches
// 4), so a context whose values are small codes them in few bits and one whose values grow adapts within a
// few values. Every field of the depth section is one such code, so a value costs a few shifts, never a
// decision per bit.
inline int bit_length(uint32_t u) { return 32 - __builtin_clz(u); }  // u > 0

struct RiceContext {
  uint32_t a = 4, n = 1;
  // The least k with n 2^k >= a, at most 17, from a's bit length (n is 1 to 3): no loop over k.
  int k() const {
    if (a <= n) return 0;
    const int bits = bit_length(a - 1);           // 2^bits >= a > 2^(bits - 1), bits >= 2 here
    int k = bits - int(n >> 1);                   // n = 1: bits; n = 2 or 3: bits - 1
    k -= int(n == 3 && (3u << (bits - 2)) >= a);  // n = 3: bits - 2 where that reaches a
    return std::min(k, 17);
  }
  void update(uint32_t v) {
    a += v;
    if (++n == 4) {
      a >>= 1;
      n = 2;
    }
  }
};

// A quotient v >> k of kRiceLimit or more is written as kRiceLimit zeros and then u = v - (kRiceLimit << k) + 1
// in Elias's gamma code (floor(log2 u) zeros, then u's bits from its leading one), so that the rare large
// value (an edge's flying pixel, a learner who moved) costs bits logarithmic in its size, not its quotient in
// unary. Values are below 2^17 (a depth step or a bin difference of a 16-bit depth, zigzagged); a code that
// says more decodes as kRiceInvalid, which every field refuses.
constexpr int kRiceLimit = 6;
constexpr uint32_t kRiceInvalid = 1u << 17;

inline int rice_bits(uint32_t v, int k) {
  const uint32_t q = v >> k;
  return q < uint32_t(kRiceLimit) ? int(q) + 1 + k : kRiceLimit + 2 * bit_length(v - (uint32_t(kRiceLimit) << k) + 1) - 1;
}

// `k`: c.k(), where the caller has it already.
inline void put_rice(BitWriter& bw, RiceContext& c, uint32_t v, int k) {
  const uint32_t q = v >> k;
  if (q < uint32_t(kRiceLimit)) {
    bw.put(1, int(q) + 1);
    if (k > 0) bw.put(v & ((1u << k) - 1), k);
  } else {
    const uint32_t u = v - (uint32_t(kRiceLimit) << k) + 1;
    const int n = bit_length(u);
    bw.put(0, kRiceLimit + n - 1);
    bw.put(u, n);
  }
  c.update(v);
}

inline void put_rice(BitWriter& bw, RiceContext& c, uint32_t v) { put_rice(bw, c, v, c.k()); }

inline uint32_t get_rice(BitReader& br, RiceContext& c) {
  br.refill();
  const int k = c.k();
  const int z = br.zeros();
  uint32_t v;
  if (z < kRiceLimit) {
    br.take(z + 1);
    v = uint32_t(z) << k | br.take(k);
  } else {
    const int n = z - kRiceLimit + 1;  // u's bits
    if (n > 18) {
      br.take(z < 32 ? z : 32);
      v = kRiceInvalid;
    } else {
      br.take(z);
      v = std::min(br.take(n) - 1 + (uint32_t(kRiceLimit) << k), kRiceInvalid);
    }
  }
  c.update(v);
  return v;
}

// The contexts both sides start every frame with (docs/network.md, "The depth section", lists them).
struct DepthContexts {
  RiceContext run[4];    // a row's runs: [2 * (0 measured, 1 holes) + the pixel above the run's start measured]
  RiceContext gap;       // delta frames: measured pixels kept before the next value
  RiceContext step[15];  // delta frames: a value as a step from the pixel's last value p (0: a bin follows),
                         // [step_context(e(p))]
  RiceContext row[2];    // a bin as the difference to the row's last depth: [0 delta frame, 1 key frame]
  RiceContext bin;       // a bin where the row has no depth before it
};

// A row codes at most w + 1 runs, and per pixel a gap, a step and a bin; each code at most 41 bits.
constexpr size_t kWorstBitsPerPixel = 4 * 41;

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

// The step's context: its size e(p) / 2 + 1 in classes 1 (e(p) <= 1: the step is in mm, near the camera where
// the bound is below the sensor's 1 mm rounding), 2 to 3, 4 to 7 … (larger steps are fewer).
inline int step_context(uint16_t p, uint16_t left, const DepthBins& b) {
  const uint16_t e = b.bound[p];
  const int size = e <= 1 ? 0 : e <= 5 ? 1 : e <= 13 ? 2 : e <= 29 ? 3 : 4;
  const int edge = left == 0 ? 2 : std::abs(int(b.bin_of[p]) - int(b.bin_of[left])) > 1 ? 1 : 0;
  return size * 3 + edge;
}

// Run i's context (it starts at x): holes or measured, and whether the pixel above its start has a depth (the
// row above, `up`; none above the first row: as if it had).
inline int run_context(int i, const uint16_t* up, int x) { return (i & 1) * 2 + int(up == nullptr || up[x] != 0); }

// A step k != 0 as the code's value: 1, 2, 3, 4 … for +1, -1, +2, -2 …; 0 says a bin follows.
inline uint32_t step_symbol(int32_t k) { return k > 0 ? uint32_t(2 * k - 1) : uint32_t(-2 * k); }
inline int32_t symbol_step(uint32_t s) { return (s & 1) ? int32_t((s + 1) / 2) : -int32_t(s / 2); }

// A delta frame's bin (a pixel without a last value, or an escape): against the bin of the row's last depth
// `left` when there is one, else the bin itself.
inline void put_bin(BitWriter& bw, DepthContexts& c, uint16_t z, uint16_t left, const DepthBins& b) {
  const int32_t bin = b.bin_of[z];
  if (left != 0)
    put_rice(bw, c.row[0], zigzag(bin - int32_t(b.bin_of[left])));
  else
    put_rice(bw, c.bin, uint32_t(bin));
}

// What put_bin() wrote, as the bin's centre; 0 when the bin is beyond the scale.
inline uint16_t get_bin(BitReader& br, DepthContexts& c, uint16_t left, const DepthBins& b) {
  const int64_t bin = left != 0 ? int64_t(b.bin_of[left]) + unzigzag(get_rice(br, c.row[0]))
                                : int64_t(get_rice(br, c.bin));
  return bin >= 1 && bin < int64_t(b.center.size()) ? b.center[size_t(bin)] : 0;
}

// The first x in [x, end) whose flag differs from `flag` (0 or 1), or end: eight flags at a time.
inline int next_other(const uint8_t* flags, int x, int end, uint8_t flag) {
  const uint64_t same = flag ? 0x0101010101010101ull : 0;
  while (x + 8 <= end) {
    uint64_t word;
    std::memcpy(&word, flags + x, 8);
    if (word != same) return x + __builtin_ctzll(word ^ same) / 8;  // little-endian: the lowest byte is flags[x]
    x += 8;
  }
  while (x < end && flags[x] == flag) ++x;
  return x;
}

// One row's measured pixels (`measured`: 1 or 0 per pixel) as runs: runs[0] measured from x = 0 (maybe
// empty), then holes, measured … each but the first at least 1 long, ending at w. Returns the number of runs.
int row_runs(const uint8_t* measured, int w, int* runs) {
  int n = 0, x = 0;
  uint8_t flag = 1;
  while (x < w) {
    const int start = x;
    x = next_other(measured, x, w, flag);
    runs[n++] = x - start;
    flag ^= 1;
  }
  return n;
}

// The encoder's per-pixel pass over a delta frame's row, without branches or table look-ups so that it is
// vectorised: moves each measured pixel's estimate of its true depth (the mean of its last measurements, a
// quarter of the way towards each new one, restarted where a measurement jumps by more than twice the bound:
// something moved) and marks the pixels that must be sent: measured, and without a last value or beyond the
// bound of it; returns how many. The bound is computed in single precision and shrunk by a millionth before it is floored, so it
// is never above e(z) (the product's rounding error is below 3 in 10^7): at worst a pixel is sent that the
// exact bound would have kept, never one kept that it would have sent (only the encoder decides this).
VCLASSROOM_SIMD_CLONES
int mark_events(const uint16_t* __restrict z, const uint16_t* __restrict mem, float scale, float* __restrict est,
                uint8_t* __restrict event, uint8_t* __restrict measured, int w) {
  int events = 0;
  for (int x = 0; x < w; ++x) {
    const float zf = float(z[x]), m = float(mem[x]), old = est[x];
    const float e = std::floor(zf * zf * scale), d = zf - old;
    const float moved = std::abs(d) > 2.0f * e + 1.0f ? zf : old + 0.25f * d;
    est[x] = zf != 0.0f ? moved : old;
    const int sent = int(zf != 0.0f) & (int(m == 0.0f) | int(std::abs(zf - m) > e));
    event[x] = uint8_t(sent);
    measured[x] = uint8_t(zf != 0.0f);
    events += sent;
  }
  return events;
}

// What one measured pixel that a delta frame sends becomes: without a last value p, its bin; else a step from
// p towards the estimate, or (0, then the bin) where no step is within the bound or the bin against the
// row's last depth `left` is shorter (where the camera or something in view moved). Returns the value the
// decoder reconstructs.
inline uint16_t put_value(BitWriter& bw, DepthContexts& c, uint16_t z, uint16_t p, float est, uint16_t left,
                          const DepthBins& b) {
  if (p != 0) {
    RiceContext& sc = c.step[step_context(p, left, b)];
    const int ks = sc.k();
    const int32_t k = delta_step(z, p, int32_t(est + 0.5f), b);  // est >= 0: rounded
    if (k != 0) {
      const uint32_t s = step_symbol(k);
      const int32_t bin = b.bin_of[z];
      const bool row_shorter = left != 0 && rice_bits(zigzag(bin - int32_t(b.bin_of[left])), c.row[0].k()) +
                                                    rice_bits(0, ks) < rice_bits(s, ks);
      if (!row_shorter) {
        put_rice(bw, sc, s, ks);
        return uint16_t(int32_t(p) + k * (int32_t(b.bound[p]) / 2 + 1));
      }
    }
    put_rice(bw, sc, 0, ks);
  }
  put_bin(bw, c, z, left, b);
  return b.center[b.bin_of[z]];
}

// A key frame's row after its runs: each measured pixel keeps the row's last depth `left` where that is within
// its bound (a bin's centre, so only a pixel of another bin is sent), else its bin is sent against left's (or
// alone at the row's first depth), with the gaps between the pixels sent as in a delta frame.
void encode_key_row(BitWriter& bw, DepthContexts& c, const uint16_t* z, uint16_t* mem, float* est, int w,
                    const DepthBins& b, const int* runs, int nruns) {
  uint16_t left = 0;
  uint32_t kept = 0;
  for (int x = 0; x < w; ++x) est[x] = float(z[x]);
  for (int i = 0, x = 0; i < nruns; x += runs[i], ++i) {
    if (i & 1) continue;  // holes
    for (int px = x; px < x + runs[i]; ++px) {
      const int32_t zi = z[px];
      if (left != 0 && std::abs(zi - int32_t(left)) <= int32_t(b.bound[zi])) {
        ++kept;
        mem[px] = left;
        continue;
      }
      put_rice(bw, c.gap, kept);
      kept = 0;
      const int32_t bin = b.bin_of[zi];
      if (left != 0)
        put_rice(bw, c.row[1], zigzag(bin - int32_t(b.bin_of[left])) - 1);  // never 0: another bin
      else
        put_rice(bw, c.bin, uint32_t(bin));
      mem[px] = left = b.center[size_t(bin)];
    }
  }
  put_rice(bw, c.gap, kept);
}

// A delta frame's row after its runs: the gaps between the measured pixels sent (`event`) and what each becomes.
void encode_delta_values(BitWriter& bw, DepthContexts& c, const uint16_t* z, uint16_t* mem, const float* est,
                         const DepthBins& b, const int* runs, int nruns, const uint8_t* event) {
  uint16_t left = 0;  // the row's last depth so far (reconstructed)
  uint32_t kept = 0;  // measured pixels kept since the last one sent
  int x = 0;
  for (int i = 0; i < nruns; x += runs[i], ++i) {
    if (i & 1) continue;  // holes
    const int end = x + runs[i];
    int px = x;
    for (;;) {
      const int next = next_other(event, px, end, 0);  // the next event: most pixels have none
      kept += uint32_t(next - px);
      if (next > x) left = mem[next - 1];
      if (next == end) break;
      put_rice(bw, c.gap, kept);
      kept = 0;
      mem[next] = left = put_value(bw, c, z[next], mem[next], est[next], left, b);
      px = next + 1;
    }
  }
  put_rice(bw, c.gap, kept);  // the row's end: a gap as long as the measured pixels left
}

// recon[x] = mem[x] where measured[x] (1), else 0: one vectorised pass, not a copy or a fill per run (the
// sensor's random holes make the runs short).
VCLASSROOM_SIMD_CLONES
void keep_measured(const uint16_t* __restrict mem, const uint8_t* __restrict measured, uint16_t* __restrict recon,
                   int w) {
  for (int x = 0; x < w; ++x) recon[x] = uint16_t(mem[x] & uint16_t(-int(measured[x])));
}

// Codes one row (docs/network.md, "The depth section"): its runs, then in a key frame every measured pixel's
// bin, in a delta frame the gaps between the measured pixels sent and what each becomes. Updates `mem` (the
// last value of each pixel) and writes the row as the decoder reconstructs it to `recon`.
void encode_row(BitWriter& bw, DepthContexts& c, bool key, const uint16_t* z, uint16_t* mem, float* est,
                const uint16_t* up, uint16_t* recon, int w, const DepthBins& b, std::vector<int>& runs,
                const uint8_t* event, uint8_t* measured) {
  if (key)
    for (int x = 0; x < w; ++x) measured[x] = uint8_t(z[x] != 0);
  const int nruns = row_runs(measured, w, runs.data());
  for (int i = 0, x = 0; i < nruns; x += runs[i], ++i)
    put_rice(bw, c.run[run_context(i, up, x)], uint32_t(runs[i] - (i > 0 ? 1 : 0)));
  if (key) {
    encode_key_row(bw, c, z, mem, est, w, b, runs.data(), nruns);
  } else {
    encode_delta_values(bw, c, z, mem, est, b, runs.data(), nruns, event);
  }
  // The row as the decoder has it: the measured pixels' last values, zeros in the holes.
  keep_measured(mem, measured, recon, w);
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
  // A delta frame's pixels to send, marked first for the whole frame: where they are most of its measured
  // pixels (the camera moved: Redwood's handheld sequence), a key frame costs less — it predicts each pixel
  // from the row, not from a memory the motion made stale — and is sent instead.
  flags_.resize(2 * size_t(w) * size_t(h));
  uint8_t* const sent = flags_.data();
  uint8_t* const measured = flags_.data() + size_t(w) * size_t(h);
  if (!key) {
    const float scale = float(tolerance) * 1e-8f * (1.0f - 1e-6f);
    size_t events = 0, pixels = size_t(cv::countNonZero(depth));
    for (int y = 0; y < h; ++y)
      events += size_t(mark_events(depth.ptr<uint16_t>(y), mem_.ptr<uint16_t>(y), scale, estimate_.ptr<float>(y),
                                   sent + size_t(y) * size_t(w), measured + size_t(y) * size_t(w), w));
    key = 2 * events > pixels;
  }
  if (key) {
    mem_ = cv::Mat::zeros(h, w, CV_16UC1);
    estimate_ = cv::Mat::zeros(h, w, CV_32FC1);
  }
  recon_.create(h, w, CV_16UC1);
  const size_t start = out->size();
  out->resize(start + kDepthLinkHeaderBytes);
  out->insert(out->end(), caps.begin(), caps.end());
  const size_t depth_start = out->size();
  // Row by row: its runs of measured pixels and holes, then the values sent (every measured pixel in a key
  // frame; in a delta frame those beyond the bound of their last value, as gaps between them).
  DepthContexts ctx;
  BitWriter bw(out);
  std::vector<int> runs(size_t(w) + 1);
  for (int y = 0; y < h; ++y) {
    bw.reserve(size_t(w) * kWorstBitsPerPixel + 64);
    encode_row(bw, ctx, key, depth.ptr<uint16_t>(y), mem_.ptr<uint16_t>(y), estimate_.ptr<float>(y),
               y > 0 ? recon_.ptr<uint16_t>(y - 1) : nullptr,
               recon_.ptr<uint16_t>(y), w, b, runs, sent + size_t(y) * size_t(w), measured + size_t(y) * size_t(w));
  }
  bw.finish();
  const size_t label_start = out->size();
  if (!label.empty()) {
    cv::Mat l = label.isContinuous() ? label : label.clone();
    deflate_into(l.data, l.total(), zlib_level, out);
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
  if (data[4] != kVersion) return "depth frame version " + std::to_string(data[4]) + " (this reads 3)";
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
  // Every row codes at least two codes of at least a bit each (its runs and its final gap; a key frame's
  // measured pixel at least a bit more): a shorter section cannot hold the declared rows.
  if (hd->depth_len < (uint64_t(hd->h) + 3) / 4) return "depth section too short for its image";
  if (depth_frame_crc(data, size) != read_le32(data + 28)) return "depth frame checksum";
  return "";
}

}  // namespace

std::string check_depth_frame(const uint8_t* data, size_t size, const DepthLinkLimits& limits,
                              DepthLinkHeader* header) {
  Header hd;
  const std::string bad = parse_header(data, size, limits, &hd);
  if (!bad.empty()) return bad;
  header->number = hd.number;
  header->key = hd.flags & kFlagKey;
  header->labels = hd.flags & kFlagLabels;
  header->tolerance = hd.tolerance;
  header->width = hd.w;
  header->height = hd.h;
  header->caps.assign(reinterpret_cast<const char*>(data + kDepthLinkHeaderBytes), size_t(hd.caps_len));
  return "";
}

namespace {

// The zeros in a row (vectorised: the decoder's one pass over every pixel).
VCLASSROOM_SIMD_CLONES
int count_zeros(const uint16_t* v, int w) {
  int n = 0;
  for (int x = 0; x < w; ++x) n += v[x] == 0;
  return n;
}

// Decodes one row that encode_row() coded into `out`, updating `mem`; "" or why not. `runs` and `starts` hold
// at least w + 1 entries.
std::string decode_row(BitReader& br, DepthContexts& c, bool key, uint16_t* mem, const uint16_t* up, uint16_t* out, int w,
                       const DepthBins& b, std::vector<int>& runs, std::vector<int>& starts) {
  int nruns = 0, x = 0, measured = 0;
  while (x < w || nruns == 0) {
    const uint32_t r = get_rice(br, c.run[run_context(nruns, up, x)]) + (nruns > 0 ? 1 : 0);
    if (r > uint32_t(w - x)) return "depth section's runs pass the row's end";
    starts[size_t(nruns)] = x;
    runs[size_t(nruns)] = int(r);
    if ((nruns & 1) == 0) measured += int(r);
    x += int(r);
    ++nruns;
  }
  // The measured pixel before the one at x in run i (even), or -1: what "the row's last depth" refers to.
  auto before = [&](int i, int px) {
    if (px > starts[size_t(i)]) return px - 1;
    return i >= 2 && runs[size_t(i - 2)] > 0 ? starts[size_t(i - 2)] + runs[size_t(i - 2)] - 1 : -1;
  };
  // The gaps: kept pixels are skipped run by run, so a row costs its events and its runs, not its pixels (in a
  // key frame they take the row's last depth, a fill).
  uint32_t remaining = uint32_t(measured);  // measured pixels from the cursor (run i, pixel px) on
  int i = 0, px = 0;
  uint16_t key_left = 0;  // key frames: the row's last depth
  auto settle = [&] {  // the cursor off the end of a run, onto the next measured run if there is one
    while (px == starts[size_t(i)] + runs[size_t(i)] && i + 2 < nruns) {
      i += 2;
      px = starts[size_t(i)];
    }
  };
  settle();
  for (;;) {
    const uint32_t g = get_rice(br, c.gap);
    if (g > remaining) return "depth section's gap passes the row's measured pixels";
    if (key && g > 0 && key_left == 0) return "depth section keeps a key frame's depth that has none before it";
    for (uint32_t n = g; n > 0; settle()) {  // n <= the measured pixels from px on
      const uint32_t t = std::min(n, uint32_t(starts[size_t(i)] + runs[size_t(i)] - px));
      if (key) std::fill(mem + px, mem + px + t, key_left);
      px += int(t);
      n -= t;
    }
    if (g == remaining) break;
    remaining -= g + 1;
    uint16_t v;
    if (key) {
      const int64_t bin = key_left != 0 ? int64_t(b.bin_of[key_left]) + unzigzag(get_rice(br, c.row[1]) + 1)
                                        : int64_t(get_rice(br, c.bin));
      v = bin >= 1 && bin < int64_t(b.center.size()) ? b.center[size_t(bin)] : 0;
      key_left = v;
    } else {
      const int prev = before(i, px);
      const uint16_t left = prev >= 0 ? mem[prev] : 0;
      const uint16_t p = mem[px];
      const uint32_t s = p != 0 ? get_rice(br, c.step[step_context(p, left, b)]) : 0;
      if (s != 0) {
        const int64_t nv = int64_t(p) + int64_t(symbol_step(s)) * (int64_t(b.bound[p]) / 2 + 1);
        v = nv >= 1 && nv <= 65535 ? uint16_t(nv) : 0;
      } else {
        v = get_bin(br, c, left, b);
      }
    }
    if (v == 0) return "depth section names a depth beyond the scale";
    mem[px] = v;
    ++px;
    settle();
  }
  // The row: its measured pixels' last values, zeros in its holes; a measured pixel that never had a value
  // (a delta frame that sent no value for it) makes the frame invalid: then the row has more zeros than holes.
  int holes = 0;
  for (int j = 0; j < nruns; ++j) {
    const size_t n = size_t(runs[size_t(j)]);
    if (j & 1) {
      std::memset(out + starts[size_t(j)], 0, n * 2);
      holes += int(n);
    } else {
      std::memcpy(out + starts[size_t(j)], mem + starts[size_t(j)], n * 2);
    }
  }
  return count_zeros(out, w) == holes ? "" : "depth section leaves a measured pixel without a value";
}

// Decodes the depth section into `depth`, updating `mem` (the state of encode()); "" or why not.
std::string decode_pixels(const uint8_t* data, size_t size, bool key, const DepthBins& b, cv::Mat* depth,
                          cv::Mat* mem) {
  const int w = depth->cols, h = depth->rows;
  DepthContexts ctx;
  BitReader br(data, size);
  std::vector<int> runs(size_t(w) + 1), starts(size_t(w) + 1);
  const uint64_t bits = uint64_t(size) * 8;
  for (int y = 0; y < h; ++y) {
    const std::string why = decode_row(br, ctx, key, mem->ptr<uint16_t>(y), y > 0 ? depth->ptr<uint16_t>(y - 1) : nullptr,
                                       depth->ptr<uint16_t>(y), w, b, runs,
                                       starts);
    if (!why.empty()) return why;
    if (br.consumed() > bits) return "depth section cut short";
  }
  // The last byte's unused bits are zeros, and nothing follows it.
  if ((br.consumed() + 7) / 8 != size) return "depth section longer than its image";
  br.refill();
  if (br.take(int((8 - br.consumed() % 8) % 8)) != 0) return "depth section's padding is not zero";
  return "";
}

}  // namespace

bool DepthLinkDecoder::decode(const uint8_t* data, size_t size, DepthLinkFrame* frame, std::string* error) {
  return decode_frame(data, size, frame, error);
}

bool DepthLinkDecoder::decode_frame(const uint8_t* data, size_t size, DepthLinkFrame* frame, std::string* error) {
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
  }
  cv::Mat depth;
  if (frame) {
    depth.create(h, w, CV_16UC1);
  } else {
    scratch_.create(h, w, CV_16UC1);
    depth = scratch_;
  }
  const std::string why = decode_pixels(p + hd.caps_len, hd.depth_len, key, bins_for(hd.tolerance), &depth, &mem_);
  if (!why.empty()) return fail(why);
  cv::Mat label;
  if (frame && hd.label_len > 0) {
    std::vector<uint8_t> l;
    if (!inflate_bounded(p + hd.caps_len + hd.depth_len, hd.label_len, pixels, &l) || l.size() != pixels)
      return fail("label section does not inflate to the image");
    label = cv::Mat(h, w, CV_8UC1);
    std::memcpy(label.data, l.data(), pixels);
  }
  if (frame) {
    frame->depth = depth;
    frame->label = label;
    frame->caps.assign(reinterpret_cast<const char*>(p), hd.caps_len);
    frame->number = hd.number;
    frame->key = key;
    frame->tolerance = hd.tolerance;
  }
  size_ = cv::Size(w, h);
  tolerance_ = hd.tolerance;
  number_ = hd.number;
  have_ref_ = true;
  return true;
}

}  // namespace vclassroom
