// The core family's helpers that the other families share: image metrics, the pose meta and the
// rate-limited warnings.
#include <gtest/gtest.h>

#include <cmath>

#include <gst/gst.h>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/warning_limiter.h>

#include "test_util.h"

using namespace vclassroom;

TEST(ImageMetrics, IdenticalImagesAreInfinitePsnrAndUnitSsim) {
  cv::Mat a(40, 50, CV_8UC3);
  cv::randu(a, 0, 255);
  EXPECT_TRUE(std::isinf(psnr_rgb(a, a)));
  EXPECT_NEAR(ssim_luma(a, a), 1.0, 1e-9);
}

TEST(ImageMetrics, PsnrFollowsTheDefinition) {
  cv::Mat a(10, 10, CV_8UC3, cv::Scalar(100, 100, 100)), b = a.clone();
  b.setTo(cv::Scalar(110, 100, 100));  // MSE = 100 / 3 over all channels
  EXPECT_NEAR(psnr_rgb(a, b), 10 * std::log10(255.0 * 255.0 / (100.0 / 3)), 1e-9);
  // The crop excludes what it should.
  cv::Mat c = a.clone();
  c(cv::Rect(5, 0, 5, 10)).setTo(cv::Scalar(0, 0, 0));
  EXPECT_TRUE(std::isinf(psnr_rgb(a, c, cv::Rect(0, 0, 5, 10))));
}

TEST(ImageMetrics, SsimDropsWithNoiseAndStructureLoss) {
  cv::Mat a(64, 64, CV_8UC3);
  cv::randu(a, 0, 255);
  cv::GaussianBlur(a, a, cv::Size(5, 5), 1.5);
  cv::Mat noisy = a.clone(), flat(64, 64, CV_8UC3, cv::mean(a));
  cv::Mat n(64, 64, CV_8UC3);
  cv::randn(n, 0, 8);
  cv::add(a, n, noisy);
  const double s_noisy = ssim_luma(a, noisy), s_flat = ssim_luma(a, flat);
  EXPECT_LT(s_noisy, 1.0);
  EXPECT_GT(s_noisy, s_flat);
}

TEST(PoseMeta, TravelsWithCopies) {
  GstBuffer* b = gst_buffer_new_allocate(nullptr, 16, nullptr);
  buffer_add_pose_meta(b, 12, 3456);
  GstBuffer* c = gst_buffer_copy(b);
  PoseMeta* m = buffer_get_pose_meta(c);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->seq, 12u);
  EXPECT_EQ(m->viewer_time_ns, 3456);
  gst_buffer_unref(b);
  gst_buffer_unref(c);
}

// ---- Rate-limited warnings (gst/vclassroom/core/warning_limiter.h)

TEST(WarningLimiter, FirstAtOnceThenOnePerIntervalWithTheCount) {
  vclassroom::WarningLimiter lim(5'000'000'000);
  uint64_t count = 0;
  int64_t span = -1;
  ASSERT_TRUE(lim.note(1'000, &count, &span));
  EXPECT_EQ(count, 1u);
  EXPECT_EQ(span, 0);
  // 36 more inside the interval: none posted, all counted.
  for (int i = 0; i < 36; ++i) EXPECT_FALSE(lim.note(1'000 + i * 100'000'000LL, &count, &span));
  EXPECT_EQ(lim.pending(), 36u);
  ASSERT_TRUE(lim.note(5'000'001'000, &count, &span));
  EXPECT_EQ(count, 37u);
  EXPECT_EQ(span, 5'000'000'000);
  EXPECT_EQ(lim.total(), 38u);
  EXPECT_EQ(lim.pending(), 0u);
  EXPECT_EQ(vclassroom::describe_occurrences(count, "a damaged frame", "damaged frames", "camera 2", span),
            "37 damaged frames from camera 2 in the last 5 s");
  EXPECT_EQ(vclassroom::describe_occurrences(1, "a damaged frame", "damaged frames", "camera 2", 0),
            "a damaged frame from camera 2");
}

TEST(WarningLimiter, PendingAfterABurstCanBeTakenForAFinalMessage) {
  vclassroom::WarningLimiter lim(1'000);
  uint64_t count;
  int64_t span;
  ASSERT_TRUE(lim.note(0, &count, &span));
  EXPECT_FALSE(lim.note(10, &count, &span));
  EXPECT_FALSE(lim.note(20, &count, &span));
  EXPECT_EQ(lim.take_pending(), 2u);
  EXPECT_EQ(lim.pending(), 0u);
  lim.reset();
  EXPECT_EQ(lim.total(), 0u);
  ASSERT_TRUE(lim.note(30, &count, &span));  // after a reset the first is posted again
  EXPECT_EQ(count, 1u);
}
