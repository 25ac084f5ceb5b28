#include <gst/vclassroom/webrtc/loss_rate.h>

#include <algorithm>
#include <cmath>

namespace vclassroom {

LossBasedRate::LossBasedRate(const LossRateParams& params)
    : params_{std::max(1, params.max_kbit), std::clamp(params.min_kbit, 1, std::max(1, params.max_kbit))},
      rate_kbit_(params_.max_kbit) {}

int LossBasedRate::on_report(double fraction_lost) {
  if (!std::isfinite(fraction_lost) || fraction_lost < 0 || fraction_lost > 1) return kbit();
  if (fraction_lost > 0.10) rate_kbit_ *= 1 - 0.5 * fraction_lost;
  else if (fraction_lost < 0.02) rate_kbit_ *= 1.05;
  rate_kbit_ = std::clamp(rate_kbit_, double(params_.min_kbit), double(params_.max_kbit));
  return kbit();
}

double link_loss(double reported, uint64_t nacked, uint64_t sent) {
  if (sent == 0) return reported;
  return std::max(reported, std::min(1.0, double(nacked) / double(sent)));
}

bool RetransmitBudget::admit(size_t bytes, int64_t now_ns, int kbit) {
  const double per_second = share_ * double(kbit > 0 ? kbit : 0) * 1000.0 / 8.0, depth = per_second / 2;
  if (last_ns_ < 0 || now_ns < last_ns_) tokens_ = depth;
  else tokens_ = std::min(depth, tokens_ + per_second * double(now_ns - last_ns_) / 1e9);
  last_ns_ = now_ns;
  if (double(bytes) > tokens_) return false;
  tokens_ -= double(bytes);
  return true;
}

}  // namespace vclassroom
