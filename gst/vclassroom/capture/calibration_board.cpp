#include <gst/vclassroom/capture/calibration_board.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

cv::Point3f CalibrationBoard::corner(int k) const {
  return cv::Point3f(float((k % inner_cols) * square_m), float((k / inner_cols) * square_m), 0.f);
}

std::vector<cv::Point3f> CalibrationBoard::corners() const {
  std::vector<cv::Point3f> out;
  out.reserve(size_t(corner_count()));
  for (int k = 0; k < corner_count(); ++k) out.push_back(corner(k));
  return out;
}

bool CalibrationBoard::is_black(double x, double y) const {
  const double i = std::floor(x / square_m), j = std::floor(y / square_m);
  // The squares run from -1 to inner_cols (inner_rows); (-1, -1) is black.
  if (i < -1 || j < -1 || i > inner_cols - 1 || j > inner_rows - 1) return false;
  return (int64_t(i) + int64_t(j)) % 2 == 0;
}

void validate_board(const CalibrationBoard& b) {
  if (b.inner_cols < 3 || b.inner_rows < 3 || b.inner_cols > 64 || b.inner_rows > 64)
    throw Error("calibration board: " + std::to_string(b.inner_cols) + "x" + std::to_string(b.inner_rows) +
                " inner corners; expected 3..64 each way");
  if ((b.inner_cols + b.inner_rows) % 2 == 0)
    throw Error("calibration board: " + std::to_string(b.inner_cols) + "x" + std::to_string(b.inner_rows) +
                " inner corners look the same turned half a turn, so cameras could number them differently; "
                "use one even and one odd count (e.g. 9x6)");
  if (!(b.square_m >= 0.005 && b.square_m <= 0.5))
    throw Error("calibration board: square of " + std::to_string(b.square_m * 1000) + " mm; expected 5..500 mm");
}

CalibrationBoard parse_board_size(const std::string& text, double square_m, const std::string& what) {
  CalibrationBoard b;
  int cols = 0, rows = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &cols, &rows, &tail) != 2)
    throw Error(what + ": '" + text + "' is not COLSxROWS inner corners (e.g. 9x6)");
  b.inner_cols = cols;
  b.inner_rows = rows;
  b.square_m = square_m;
  validate_board(b);
  return b;
}

namespace {

// Mean grey level in a small disc around p (0 where it leaves the image).
double mean_around(const cv::Mat& gray, cv::Point2f p, int radius) {
  const int x0 = std::max(0, int(std::lround(p.x)) - radius), x1 = std::min(gray.cols - 1, int(std::lround(p.x)) + radius);
  const int y0 = std::max(0, int(std::lround(p.y)) - radius), y1 = std::min(gray.rows - 1, int(std::lround(p.y)) + radius);
  if (x0 > x1 || y0 > y1) return 0;
  return cv::mean(gray(cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1)))[0];
}

}  // namespace

std::optional<std::vector<cv::Point2f>> detect_board(const cv::Mat& gray, const CalibrationBoard& board) {
  CV_Assert(gray.type() == CV_8UC1);
  const cv::Size pattern(board.inner_cols, board.inner_rows);
  std::vector<cv::Point2f> c;
  if (!cv::findChessboardCorners(gray, pattern, c,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK))
    return std::nullopt;
  if (int(c.size()) != board.corner_count()) return std::nullopt;
  const int cols = board.inner_cols, rows = board.inner_rows;

  // Seen from its printed side, the board's x and y turn like the image's:
  // a mirrored numbering is put right by reversing the rows.
  const cv::Point2f along = c[1] - c[0], down = c[size_t(cols)] - c[0];
  if (along.x * down.y - along.y * down.x < 0) {
    for (int r = 0; r < rows / 2; ++r)
      std::swap_ranges(c.begin() + r * cols, c.begin() + (r + 1) * cols, c.begin() + (rows - 1 - r) * cols);
  }
  // The outer square diagonal to the first corner is black, the one diagonal
  // to the last corner white: otherwise the numbering is half a turn round.
  const size_t last = c.size() - 1;
  auto outside = [&](size_t k, size_t step_along, size_t step_down) {
    return c[k] - 0.5f * (c[step_along] - c[k]) - 0.5f * (c[step_down] - c[k]);
  };
  const cv::Point2f near_first = outside(0, 1, size_t(cols));
  const cv::Point2f near_last = outside(last, last - 1, last - size_t(cols));
  const double square_px = std::max(cv::norm(c[1] - c[0]), cv::norm(c[size_t(cols)] - c[0]));
  const int radius = std::max(1, int(square_px / 5));
  if (mean_around(gray, near_first, radius) > mean_around(gray, near_last, radius)) std::reverse(c.begin(), c.end());

  // Sub-pixel refinement inside a window well within one square.
  const int win = std::clamp(int(square_px * 0.35), 2, 11);
  cv::cornerSubPix(gray, c, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.01));
  return c;
}

}  // namespace vclassroom
