// Recorded RGB-D datasets on disk (docs/dataset-format.md):
//   <folder>/rig.yaml
//   <folder>/cam<ID>/color/<frame>.png|jpg|ppm   8-bit colour
//   <folder>/cam<ID>/depth/<frame>.png           16-bit, rig depth_scale mm per unit
//   <folder>/cam<ID>/label/<frame>.png           8-bit learner labels (optional)
//   <folder>/cam<ID>/depth-gt/<frame>.png        16-bit clean depth in mm (optional)
//   <folder>/cam<ID>/stream.vcrs                 or: a live recording, coded frames with their times
// Frames pair by file name (without extension); a camera without depth/ has no measurements.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/image_io.h>
#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/datasets/coded_stream.h>

namespace vclassroom {

// One frame of one camera. color is CV_8UC3 RGB; depth/depth_gt CV_16UC1 mm;
// label CV_8UC1. Optional planes are empty when absent.
struct RgbdImages {
  cv::Mat color, depth, label, depth_gt;
};

class Dataset {
 public:
  // Reads <folder>/rig.yaml and lists every camera's frames. Throws Error.
  static Dataset open(const std::string& folder);

  const std::string& folder() const { return folder_; }
  const Rig& rig() const { return rig_; }
  size_t frame_count(int camera_id) const;
  bool has_label(int camera_id) const;
  bool has_depth_gt(int camera_id) const { return !camera(camera_id).depth_gt.empty(); }
  // Loads frame `index` of a camera; depth is converted to mm. Throws Error
  // naming the file on a missing, undecodable or wrongly sized image or a
  // damaged recorded frame.
  RgbdImages load(int camera_id, size_t index) const;

  // Live recordings (cam<ID>/stream.vcrs) keep each frame's running time.
  bool is_recording(int camera_id) const { return !camera(camera_id).stream.empty(); }
  // The frame's recorded running time in ns minus the dataset's time origin
  // (the earliest first frame of its recorded cameras, so cameras recorded
  // together play back together). Only for recorded cameras.
  uint64_t frame_time_ns(int camera_id, size_t index) const;
  // Why a recorded camera's stream ends early ("" when it does not): e.g. the
  // recorder was killed in the middle of a frame.
  const std::string& recording_problem(int camera_id) const { return camera(camera_id).index.tail_problem; }

 private:
  struct Files {
    int id;
    std::vector<std::string> color, depth, label, depth_gt;
    std::string stream;  // live recording, instead of the image folders
    CodedStreamIndex index;
  };
  const Files& camera(int id) const;
  std::string folder_;
  Rig rig_;
  std::vector<Files> cameras_;
  uint64_t time_origin_ns_ = 0;
};

// Path of a camera's folder inside a dataset.
std::string dataset_camera_dir(const std::string& folder, int camera_id);
// Writes one frame (PNG, depth in mm) as <frame index, 6 digits>.png. Creates folders. Throws Error.
void dataset_write_frame(const std::string& folder, int camera_id, size_t index, const RgbdImages& images);
// Adds or replaces one camera in <folder>/rig.yaml (depth_scale forced to 1: recordings are mm).
void dataset_write_camera(const std::string& folder, const CameraCalib& camera, const std::string& rig_name);

// The most frames a dataset reader accepts (docs/dataset-format.md; image limits: core/image_io.h).
inline constexpr size_t kMaxFrames = 10000000;

// The files of one plane (depth/, label/, depth-gt/) in the order of the
// colour files they pair with, by file name without extension. Empty for an
// empty plane. A colour frame without a partner, a plane file without one, or
// two files of one frame is an Error naming the files.
std::vector<std::string> pair_by_name(const std::vector<std::string>& color, const std::vector<std::string>& plane,
                                      const std::string& plane_name);

}  // namespace vclassroom
