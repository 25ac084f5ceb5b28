// An adaptive binary range coder (the camera link's depth, docs/network.md "The depth frame"): each bit is
// coded with a probability that its context learns as it goes, so a bit that is nearly always the same costs
// a small fraction of a bit. 32-bit range, 12-bit probabilities moving 1/32 of the way towards each bit
// coded; the carry is propagated through a one-byte cache (the first byte written is always 0).
// Written for this project; header-only so the per-pixel loops inline it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vclassroom {

// A context's probability that the next bit is 0, in 1/4096.
struct BitModel {
  uint16_t p0 = 2048;
};

inline constexpr int kRangeProbBits = 12;
inline constexpr int kRangeAdapt = 5;
inline constexpr uint32_t kRangeTop = 1u << 24;

class RangeEncoder {
 public:
  // Appends to `out`. The bytes go through a raw pointer into room reserve() made, so that the coder's state
  // can stay in registers (a vector's push_back, which may reallocate, would make it spill at every bit).
  explicit RangeEncoder(std::vector<uint8_t>* out) : out_(out), start_(out->size()), p_(out->data() + start_) {}

  // Makes room for `bytes` more (at most 8 bits of output per 7 coded bits, plus the carry's pending bytes,
  // which reserve() counts): call it before coding each row, with the row's worst case.
  void reserve(size_t bytes) {
    const size_t used = size_t(p_ - base());
    if (out_->size() - start_ - used >= bytes + pending_ + 8) return;
    out_->resize(start_ + used + 2 * (bytes + pending_ + 8) + (out_->size() - start_));
    p_ = base() + used;
  }

  void put(BitModel& m, bool bit) {
    const uint32_t bound = (range_ >> kRangeProbBits) * m.p0;
    if (!bit) {
      range_ = bound;
      m.p0 = uint16_t(m.p0 + (((1u << kRangeProbBits) - m.p0) >> kRangeAdapt));
    } else {
      low_ += bound;
      range_ -= bound;
      m.p0 = uint16_t(m.p0 - (m.p0 >> kRangeAdapt));
    }
    while (range_ < kRangeTop) {
      range_ <<= 8;
      shift_low();
    }
  }
  // Ends the stream (afterwards the decoder has every byte it needs) and trims `out` to what was written.
  void finish() {
    reserve(8);
    for (int i = 0; i < 5; ++i) shift_low();
    out_->resize(size_t(p_ - out_->data()));
  }

 private:
  uint8_t* base() { return out_->data() + start_; }
  void shift_low() {
    if (uint32_t(low_) < 0xFF000000u || (low_ >> 32) != 0) {
      const auto carry = uint8_t(low_ >> 32);
      uint8_t byte = cache_;
      do {
        *p_++ = uint8_t(byte + carry);
        byte = 0xFF;
      } while (--pending_ != 0);
      cache_ = uint8_t(low_ >> 24);
    }
    ++pending_;
    low_ = (low_ & 0x00FFFFFFu) << 8;
  }

  std::vector<uint8_t>* out_;
  size_t start_;
  uint8_t* p_;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t pending_ = 1;
};

// Reads what RangeEncoder wrote. Never reads outside [data, data + size): past the end it reads zeros and
// counts them (overrun() > 0: the stream was cut short).
class RangeDecoder {
 public:
  RangeDecoder(const uint8_t* data, size_t size) : p_(data), end_(data + size) {
    for (int i = 0; i < 5; ++i) code_ = (code_ << 8) | next();
  }

  bool get(BitModel& m) {
    const uint32_t bound = (range_ >> kRangeProbBits) * m.p0;
    bool bit;
    if (code_ < bound) {
      range_ = bound;
      m.p0 = uint16_t(m.p0 + (((1u << kRangeProbBits) - m.p0) >> kRangeAdapt));
      bit = false;
    } else {
      code_ -= bound;
      range_ -= bound;
      m.p0 = uint16_t(m.p0 - (m.p0 >> kRangeAdapt));
      bit = true;
    }
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = (code_ << 8) | next();
    }
    return bit;
  }
  size_t overrun() const { return overrun_; }
  size_t left() const { return size_t(end_ - p_); }

 private:
  uint32_t next() {
    if (p_ < end_) return *p_++;
    ++overrun_;
    return 0;
  }

  const uint8_t* p_;
  const uint8_t* end_;
  uint32_t range_ = 0xFFFFFFFFu, code_ = 0;
  size_t overrun_ = 0;
};

}  // namespace vclassroom
