#include <gst/vclassroom/core/planes.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

namespace vclassroom {

namespace {

RoomPlane fit_plane(const std::vector<Eigen::Vector3f>& pts, const std::vector<int>& idx) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : idx) c += pts[i].cast<double>();
  c /= static_cast<double>(idx.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : idx) {
    const Eigen::Vector3d d = pts[i].cast<double>() - c;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  RoomPlane p;
  p.normal = es.eigenvectors().col(0).normalized();
  p.offset = -p.normal.dot(c);
  return p;
}

void name_planes(std::vector<RoomPlane>& planes) {
  double lowest = 1e9, highest = -1e9;
  int floor = -1, ceiling = -1;
  for (size_t i = 0; i < planes.size(); ++i) {
    const RoomPlane& p = planes[i];
    if (std::abs(p.normal.y()) < 0.9) continue;
    const double y = -p.offset / p.normal.y();
    if (p.normal.y() > 0 && y < lowest) lowest = y, floor = static_cast<int>(i);
    if (p.normal.y() < 0 && y > highest) highest = y, ceiling = static_cast<int>(i);
  }
  for (size_t i = 0; i < planes.size(); ++i) {
    RoomPlane& p = planes[i];
    if (static_cast<int>(i) == floor)
      p.name = "floor";
    else if (static_cast<int>(i) == ceiling)
      p.name = "ceiling";
    else if (p.normal.y() > 0.9)
      p.name = "desk";
    else if (std::abs(p.normal.y()) < 0.3)
      p.name = "wall";
    else
      p.name = "plane";
  }
}

}  // namespace

std::vector<RoomPlane> find_planes(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& viewpoint,
                                   const PlaneFinding& o) {
  std::vector<RoomPlane> planes;
  std::vector<int> rest(points.size());
  for (size_t i = 0; i < points.size(); ++i) rest[i] = static_cast<int>(i);
  const size_t min_inliers = std::max<size_t>(200, static_cast<size_t>(o.min_share * points.size()));
  std::mt19937_64 rng(o.seed);
  const float dist = static_cast<float>(o.distance_m);
  while (static_cast<int>(planes.size()) < o.max_planes && rest.size() >= min_inliers) {
    // Score hypotheses on a subsample, then take inliers from all remaining points.
    std::vector<int> sample = rest;
    std::shuffle(sample.begin(), sample.end(), rng);
    sample.resize(std::min<size_t>(sample.size(), 20000));
    std::uniform_int_distribution<size_t> pick(0, rest.size() - 1);
    Eigen::Vector3f best_n = Eigen::Vector3f::UnitY();
    float best_d = 0;
    size_t best_count = 0;
    for (int it = 0; it < o.iterations; ++it) {
      const Eigen::Vector3f a = points[rest[pick(rng)]], b = points[rest[pick(rng)]], c = points[rest[pick(rng)]];
      Eigen::Vector3f n = (b - a).cross(c - a);
      if (n.norm() < 1e-6f) continue;
      n.normalize();
      const float d = -n.dot(a);
      size_t count = 0;
      for (int i : sample) count += std::abs(n.dot(points[i]) + d) < dist;
      if (count > best_count) best_count = count, best_n = n, best_d = d;
    }
    std::vector<int> in, out;
    for (int i : rest) (std::abs(best_n.dot(points[i]) + best_d) < dist ? in : out).push_back(i);
    if (in.size() < min_inliers) break;
    RoomPlane p = fit_plane(points, in);
    in.clear(), out.clear();
    for (int i : rest)
      (std::abs(p.normal.dot(points[i].cast<double>()) + p.offset) < o.distance_m ? in : out).push_back(i);
    if (in.size() < min_inliers) break;
    p = fit_plane(points, in);
    if (p.normal.dot(viewpoint) + p.offset < 0) p.normal = -p.normal, p.offset = -p.offset;
    p.inliers = static_cast<int>(in.size());
    planes.push_back(p);
    rest.swap(out);
  }
  name_planes(planes);
  return planes;
}

}  // namespace vclassroom
