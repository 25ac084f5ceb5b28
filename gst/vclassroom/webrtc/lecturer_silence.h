// Whether a lecturer's browser is still there (docs/lecturer.md, "A lecturer
// who vanishes"). A browser that receives the video sends receiver reports
// (RTCP) about once a second. A session whose browser sent none for the
// timeout while the server kept sending - at least min_frames frames offered
// since the last report, so a view that stalled or has not started does not
// count against its lecturer - has lost its lecturer: a closed laptop, a
// dropped network, a tab killed without the page's DELETE, a peer that never
// finished its handshake. The endpoint then ends the session, which frees its
// place under the session cap and, with whepviewsink, its view.
#pragma once

#include <cstdint>

namespace vclassroom {

class LecturerSilence {
 public:
  // timeout_ns <= 0: never gone.
  explicit LecturerSilence(int64_t timeout_ns, uint64_t min_frames = 30);
  // The session started at now_ns (before any report).
  void start(int64_t now_ns);
  // A receiver report not seen before.
  void on_report(int64_t now_ns);
  // A frame offered to the session.
  void on_frame() { ++frames_since_report_; }
  bool gone(int64_t now_ns) const;
  // How long no report came, as of now_ns.
  int64_t silent_ns(int64_t now_ns) const { return now_ns - last_report_ns_; }

 private:
  int64_t timeout_ns_;
  uint64_t min_frames_;
  int64_t last_report_ns_ = 0;
  uint64_t frames_since_report_ = 0;
};

}  // namespace vclassroom
