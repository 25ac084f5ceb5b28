// A lecturer's bitrate from the losses their browser reports (docs/lecturer.md,
// "Bitrate"). GStreamer 1.22's webrtcbin has no congestion controller, but it
// hands over the receiver reports: this is the loss-based half of Google
// congestion control (draft-ietf-rmcat-gcc-02, section 6). Over 10 % lost, the
// rate falls by half the loss; under 2 %, it grows by 5 % per report; in
// between it holds. The link is then used up to where it starts losing, and a
// lecturer behind a slow link gets fewer bits instead of a broken picture.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vclassroom {

struct LossRateParams {
  int max_kbit = 4000;  // where it starts, and never above (the element's bitrate)
  int min_kbit = 250;   // never below
};

class LossBasedRate {
 public:
  explicit LossBasedRate(const LossRateParams& params = LossRateParams());
  // One receiver report: the share of the packets lost since the previous one
  // (0..1; anything else is ignored). Returns the new rate.
  int on_report(double fraction_lost);
  int kbit() const { return int(rate_kbit_ + 0.5); }

 private:
  LossRateParams params_;
  double rate_kbit_;
};

// The link's loss over one receiver report's interval: the report's share lost, or the share of the packets
// sent (`sent`) that the browser asked for again (`nacked`) where that is larger: a report counts a resent
// packet as received, though the link lost it. Out of range values are clamped (no packets sent: the report).
double link_loss(double reported, uint64_t nacked, uint64_t sent);

// The retransmissions' share of a lecturer's link: a token bucket that lets resent packets take at most
// `share` of the current rate (at most half a second's worth at once). Behind a congested link every loss
// is asked for again, and resending all of it would add to the congestion that lost it.
class RetransmitBudget {
 public:
  explicit RetransmitBudget(double share = 0.15) : share_(share) {}
  // Whether a resent packet of `bytes` may go at `now_ns` (monotonic) with the link's rate `kbit`.
  bool admit(size_t bytes, int64_t now_ns, int kbit);

 private:
  double share_;
  double tokens_ = 0;  // bytes
  int64_t last_ns_ = -1;
};

}  // namespace vclassroom
