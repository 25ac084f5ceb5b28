#include <gst/vclassroom/vva/room_mesh.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace vclassroom {

namespace {

// The plane (1/z in 1/m = p . (x - x0, y - y0, 1)) of the tile's grid, if every pixel lies on it within tol.
bool planar_tile(const cv::Mat& d, int x0, int y0, int s, double ratio, double min_mm, Eigen::Vector3d* plane) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int y = y0; y <= y0 + s; ++y)
    for (int x = x0; x <= x0 + s; ++x) {
      const int z = d.at<uint16_t>(y, x);
      if (z == 0) return false;
      const Eigen::Vector3d r(x - x0, y - y0, 1);
      A += r * r.transpose();
      b += r * (1000.0 / z);
    }
  const Eigen::Vector3d p = A.ldlt().solve(b);
  for (int y = y0; y <= y0 + s; ++y)
    for (int x = x0; x <= x0 + s; ++x) {
      const double z = d.at<uint16_t>(y, x), inv = p.dot(Eigen::Vector3d(x - x0, y - y0, 1));
      if (inv <= 0 || std::fabs(1000.0 / inv - z) > std::max(min_mm, ratio * z)) return false;
    }
  *plane = p;
  return true;
}

bool one_surface(const cv::Mat& d, int x0, int y0) {
  int lo = 65535, hi = 0;
  for (int k = 0; k < 4; ++k) {
    const int z = d.at<uint16_t>(y0 + (k >> 1), x0 + (k & 1));
    if (z == 0) return false;
    lo = std::min(lo, z), hi = std::max(hi, z);
  }
  return hi - lo <= std::max(15.0, 0.03 * lo);
}

struct Quadtree {
  const cv::Mat& d;
  double ratio, min_mm;
  cv::Mat* planar;
  RoomMeshCount count;

  void split(int x0, int y0, int level) {
    const int s = 1 << level;
    if (x0 >= d.cols - 1 || y0 >= d.rows - 1) return;
    if (level == 0) {
      if (one_surface(d, x0, y0)) ++count.tiles[0];
      else ++count.dropped;
      return;
    }
    Eigen::Vector3d p;
    if (x0 + s <= d.cols - 1 && y0 + s <= d.rows - 1 && planar_tile(d, x0, y0, s, ratio, min_mm, &p)) {
      ++count.tiles[level];
      if (planar)
        for (int y = y0; y <= y0 + s; ++y)
          for (int x = x0; x <= x0 + s; ++x)
            planar->at<uint16_t>(y, x) =
                cv::saturate_cast<uint16_t>(1000.0 / p.dot(Eigen::Vector3d(x - x0, y - y0, 1)));
      return;
    }
    const int h = s / 2;
    for (int k = 0; k < 4; ++k) split(x0 + (k & 1) * h, y0 + (k >> 1) * h, level - 1);
  }
};

}  // namespace

RoomMeshCount room_mesh(const cv::Mat& depth, double ratio, double min_mm, int top, cv::Mat* planar) {
  CV_Assert(depth.type() == CV_16UC1 && top >= 0 && top < 8);
  if (planar) depth.copyTo(*planar);
  Quadtree q{depth, ratio, min_mm, planar, {}};
  const int s = 1 << top;
  for (int y = 0; y < depth.rows - 1; y += s)
    for (int x = 0; x < depth.cols - 1; x += s) q.split(x, y, top);
  return q.count;
}

}  // namespace vclassroom
