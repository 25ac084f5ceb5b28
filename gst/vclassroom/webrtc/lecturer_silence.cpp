#include <gst/vclassroom/webrtc/lecturer_silence.h>

namespace vclassroom {

LecturerSilence::LecturerSilence(int64_t timeout_ns, uint64_t min_frames)
    : timeout_ns_(timeout_ns), min_frames_(min_frames) {}

void LecturerSilence::start(int64_t now_ns) {
  last_report_ns_ = now_ns;
  frames_since_report_ = 0;
}

void LecturerSilence::on_report(int64_t now_ns) { start(now_ns); }

bool LecturerSilence::gone(int64_t now_ns) const {
  return timeout_ns_ > 0 && silent_ns(now_ns) >= timeout_ns_ && frames_since_report_ >= min_frames_;
}

}  // namespace vclassroom
