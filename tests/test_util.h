// Helpers shared by the tests: temporary folders, the shared data, pipelines.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <cstdint>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/rig.h>

namespace vctest {

// Issue 35's scene for the hole filling: a wall (depth 3000 mm, colours that vary with x and y, blue 140
// everywhere) with a bright yellow object in front (1200 mm), and the hole a view opened beside it: 40 px wide
// to the object's right and 6 rows under it, so that the object ends runs of holes both along rows and along
// columns. `hole` is 255 there, where `depth` is 0 and `color` black. `width` >= 128 (beyond 128 px the wall
// goes on in the colour of its column 127: viewfuse fades a fill that lies farther than 2 % of the width from
// anything seen, and a wider view keeps this hole clear of that).
struct HoleBesideAnObject {
  static constexpr int kH = 72;
  const int kW;
  cv::Mat color = cv::Mat(kH, kW, CV_8UC3), depth = cv::Mat(kH, kW, CV_16UC1, cv::Scalar(3000)),
          hole = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0));
  explicit HoleBesideAnObject(int width = 128) : kW(width) {
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        color.at<cv::Vec3b>(y, x) = cv::Vec3b(uint8_t(60 + std::min(x, 127) / 3), uint8_t(90 + y), 140);
    const cv::Rect object(30, 14, 24, 34);
    color(object).setTo(cv::Scalar(250, 250, 40));
    depth(object).setTo(cv::Scalar(1200));
    hole(cv::Rect(54, 10, 40, 50)).setTo(255);
    hole(cv::Rect(30, 48, 24, 6)).setTo(255);
    depth.setTo(cv::Scalar(0), hole);
    color.setTo(cv::Scalar(0, 0, 0), hole);
  }
  // Whether `c` could be the wall's (red 60..102, green 90..161, blue 140, give or take 4 levels of
  // rounding), and not the object's (250, 250, 40) or a mix with it.
  static bool wall_like(const cv::Vec3b& c) {
    return c[0] >= 56 && c[0] <= 106 && c[1] >= 86 && c[1] <= 165 && c[2] >= 136 && c[2] <= 144;
  }
};

// A fresh empty folder, removed when the object goes.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// ../shared/data (from VCLASSROOM_SHARED_DATA), or "" when absent.
// The default synthetic classroom's rig with every camera at width x height, written to `dir`/rig.yaml;
// returns its path.
std::string small_classroom_rig(const TempDir& dir, int width = 160, int height = 90);

std::string shared_data();
// Path of a file or folder inside the shared data, or "" when absent.
std::string shared_path(const std::string& relative);

void write_text(const std::string& path, const std::string& text);

// A small valid rig of `n` cameras in a row, 0.1 m apart, facing +Z of the rig.
vclassroom::Rig make_rig(int n, int width = 64, int height = 48);

// Runs a pipeline to EOS or error. Returns the error message ("" on EOS),
// and collects warnings. Fails the test on timeout (a hang).
struct RunResult {
  std::string error;
  std::string error_source;
  std::vector<std::string> warnings;
  std::vector<std::string> element_messages;  // their structures, serialised
};
RunResult run_pipeline(GstElement* pipeline, GstClockTime timeout = 60 * GST_SECOND);
RunResult run_launch(const std::string& description, GstClockTime timeout = 60 * GST_SECOND);

// The text of the first error `element` (a pipeline, or an element on its own) has posted on its bus, taken
// off the bus; nullopt when none is there.
std::optional<std::string> posted_error(GstElement* element);

// Keeps every sample an appsink receives while the pipeline runs.
class SampleCollector {
 public:
  explicit SampleCollector(GstElement* appsink);
  ~SampleCollector();
  const std::vector<GstSample*>& samples() const { return samples_; }
  size_t size() const { return samples_.size(); }
  GstBuffer* buffer(size_t i) const { return gst_sample_get_buffer(samples_.at(i)); }
  GstCaps* caps(size_t i) const { return gst_sample_get_caps(samples_.at(i)); }

 private:
  static GstFlowReturn on_sample(GstAppSink* sink, gpointer self);
  GMutex lock_;
  std::vector<GstSample*> samples_;
};

// A UDP or TCP port on 127.0.0.1 that is free now (bound and released).
int free_udp_port();
int free_tcp_port();

// Sends `request` (e.g. "GET / HTTP/1.1\r\nHost: ...\r\n\r\n") to 127.0.0.1:`port`, over TLS when `tls` (any
// certificate accepted: the tests' own is self-signed); the first line of the answer without its CR ("HTTP/1.1
// 200 OK"), or "" when none came.
std::string first_response_line(int port, bool tls, const std::string& request);

// A program run to its end: its exit status (-1 when it did not exit normally) and what it printed.
struct Exit {
  int status = -1;
  std::string out, err;
};
Exit run_tool(const std::vector<std::string>& argv);
// The 16-bit samples of a raw audio file (host order; empty when it cannot be read).
std::vector<int16_t> read_s16_samples(const std::string& path);

// vclassroom-calibrate's output `out` ends with "rig error: max C cm, max D deg, floor F deg" within issue 12's
// targets (1 cm, 0.3 deg, floor 0.5 deg); a failure of the calling test otherwise.
void expect_rig_error_within_targets(const std::string& out);

// A pose with every field set (fov included), for round trips through an event, a trace or the wire.
vclassroom::Pose sample_pose();
// A valid pose numbered `seq`, its position, heading and viewer time following from it.
vclassroom::Pose pose_with_seq(uint64_t seq);
// `a` and `b` are the same pose to the precision a round trip keeps; a failure of the calling test otherwise.
void expect_same_pose(const vclassroom::Pose& a, const vclassroom::Pose& b);

// Structural-equality of two images (type, size, bytes).
bool same_image(const cv::Mat& a, const cv::Mat& b);

}  // namespace vctest

#define SKIP_WITHOUT_SHARED_DATA(path)                                                          \
  do {                                                                                          \
    if ((path).empty())                                                                         \
      GTEST_SKIP() << "needs ../shared/data beside the project (set VCLASSROOM_SHARED_DATA); " \
                      "it is absent here, as on a user's machine";                              \
  } while (0)
