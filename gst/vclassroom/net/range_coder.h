// An adaptive binary range coder (the camera link's depth, docs/network.md "The depth frame"): each bit is
// coded with a probability that its context learns as it goes, so a bit that is nearly always the same costs
// a small fraction of a bit. 32-bit range, 12-bit probabilities moving 1/32 of the way towards each bit
// coded (range coding: G. N. N. Martin 1979, docs/references.md). The bytes are written to memory as they
// leave the low end of the interval, so a carry out of it is added to the bytes already written (the run of
// 0xFF bytes before it turns to 0 and the byte before them takes the 1); a leading 0 byte stops every
// such run. Header-only so the per-pixel loops inline it.
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
  explicit RangeEncoder(std::vector<uint8_t>* out) : out_(out), start_(out->size()), p_(nullptr) {
    out_->resize(start_ + 64);
    p_ = base();
    *p_++ = 0;  // the leading byte: a carry never reaches it, and stops at it
  }

  // Makes room for `bytes` more (a coded bit writes at most one byte): call it before coding each row, with
  // the row's worst case.
  void reserve(size_t bytes) {
    const size_t used = size_t(p_ - base());
    if (out_->size() - start_ - used >= bytes + 8) return;
    out_->resize(start_ + used + 2 * (bytes + 8) + (out_->size() - start_));
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
    for (int i = 0; i < 4; ++i) shift_low();  // the four bytes of the interval's low end
    out_->resize(size_t(p_ - out_->data()));
  }

 private:
  uint8_t* base() { return out_->data() + start_; }
  // The interval's top byte out; first the carry, if the low end passed 2^32, into what was written.
  void shift_low() {
    if (low_ >> 32) {
      uint8_t* q = p_;
      while (*--q == 0xFF) *q = 0;
      ++*q;
    }
    *p_++ = uint8_t(low_ >> 24);
    low_ = (low_ & 0x00FFFFFFu) << 8;
  }

  std::vector<uint8_t>* out_;
  size_t start_;
  uint8_t* p_;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
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
