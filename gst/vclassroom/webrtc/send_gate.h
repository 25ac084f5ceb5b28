// What a lecturer's send queue lets through when it is full. An encoded frame
// cannot simply be dropped: every frame after it, up to the next key frame,
// refers to it, and a browser shows them as smears or freezes and asks for a
// key frame, which is the largest burst of all (docs/lecturer.md). So once a
// frame is dropped, the rest of its group of pictures is dropped too, a key
// frame is asked for once, and sending resumes with it: the decoder never sees
// a frame whose reference is missing, and one slow lecturer never stalls the
// encoder the others share.
#pragma once

#include <cstdint>

namespace vclassroom {

class GopSendGate {
 public:
  // One encoded frame: `key_frame` when it decodes alone, `queue_full` when there is no room for it now.
  // True: send it; false: drop it.
  bool admit(bool key_frame, bool queue_full);
  // True once when a run of drops begins, and once more when the queue has room again after the key frame
  // asked for was dropped too (a lecturer whose link is not up yet): ask the encoder for a key frame now.
  bool take_key_frame_request();
  bool waiting_for_key_frame() const { return waiting_; }
  uint64_t dropped() const { return dropped_; }

 private:
  bool waiting_ = false;
  bool request_ = false;
  bool key_frame_lost_ = false;
  uint64_t dropped_ = 0;
};

}  // namespace vclassroom
