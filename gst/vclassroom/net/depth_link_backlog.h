// The server's depth frames between the access unit that brought them and the picture that uses them
// (docs/network.md, "Decoding the depth where the picture is used"). Depth is coded across time, so every
// frame must be decoded in order; but on a server with fewer cores than work most pictures are dropped
// before anything uses them (the newest-frame-only queue before the camera's processing). Decoding every
// depth frame as it arrives, at the priority of the thread that receives the link, takes that CPU from the
// lecturers' views. So the receiving thread only checks each frame (header, sizes, checksum: cheap) and
// queues it here, and the thread that takes a picture decodes the queued frames up to that picture's,
// in order, at its own (low) priority. A key frame queued before the wanted one lets the frames before it go
// undecoded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/net/depth_link.h>

namespace vclassroom {

struct DepthLinkBacklogLimits {
  size_t max_frames = 90;            // 3 s at 30 fps: the low-priority thread may starve that long
  size_t max_bytes = size_t(64) << 20;  // all queued frames together
};

class DepthLinkBacklog {
 public:
  explicit DepthLinkBacklog(DepthLinkLimits limits = {}, DepthLinkBacklogLimits backlog = {})
      : limits_(limits), backlog_(backlog), decoder_(limits) {}

  // Any thread. Checks the frame (check_depth_frame) and that it continues the frames pushed before it (a key
  // frame, or a delta frame with the next number, the same size and tolerance), and queues a copy under `id`,
  // the backlog's own count of the frames it queued (a camera that restarts numbers its frames from 0 again:
  // the wire's numbers may repeat, the ids never do); the oldest frames go when the limits are passed (their
  // successors then wait for a key frame). False with a reason when refused; after a refusal delta frames
  // are refused until the next key frame.
  bool push(const uint8_t* data, size_t size, DepthLinkHeader* header, uint64_t* id, std::string* why);
  // check_depth_frame() under the backlog's limits: "" and the header, or why the frame is refused. A caller
  // that must look at the header before it queues (its caps) checks here, then calls push_checked().
  std::string check(const uint8_t* data, size_t size, DepthLinkHeader* header) const {
    return check_depth_frame(data, size, limits_, header);
  }
  // The same as push() for a frame that check() accepted with `header` (not checked again): its bytes are
  // taken, not copied.
  bool push_checked(std::vector<uint8_t> frame, const DepthLinkHeader& header, uint64_t* id, std::string* why);

  // One thread at a time. Decodes the queued frames before and including the one queued under `id`, in order
  // (from the last key frame among them), removes them from the queue and returns that frame. False with a
  // reason when it is not queued (refused, or dropped for the limits) or does not decode.
  bool take(uint64_t id, DepthLinkFrame* frame, std::string* why);

  // Forgets every queued frame and the decoder's state (a flush, a restart).
  void reset();

  size_t queued() const;

 private:
  struct Queued {
    uint64_t id;
    bool key;
    std::vector<uint8_t> data;
  };
  const DepthLinkLimits limits_;
  const DepthLinkBacklogLimits backlog_;
  mutable std::mutex mutex_;
  std::deque<Queued> queue_;  // in the order pushed
  size_t queued_bytes_ = 0;
  uint64_t next_id_ = 0;
  bool chain_ = false;  // the last frame pushed was queued: a delta frame may follow it
  DepthLinkHeader last_;
  std::mutex decode_mutex_;  // held by take(): the decoder's state is take's alone
  DepthLinkDecoder decoder_;
};

}  // namespace vclassroom
