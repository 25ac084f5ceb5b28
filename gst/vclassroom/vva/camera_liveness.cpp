#include <gst/vclassroom/vva/camera_liveness.h>

#include <algorithm>
#include <sstream>

#include <opencv2/imgproc.hpp>

namespace vclassroom {

bool CameraLiveness::seen(int id, int64_t now_ns) {
  Camera& c = cameras_[id];
  const bool back = c.lost;
  c.last_seen_ns = std::max(c.last_seen_ns, now_ns);
  c.lost = false;
  c.ever_seen = true;
  return back;
}

void CameraLiveness::expect(int id, int64_t now_ns) {
  if (cameras_.count(id)) return;
  cameras_[id].last_seen_ns = now_ns;
}

bool CameraLiveness::ever_seen(int id) const {
  const auto it = cameras_.find(id);
  return it != cameras_.end() && it->second.ever_seen;
}

std::vector<int> CameraLiveness::newly_lost(int64_t now_ns) {
  std::vector<int> out;
  if (timeout_ns_ <= 0) return out;
  for (auto& [id, c] : cameras_)
    if (!c.lost && now_ns - c.last_seen_ns > timeout_ns_) {
      c.lost = true;
      out.push_back(id);
    }
  return out;
}

int64_t CameraLiveness::silent_for(int id, int64_t now_ns) const {
  const auto it = cameras_.find(id);
  return it == cameras_.end() ? 0 : std::max<int64_t>(0, now_ns - it->second.last_seen_ns);
}

std::vector<int> CameraLiveness::missing() const {
  std::vector<int> out;
  for (const auto& [id, c] : cameras_)
    if (c.lost) out.push_back(id);
  return out;
}

bool CameraLiveness::all_lost() const {
  return !cameras_.empty() && std::all_of(cameras_.begin(), cameras_.end(), [](const auto& c) { return c.second.lost; });
}

std::string missing_cameras_text(const std::vector<int>& ids) {
  if (ids.empty()) return "";
  std::ostringstream os;
  os << (ids.size() == 1 ? "camera " : "cameras ");
  for (size_t i = 0; i < ids.size(); ++i) os << (i ? ", " : "") << ids[i];
  os << " missing";
  return os.str();
}

cv::Rect draw_missing_banner(cv::Mat& rgb, const std::string& text) {
  if (text.empty() || rgb.empty() || rgb.type() != CV_8UC3) return {};
  // Text about 1/25 of the picture's height, readable at 960x540 and at thumbnails.
  const double scale = std::max(0.3, rgb.rows / 25.0 / 22.0);
  const int thickness = std::max(1, int(scale * 1.5 + 0.5));
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, font, scale, thickness, &baseline);
  const int pad = std::max(2, size.height / 2);
  cv::Rect box(0, 0, size.width + 2 * pad, size.height + baseline + 2 * pad);
  box &= cv::Rect(0, 0, rgb.cols, rgb.rows);
  rgb(box).setTo(cv::Scalar(kMissingBannerColor[0], kMissingBannerColor[1], kMissingBannerColor[2]));
  cv::putText(rgb, text, cv::Point(pad, pad + size.height), font, scale, cv::Scalar(255, 255, 255), thickness,
              cv::LINE_AA);
  return box;
}

}  // namespace vclassroom
