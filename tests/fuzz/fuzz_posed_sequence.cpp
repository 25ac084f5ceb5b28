// libFuzzer target: the posed-sequence importer's trajectory.log
// (parse_trajectory_log, as vclassroom-import posed-sequence reads it). Only
// vclassroom::Error may come out, and every pose that does is a rotation
// and a finite translation.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/datasets/posed_sequence.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const auto poses = parse_trajectory_log(std::string(reinterpret_cast<const char*>(data), size), "fuzz.log");
    for (const Eigen::Isometry3d& p : poses) {
      if (!p.matrix().allFinite()) std::abort();
      if ((p.linear().transpose() * p.linear() - Eigen::Matrix3d::Identity()).norm() > 1e-6) std::abort();
    }
  } catch (const Error&) {
  }
  return 0;
}
