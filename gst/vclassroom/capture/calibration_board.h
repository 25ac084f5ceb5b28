// The printed checkerboard that vclassroom-calibrate finds in every camera
// (docs/real-classroom.md, "Calibrating"), and its detection. GStreamer-free.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

// A checkerboard of (inner_cols + 1) x (inner_rows + 1) squares with a white
// margin one square wide. Board frame: origin at the first inner corner
// (top left as printed), x along a row, y down the columns, z into the board
// (the printed side faces -z). The square diagonally outside the first inner
// corner is black; inner_cols + inner_rows must be odd, so that the board
// turned by half a turn looks different and every camera numbers the corners
// alike.
struct CalibrationBoard {
  int inner_cols = 9;
  int inner_rows = 6;
  double square_m = 0.08;

  int corner_count() const { return inner_cols * inner_rows; }
  // Corner k (row-major) in the board frame, metres.
  cv::Point3f corner(int k) const;
  std::vector<cv::Point3f> corners() const;
  // The printed sheet's extent in the board frame (margin included), metres.
  double left() const { return -2 * square_m; }
  double top() const { return -2 * square_m; }
  double right() const { return (inner_cols + 1) * square_m; }
  double bottom() const { return (inner_rows + 1) * square_m; }
  // Whether board point (x, y) is on a black square (false in the margin).
  bool is_black(double x, double y) const;
};

// Throws Error unless the board has at least 3x3 inner corners, at most
// 64 each way, an odd inner_cols + inner_rows, and a square of 5..500 mm.
void validate_board(const CalibrationBoard& board);
// Parses "COLSxROWS" (inner corners), e.g. "9x6"; throws Error naming `what`.
CalibrationBoard parse_board_size(const std::string& text, double square_m, const std::string& what);

// Finds the board in a grey (CV_8UC1) image: corners in the board's own
// order (row-major from the corner by the black outer square, whichever way
// the board is turned), refined to a tenth of a pixel. nullopt when the whole
// board is not visible.
std::optional<std::vector<cv::Point2f>> detect_board(const cv::Mat& gray, const CalibrationBoard& board);

}  // namespace vclassroom
