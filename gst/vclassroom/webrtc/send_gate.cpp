#include "send_gate.h"

namespace vclassroom {

bool GopSendGate::admit(bool key_frame, bool queue_full) {
  if (!queue_full && (key_frame || !waiting_)) {
    waiting_ = key_frame_lost_ = false;
    return true;
  }
  if (!waiting_) {  // a run of drops begins: ask for a key frame
    waiting_ = true;
    request_ = true;
  } else if (key_frame) {  // the key frame asked for found no room either
    key_frame_lost_ = true;
  } else if (!queue_full && key_frame_lost_) {  // room again: ask once more rather than wait for the next GOP
    request_ = true;
    key_frame_lost_ = false;
  }
  ++dropped_;
  return false;
}

bool GopSendGate::take_key_frame_request() {
  const bool r = request_;
  request_ = false;
  return r;
}

}  // namespace vclassroom
