// Pose traces: a lecturer's poses over time as CSV (docs/pose.md, "Pose traces").
#pragma once

#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

// A pose trace: CSV with a header naming the columns, one pose per frame.
// Required columns x,y,z,qw,qx,qy,qz; optional t (seconds), fov (deg), seq.
// '#' starts a comment line. Throws Error naming file, line and column.
struct PoseSample {
  double t = std::numeric_limits<double>::quiet_NaN();  // seconds, NaN when the trace has no t column
  Pose pose;
};
std::vector<PoseSample> load_pose_trace(const std::string& path);
void save_pose_trace(const std::vector<PoseSample>& trace, const std::string& path);
// Writes a trace as it happens (the lecturer's poses during a session), one
// line per pose handed to the kernel at once, so a killed process leaves every
// pose before. The columns are those of the first pose (fov or not). Throws
// Error naming the file.
class PoseTraceWriter {
 public:
  explicit PoseTraceWriter(const std::string& path);
  ~PoseTraceWriter();
  PoseTraceWriter(const PoseTraceWriter&) = delete;
  PoseTraceWriter& operator=(const PoseTraceWriter&) = delete;
  void append(const PoseSample& sample);

 private:
  std::string path_;
  FILE* file_ = nullptr;
  bool fov_ = false;
  bool header_written_ = false;
};
// Which sample of a non-empty trace shows the frame at running time `t`
// seconds, the `frame`-th of its stream: with a t column the last sample at or
// before t (the first before it starts), else sample `frame`; the last one is
// held.
size_t pose_trace_index(const std::vector<PoseSample>& trace, double t, uint64_t frame);

}  // namespace vclassroom
