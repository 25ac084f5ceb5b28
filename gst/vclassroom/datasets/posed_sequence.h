// Importer for an RGB-D sequence with a camera pose per frame, as the
// Redwood / Augmented ICL-NUIM data ships it (rgbd.match pairing depth and
// colour files, trajectory.log with each frame's camera-to-world matrix):
// every frame becomes a camera of its own at its pose, so a leave-one-out
// (vclassroom-eval-views --dataset) synthesises one frame from the others.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include <gst/vclassroom/datasets/middlebury.h>

namespace vclassroom {

struct PosedSequenceIntrinsics {
  // Redwood and ICL-NUIM use the PrimeSense defaults at 640x480.
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  double depth_mm_per_unit = 1.0;  // their depth PNGs are in mm
};

// scene_dir holds rgbd.match ("depth/N.png color/N.jpg" per line) and
// trajectory.log (per frame a line "i j n" and the 4x4 camera-to-world
// matrix, metres, OpenCV camera axes). Camera ids are frame numbers; the
// rig frame is the log's world. At most 1000 frames; a malformed log, a
// pose that is not a rotation, or a missing image is an Error naming the file.
ImportSummary import_posed_sequence(const std::string& scene_dir, const std::string& out_folder,
                                    const PosedSequenceIntrinsics& k = PosedSequenceIntrinsics());

// The camera-to-world poses of a trajectory.log's text, in frame order;
// `name` stands for the file in messages. Throws Error on a malformed log or
// a matrix that is not a rotation and a translation.
std::vector<Eigen::Isometry3d> parse_trajectory_log(const std::string& text, const std::string& name);

}  // namespace vclassroom
