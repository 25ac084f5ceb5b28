#include <gst/vclassroom/net/depth_link_backlog.h>

#include <utility>

namespace vclassroom {

bool DepthLinkBacklog::push(const uint8_t* data, size_t size, DepthLinkHeader* header, uint64_t* id,
                            std::string* why) {
  const std::string bad = check(data, size, header);
  if (!bad.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    chain_ = false;
    if (why) *why = bad;
    return false;
  }
  return push_checked(std::vector<uint8_t>(data, data + size), *header, id, why);
}

bool DepthLinkBacklog::push_checked(std::vector<uint8_t> frame, const DepthLinkHeader& hd, uint64_t* id,
                                    std::string* why) {
  const size_t size = frame.size();
  std::string bad;
  if (size > backlog_.max_bytes) bad = "depth frame larger than the backlog holds";
  std::lock_guard<std::mutex> lock(mutex_);
  if (bad.empty() && !hd.key &&
      !(chain_ && hd.number == last_.number + 1 && hd.tolerance == last_.tolerance && hd.width == last_.width &&
        hd.height == last_.height))
    bad = "delta depth frame " + std::to_string(hd.number) + " without the frame before it (waiting for a key frame)";
  if (!bad.empty()) {
    chain_ = false;
    if (why) *why = bad;
    return false;
  }
  while (!queue_.empty() && (queue_.size() >= backlog_.max_frames || queued_bytes_ + size > backlog_.max_bytes)) {
    queued_bytes_ -= queue_.front().data.size();
    queue_.pop_front();
  }
  *id = next_id_++;
  queue_.push_back(Queued{*id, hd.key, std::move(frame)});
  queued_bytes_ += size;
  chain_ = true;
  last_ = hd;
  return true;
}

bool DepthLinkBacklog::take(uint64_t id, DepthLinkFrame* frame, std::string* why) {
  std::vector<Queued> run;  // from the last key frame at or before the wanted one (or the oldest) to it
  {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t wanted = 0;
    while (wanted < queue_.size() && queue_[wanted].id != id) ++wanted;
    if (wanted == queue_.size()) {
      if (why) *why = "depth frame #" + std::to_string(id) + " of the backlog is not queued (refused or dropped)";
      return false;
    }
    size_t start = wanted;
    while (start > 0 && !queue_[start].key) --start;
    for (size_t i = start; i <= wanted; ++i) run.push_back(std::move(queue_[i]));
    for (size_t i = 0; i <= wanted; ++i) {
      queued_bytes_ -= i < start ? queue_.front().data.size() : run[i - start].data.size();
      queue_.pop_front();
    }
  }
  std::lock_guard<std::mutex> decoding(decode_mutex_);
  for (size_t i = 0; i + 1 < run.size(); ++i) decoder_.skip(run[i].data.data(), run[i].data.size(), nullptr);
  return decoder_.decode(run.back().data.data(), run.back().data.size(), frame, why);
}

void DepthLinkBacklog::reset() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
    queued_bytes_ = 0;
    chain_ = false;
  }
  std::lock_guard<std::mutex> decoding(decode_mutex_);
  decoder_.reset();
}

size_t DepthLinkBacklog::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

}  // namespace vclassroom
