// A consumer RGB-D camera's colour and depth nodes stream on their own: each
// colour frame must be paired with the depth frame taken at the same moment
// (by the kernel's capture time), never with a neighbour. GStreamer-free.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

namespace vclassroom {

// Pairs frames whose capture times differ by at most `max_skew_ns`. Frames
// arrive in capture order per stream; a frame that cannot have a partner any
// more (the other stream has moved past it by more than the skew) is dropped
// and counted. With max_skew below half the frame interval a frame has at most
// one candidate, so no pair is ever a mismatch. The caller keeps the frames;
// the pairer deals in their ids.
class FramePairer {
 public:
  explicit FramePairer(int64_t max_skew_ns) : max_skew_ns_(max_skew_ns) {}

  struct Pair {
    uint64_t color_id, depth_id;
    int64_t color_time_ns, depth_time_ns;
  };

  void push_color(uint64_t id, int64_t time_ns) { color_.push_back({id, time_ns}); }
  void push_depth(uint64_t id, int64_t time_ns) { depth_.push_back({id, time_ns}); }

  // The next pair, if one is complete. Dropped frames' ids go to
  // *dropped_color / *dropped_depth (optional) so the caller can free them.
  std::optional<Pair> pop(std::deque<uint64_t>* dropped_color = nullptr, std::deque<uint64_t>* dropped_depth = nullptr);

  uint64_t unpaired_color() const { return unpaired_color_; }
  uint64_t unpaired_depth() const { return unpaired_depth_; }
  size_t waiting() const { return color_.size() + depth_.size(); }
  // Forgets everything waiting (a stream restarted); returns nothing.
  void clear(std::deque<uint64_t>* dropped_color = nullptr, std::deque<uint64_t>* dropped_depth = nullptr);

 private:
  struct Frame {
    uint64_t id;
    int64_t time_ns;
  };
  int64_t max_skew_ns_;
  std::deque<Frame> color_, depth_;
  uint64_t unpaired_color_ = 0, unpaired_depth_ = 0;
};

}  // namespace vclassroom
