#include <gst/vclassroom/vva/background_memory.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

// The mean is kept in 1/256 grey levels (8.8 fixed point, 16 bits a
// channel): integer arithmetic that the loop below vectorises, where a float
// mean with a branch per pixel cost ~4 ms a 960x540 frame.
constexpr int kFraction = 256;

// Per-row scratch of update_row: per channel, whether it changed much, its pixel's rate (65536 / the pixel's
// count of frames), whether the pixel restarts, whether it is room.
struct RowScratch {
  std::vector<int32_t> rate;
  std::vector<uint8_t> big, restart, room;
  void resize(size_t n) {
    rate.resize(3 * n);
    big.resize(3 * n);
    restart.resize(3 * n);
    room.resize(3 * n);
  }
};

// The passes of update_row, each a plain loop the compiler vectorises: the
// channels as one array where a pixel's three do the same, the per-pixel
// decision on its own. A channel's difference to its mean is computed where
// it is used rather than kept: the row's scratch stays in the first-level cache.
VCLASSROOM_SIMD_INLINE int32_t difference_to_mean(uint8_t color, uint16_t mean) {
  return int32_t(color) * kFraction - int32_t(mean);
}

VCLASSROOM_SIMD_INLINE void channel_changes(int n3, const uint8_t* __restrict color, const uint16_t* __restrict mean,
                                            int32_t limit, uint8_t* __restrict big) {
  for (int i = 0; i < n3; ++i) {
    const int32_t d = difference_to_mean(color[i], mean[i]);
    big[i] = uint8_t((d > limit) | (d < -limit));
  }
}

VCLASSROOM_SIMD_INLINE void pixel_decisions(int n, const uint8_t* __restrict label, const uint8_t* __restrict big,
                                            uint8_t* __restrict count, int32_t frames, int32_t* __restrict rate,
                                            uint8_t* __restrict restart, uint8_t* __restrict room) {
  for (int x = 0; x < n; ++x) {
    const int32_t k = count[x];
    // Something new (or nothing yet) starts the mean again at this pixel, as does every frame of a memory of one.
    const bool again =
        (k == 0) | (big[3 * x] != 0) | (big[3 * x + 1] != 0) | (big[3 * x + 2] != 0) | (frames == 1);
    const int32_t next = again ? 1 : (k + 1 < frames ? k + 1 : frames);
    // A learner: shown as seen, the room behind stays remembered.
    const bool is_room = label[x] == 0;
    count[x] = uint8_t(is_room ? next : k);
    // 65536 / next, exact for next <= 255 (a float has 24 bits); 0 where the pixel restarts, whose kept mean is
    // not used (65536 there would overflow the product with its difference). (The restart taken from next == 1
    // instead, which would cover a memory of one frame without the test above, compiles to scalar code.)
    const int32_t r = (is_room & !again) ? int32_t(65536.0f / float(next)) : 0;
    const uint8_t a = uint8_t(is_room & again), o = uint8_t(is_room);
    rate[3 * x] = rate[3 * x + 1] = rate[3 * x + 2] = r;
    restart[3 * x] = restart[3 * x + 1] = restart[3 * x + 2] = a;
    room[3 * x] = room[3 * x + 1] = room[3 * x + 2] = o;
  }
}

VCLASSROOM_SIMD_INLINE void channel_updates(int n3, const uint8_t* __restrict color, const int32_t* __restrict rate,
                                            const uint8_t* __restrict restart, const uint8_t* __restrict room,
                                            uint16_t* __restrict mean, uint8_t* __restrict shown,
                                            uint8_t* __restrict remembered) {
  for (int i = 0; i < n3; ++i) {
    const int32_t c = color[i];
    // Without a restart |diff| <= 255 levels and rate <= 65536 / 2: no overflow.
    const int32_t kept = int32_t(mean[i]) + ((difference_to_mean(color[i], mean[i]) * rate[i]) >> 16);
    const int32_t m = restart[i] ? c * kFraction : kept;
    mean[i] = uint16_t(m);
    const int32_t r = (m + kFraction / 2) >> 8;
    remembered[i] = uint8_t(r);
    shown[i] = uint8_t(room[i] ? r : c);
  }
}

