// A calibration board carried through the synthetic classroom, for testing
// and demonstrating vclassroom-calibrate without cameras (rgbdtestsrc
// calibration-board=true). GStreamer-free.
#pragma once

#include <Eigen/Geometry>

#include <gst/vclassroom/capture/calibration_board.h>
#include <gst/vclassroom/synthetic/classroom.h>

namespace vclassroom {

// Someone holds the board still at a stop for kBoardStillSeconds, then moves
// it to the next stop in kBoardMoveSeconds, as the calibration guide asks.
// The stops lie in front of the default rig's cameras, 1.8 to 3.2 m away and
// 1.0 to 1.6 m above the floor, the board facing the cameras and turned up to
// 30 degrees each way; the same for every run. After the last stop the trace
// starts again.
inline constexpr int kBoardStops = 24;
inline constexpr double kBoardStillSeconds = 1.0;
inline constexpr double kBoardMoveSeconds = 0.6;
inline constexpr double kBoardStopSeconds = kBoardStillSeconds + kBoardMoveSeconds;  // one stop and the move on

// The board the trace carries: 9x6 inner corners of 80 mm (an A1 sheet).
CalibrationBoard trace_board();
// Board frame to rig frame at scene time t (seconds), for `room`'s floor.
Eigen::Isometry3d board_pose_on_trace(const Classroom& room, double t);

// Draws the board at `board_to_rig` into a rendered view: depth-tested
// against what is already there (a learner in front hides it), its colour
// anti-aliased over 4x4 samples per pixel, depth and surface set where a
// pixel's centre falls on it (a matte print for the sensor model).
void draw_board(const CalibrationBoard& board, const Eigen::Isometry3d& board_to_rig, const CameraCalib& cam,
                RenderOutput* out);

}  // namespace vclassroom
