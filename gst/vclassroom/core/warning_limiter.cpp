#include <gst/vclassroom/core/warning_limiter.h>

#include <sstream>

namespace vclassroom {

bool WarningLimiter::note(int64_t now_ns, uint64_t* count, int64_t* span_ns) {
  ++total_;
  ++pending_;
  if (posted_ && now_ns - last_post_ns_ < interval_ns_) return false;
  *count = pending_;
  *span_ns = posted_ ? now_ns - last_post_ns_ : 0;
  posted_ = true;
  last_post_ns_ = now_ns;
  pending_ = 0;
  return true;
}

uint64_t WarningLimiter::take_pending() {
  const uint64_t n = pending_;
  pending_ = 0;
  return n;
}

std::string describe_occurrences(uint64_t count, const std::string& singular, const std::string& plural,
                                 const std::string& source, int64_t span_ns) {
  std::ostringstream os;
  if (count == 1)
    os << singular;
  else
    os << count << ' ' << plural;
  if (!source.empty()) os << " from " << source;
  if (span_ns > 0) {
    const double s = static_cast<double>(span_ns) / 1e9;
    os.precision(s < 10 ? 2 : 3);
    os << " in the last " << s << " s";
  }
  return os.str();
}

}  // namespace vclassroom
