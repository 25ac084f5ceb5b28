// Which cameras of a live fusion are missing: a camera silent for longer than
// a timeout is lost until its next frame, and the lecturer's picture says so
// (a banner drawn into the frame). GStreamer-free; times are the caller's
// monotonic clock in nanoseconds, so tests pass their own.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

class CameraLiveness {
 public:
  // timeout_ns 0: cameras are never declared lost.
  explicit CameraLiveness(int64_t timeout_ns = 1'000'000'000) : timeout_ns_(timeout_ns) {}
  void set_timeout(int64_t timeout_ns) { timeout_ns_ = timeout_ns; }
  int64_t timeout() const { return timeout_ns_; }

  // A frame of camera `id` arrived at now_ns. True when the camera was lost
  // and is back (its return is to be reported).
  bool seen(int id, int64_t now_ns);
  // Camera `id` is configured (the fuse has its pad) and is watched from
  // now_ns if it is not yet: a camera silent from the start is then lost after
  // the timeout like one that stopped, instead of never being missed.
  void expect(int id, int64_t now_ns);
  // True when camera `id` has sent a frame since it was first known.
  bool ever_seen(int id) const;
  // Cameras that became lost by now_ns (silent for more than the timeout
  // since their last frame); each is reported once, until it returns.
  std::vector<int> newly_lost(int64_t now_ns);
  // How long camera `id` has been silent at now_ns (0 for an unknown one).
  int64_t silent_for(int id, int64_t now_ns) const;
  // The cameras lost now, in increasing id.
  std::vector<int> missing() const;
  // True when cameras are known and every one of them is lost.
  bool all_lost() const;
  bool empty() const { return cameras_.empty(); }
  // A camera whose input went away for good (its pad released).
  void forget(int id) { cameras_.erase(id); }
  void clear() { cameras_.clear(); }

 private:
  struct Camera {
    int64_t last_seen_ns = 0;  // or since when it is expected, until its first frame
    bool lost = false;
    bool ever_seen = false;
  };
  int64_t timeout_ns_;
  std::map<int, Camera> cameras_;
};

// "camera 2 missing", "cameras 0, 2 missing"; "" when none is.
std::string missing_cameras_text(const std::vector<int>& ids);

// The banner's fill colour (RGB): a warning red no classroom surface is likely
// to match exactly, so tests can find the banner.
inline const cv::Vec3b kMissingBannerColor(190, 24, 24);

// Draws `text` in white on a banner in the top-left corner of an RGB image
// (CV_8UC3), scaled to the image; nothing for an empty text. Returns the
// banner's rectangle (empty when nothing was drawn).
cv::Rect draw_missing_banner(cv::Mat& rgb, const std::string& text);

}  // namespace vclassroom
