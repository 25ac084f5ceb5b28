// The rig of a classroom's cameras from a board carried through the room
// (vclassroom-calibrate, docs/real-classroom.md): each camera's intrinsics
// (from the board where the device gives none), every camera's pose by a
// bundle adjustment of the board corners all cameras saw, refined by the
// board's plane in each camera's depth, then the paper's rig frame: origin at
// the reference camera, Y up from the floor found in the depth, X along the
// front wall. GStreamer-free.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <gst/vclassroom/capture/calibration_board.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// One camera's sight of the board at one stop.
struct BoardSighting {
  std::vector<cv::Point2f> corners;  // detect_board's order, pixels as seen (distorted)
  // Pixels on the board with a depth: (u, v, z mm), depth registered to colour.
  std::vector<cv::Point3f> depth_samples;
};

// The depth samples of a sighting: up to four per square, inside the inner
// corners (away from the sheet's edge and its flying pixels).
std::vector<cv::Point3f> board_depth_samples(const CalibrationBoard& board, const std::vector<cv::Point2f>& corners,
                                             const cv::Mat& depth_mm);

struct CalibrationCapture {
  CalibrationBoard board;
  // Ids, names, sizes and depth scales; intrinsics where the device gives
  // them (fx > 0), else 0; depth_to_color and depth_lens are kept as given.
  std::vector<CameraCalib> cameras;
  // views[v][c]: camera c's sighting at stop v, where it saw the whole board.
  std::vector<std::vector<std::optional<BoardSighting>>> views;
  // Per camera, a depth image of the room (CV_16UC1 mm, registered to
  // colour): the floor and the wall are found in it.
  std::vector<cv::Mat> room_depth;
};

enum class XAxisFrom { Wall, Camera, Points };

struct RigCalibrationOptions {
  int reference = 0;                  // index into cameras: the rig's origin
  bool intrinsics_from_board = false; // also for cameras whose device gives intrinsics
  bool depth_refine = true;           // the board's plane in depth joins the adjustment
  XAxisFrom x_axis = XAxisFrom::Wall;
  // With XAxisFrom::Points: two points along the front wall, in the
  // reference camera's frame (metres); X runs from the first to the second.
  Eigen::Vector3d x_from = Eigen::Vector3d::Zero(), x_to = Eigen::Vector3d::Zero();
  int min_shared_views = 6;  // per camera, each shared with another camera
};

struct RigCalibrationReport {
  Rig rig;
  std::vector<int> views;                 // per camera: sightings used
  std::vector<double> reprojection_px;    // per camera: RMS corner error after adjustment
  std::vector<double> depth_plane_mm;     // per camera: RMS distance of board depth to the board (0: no depth)
  std::vector<bool> intrinsics_from_board;
  struct Pair {
    int a = 0, b = 0;   // camera indices
    int views = 0;      // stops both saw
    double agreement_mm = 0;  // mean distance between the corners each placed alone, in the rig
  };
  std::vector<Pair> pairs;
  double floor_spread_deg = 0;  // largest angle between one camera's floor and the rig's
  double camera_height_m = 0;   // reference camera above the floor
  std::string x_axis_from;      // what X was taken from, for the report
};

// Throws Error with what to do when the capture cannot give a rig: a camera
// with too few views or none shared with another camera, no floor in the
// depth, no wall (then give the X axis another way).
RigCalibrationReport calibrate_rig(const CalibrationCapture& capture, const RigCalibrationOptions& options);

// How far a calibrated rig is from the true one (both in the paper's frame).
struct RigError {
  double max_position_cm = 0;
  double max_rotation_deg = 0;
  double floor_deg = 0;  // angle between the two rigs' up axes, seen from the reference camera
};
RigError compare_rigs(const Rig& calibrated, const Rig& truth, int reference_id);

}  // namespace vclassroom
