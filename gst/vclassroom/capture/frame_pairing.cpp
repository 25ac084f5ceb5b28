#include <gst/vclassroom/capture/frame_pairing.h>

namespace vclassroom {

std::optional<FramePairer::Pair> FramePairer::pop(std::deque<uint64_t>* dropped_color,
                                                  std::deque<uint64_t>* dropped_depth) {
  while (!color_.empty() && !depth_.empty()) {
    const Frame c = color_.front(), d = depth_.front();
    if (c.time_ns < d.time_ns - max_skew_ns_) {
      // No later depth frame can be nearer: this colour frame has no partner.
      color_.pop_front();
      ++unpaired_color_;
      if (dropped_color) dropped_color->push_back(c.id);
    } else if (d.time_ns < c.time_ns - max_skew_ns_) {
      depth_.pop_front();
      ++unpaired_depth_;
      if (dropped_depth) dropped_depth->push_back(d.id);
    } else {
      color_.pop_front();
      depth_.pop_front();
      return Pair{c.id, d.id, c.time_ns, d.time_ns};
    }
  }
  return std::nullopt;
}

void FramePairer::clear(std::deque<uint64_t>* dropped_color, std::deque<uint64_t>* dropped_depth) {
  for (const Frame& f : color_)
    if (dropped_color) dropped_color->push_back(f.id);
  for (const Frame& f : depth_)
    if (dropped_depth) dropped_depth->push_back(f.id);
  color_.clear();
  depth_.clear();
}

}  // namespace vclassroom
