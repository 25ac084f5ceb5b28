// Rate-limited warnings: a source that goes bad (a damaged link, a flooding
// sender) must not bury the bus under one message per packet, yet the first
// problem of each kind must always be seen and none may go uncounted.
#pragma once

#include <cstdint>
#include <string>

namespace vclassroom {

// Decides when a warning about one kind of problem from one source is posted:
// the first occurrence at once, then at most one message per interval, each
// carrying how many occurred since the previous message. Times are the
// caller's monotonic clock in nanoseconds (GStreamer-free, and tests can pass
// their own times instead of sleeping). Not thread-safe: callers lock.
class WarningLimiter {
 public:
  static constexpr int64_t kDefaultIntervalNs = 5'000'000'000;

  explicit WarningLimiter(int64_t interval_ns = kDefaultIntervalNs) : interval_ns_(interval_ns) {}

  // Records one occurrence at now_ns. True when a message is due now; then
  // *count holds the occurrences it reports (this one included) and
  // *span_ns the time they span (0 for the first message).
  bool note(int64_t now_ns, uint64_t* count, int64_t* span_ns);
  // Occurrences not yet reported; a source that falls silent after a burst
  // reports them through this (e.g. at end of stream).
  uint64_t pending() const { return pending_; }
  // Takes the pending count (for a final message), as note() would.
  uint64_t take_pending();
  uint64_t total() const { return total_; }
  void reset() { *this = WarningLimiter(interval_ns_); }

 private:
  int64_t interval_ns_;
  bool posted_ = false;
  int64_t last_post_ns_ = 0;
  uint64_t pending_ = 0;
  uint64_t total_ = 0;
};

// "37 damaged frames from camera 2 in the last 5 s": what (plural noun
// phrase), count, source, span. The first message reads "a damaged frame
// from camera 2" when count is 1.
std::string describe_occurrences(uint64_t count, const std::string& singular, const std::string& plural,
                                 const std::string& source, int64_t span_ns);

}  // namespace vclassroom