// One row of BackgroundMemory::update. `remembered` gets the mean of every
// pixel (the room as remembered), `shown` the frame with its static pixels
// as remembered.
VCLASSROOM_SIMD_CLONES
void update_row(int n, const uint8_t* color, const uint8_t* label, uint16_t* mean, uint8_t* count, int frames,
                int change, RowScratch& s, uint8_t* shown, uint8_t* remembered) {
  channel_changes(3 * n, color, mean, change * kFraction, s.big.data());
  pixel_decisions(n, label, s.big.data(), count, frames, s.rate.data(), s.restart.data(), s.room.data());
  channel_updates(3 * n, color, s.rate.data(), s.restart.data(), s.room.data(), mean, shown, remembered);
}

}  // namespace

void BackgroundMemory::seed(const cv::Mat& empty_room) {
  if (empty_room.type() != CV_8UC3 || empty_room.empty())
    throw Error("background memory: the empty room must be an RGB image");
  empty_room.convertTo(mean_, CV_16UC3, kFraction);
  empty_room.copyTo(own_remembered_);
  remembered_ = own_remembered_;
  count_ = cv::Mat(empty_room.size(), CV_8UC1, cv::Scalar(std::clamp(params_.frames, 1, 255)));
}

void BackgroundMemory::update(const cv::Mat& color, const cv::Mat& label, cv::Mat* out, cv::Mat* remembered) {
  if (color.type() != CV_8UC3 || (!label.empty() && (label.type() != CV_8UC1 || label.size() != color.size())))
    throw Error("background memory: expected an RGB image and a label plane of its size");
  if (mean_.size() != color.size()) {
    mean_ = cv::Mat::zeros(color.size(), CV_16UC3);
    count_ = cv::Mat::zeros(color.size(), CV_8UC1);
  }
  out->create(color.size(), CV_8UC3);
  // The remembered room goes into the caller's image or the memory's own, never into remembered_ as it
  // stands: that may be a caller's image of an earlier frame, still in use.
  cv::Mat& target = remembered ? *remembered : own_remembered_;
  target.create(color.size(), CV_8UC3);
  remembered_ = target;
  const int frames = std::clamp(params_.frames, 1, 255);
  // Beyond 255 levels every difference is noise: no restart ever.
  const int change = std::clamp(params_.change, 0, 255);
  static thread_local std::vector<uint8_t> all_room;
  all_room.assign(size_t(color.cols), 0);
  static thread_local RowScratch scratch;
  scratch.resize(size_t(color.cols));
  for (int y = 0; y < color.rows; ++y)
    update_row(color.cols, color.ptr<uint8_t>(y), label.empty() ? all_room.data() : label.ptr<uint8_t>(y),
               mean_.ptr<uint16_t>(y), count_.ptr<uint8_t>(y), frames, change, scratch, out->ptr<uint8_t>(y),
               remembered_.ptr<uint8_t>(y));
}

void BackgroundMemory::room_behind_learners(const cv::Mat& label, const cv::Mat& static_depth, cv::Mat* color,
                                            cv::Mat* depth) const {
  if (label.type() != CV_8UC1 || static_depth.type() != CV_16UC1 || label.size() != static_depth.size())
    throw Error("background memory: the room layer needs a label plane and a 16-bit static depth of one size");
  if (mean_.size() != label.size()) {  // nothing remembered at this size
    *depth = cv::Mat::zeros(label.size(), CV_16UC1);
    *color = cv::Mat::zeros(label.size(), CV_8UC3);
    return;
  }
  static thread_local cv::Mat hidden, steady;
  cv::compare(label, 0, hidden, cv::CMP_NE);
  const int margin = params_.room_margin;
  if (margin > 0)
    cv::dilate(hidden, hidden, cv::getStructuringElement(cv::MORPH_RECT, {2 * margin + 1, 2 * margin + 1}));
  depth->create(label.size(), CV_16UC1);
  *depth = cv::Scalar::all(0);
  cv::compare(count_, stable_count(), steady, cv::CMP_GE);
  cv::bitwise_and(hidden, steady, hidden);
  static_depth.copyTo(*depth, hidden);
  *color = remembered_;
}

void BackgroundMemory::apply(WarpSource* src, cv::Mat* shown, cv::Mat* room_color, cv::Mat* room_depth) {
  update(src->color, src->label, shown, room_color);
  src->color = *shown;
  if (src->static_depth.empty() || src->label.empty()) return;
  room_behind_learners(src->label, src->static_depth, room_color, room_depth);
  src->room_color = *room_color;
  src->room_depth = *room_depth;
}

}  // namespace vclassroom
