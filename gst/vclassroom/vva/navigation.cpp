#include <gst/vclassroom/vva/navigation.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

CoverageEstimator::CoverageEstimator(const std::vector<CameraCalib>& cameras, const std::vector<cv::Mat>& static_depth,
                                     const CameraCalib& reference, int width)
    : reference_(reference) {
  if (cameras.empty() || cameras.size() != static_depth.size())
    throw Error("coverage: one static depth per camera is needed");
  if (width < 8 || width > reference.width) throw Error("coverage: working width must be 8 to the reference's width");
  const int height = std::max(1, int(std::lround(double(width) * reference.height / reference.width)));
  view_ = scale_camera(reference, width, height);
  for (size_t i = 0; i < cameras.size(); ++i) {
    const CameraCalib& c = cameras[i];
    if (static_depth[i].type() != CV_16UC1 || static_depth[i].size() != cv::Size(c.width, c.height))
      throw Error("coverage: the static depth of camera " + std::to_string(c.id) + " is not " + std::to_string(c.width) +
                  "x" + std::to_string(c.height) + " 16-bit");
    // Sources a little larger than the view: every view pixel still gets samples.
    const int w = std::min(c.width, 2 * width), h = std::max(1, int(std::lround(double(w) * c.height / c.width)));
    cameras_.push_back(scale_camera(c, w, h));
    cv::Mat small;
    cv::resize(static_depth[i], small, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
    depth_.push_back(small);
    color_.push_back(cv::Mat::zeros(h, w, CV_8UC3));
  }
  warpers_.resize(cameras_.size());
  warped_.resize(cameras_.size());
}

double CoverageEstimator::coverage(const ViewOffset& offset) {
  const Pose pose = offset_to_pose(offset, reference_);
  const CameraCalib virt = virtual_camera(view_, pose.cam_to_rig(), std::numeric_limits<double>::quiet_NaN());
  seen_.create(virt.height, virt.width, CV_8UC1);
  seen_.setTo(0);
  WarpParams params;
  for (size_t i = 0; i < cameras_.size(); ++i) {
    warpers_[i].warp(cameras_[i], WarpSource{color_[i], depth_[i], cv::Mat(), cv::Mat()}, virt, params, &warped_[i]);
    seen_.setTo(255, warped_[i].depth > 0);
  }
  return double(cv::countNonZero(seen_)) / double(seen_.total());
}

namespace {

ViewOffset offset_of(const std::array<double, 6>& v) { return ViewOffset{v[0], v[1], v[2], v[3], v[4], v[5]}; }

}  // namespace

NavigationBounds derive_navigation(CoverageEstimator& est, int reference_camera, const NavigationSearch& s,
                                   const std::function<void(const std::string&)>& progress) {
  NavigationBounds b;
  b.reference_camera = reference_camera;
  b.coverage = s.threshold;
  if (est.coverage(ViewOffset{}) < s.threshold) {
    if (progress) progress("the reference view itself is covered less than the threshold: bounds are that view alone");
    return b;
  }
  // The cone at the reference position, one angle at a time.
  for (int axis = 3; axis < 6; ++axis)
    for (int sign : {-1, 1}) {
      double& limit = sign < 0 ? b.min[axis] : b.max[axis];
      const double reach = sign < 0 ? s.reach_min[axis] : s.reach_max[axis];
      for (double a = s.angle_step; a <= std::abs(reach) + 1e-9; a += s.angle_step) {
        std::array<double, 6> v{};
        v[axis] = sign * a;
        if (est.coverage(offset_of(v)) < s.threshold) break;
        limit = sign * a;
      }
    }
  if (progress) {
    char text[160];
    std::snprintf(text, sizeof text, "view cone: yaw %.1f..%.1f, pitch %.1f..%.1f, roll %.1f..%.1f deg", b.min[3],
                  b.max[3], b.min[4], b.max[4], b.min[5], b.max[5]);
    progress(text);
  }
  // The box of positions where the view straight ahead stays covered, grown
  // one face at a time, round robin, while a face can move (its four corners
  // and centre tested).
  auto face_points = [](const NavigationBounds& nb, int axis, double value) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    std::vector<std::array<double, 3>> points;
    for (int corner = 0; corner < 5; ++corner) {
      std::array<double, 3> p{};
      p[axis] = value;
      p[a1] = corner == 4 ? 0.5 * (nb.min[a1] + nb.max[a1]) : (corner & 1 ? nb.max[a1] : nb.min[a1]);
      p[a2] = corner == 4 ? 0.5 * (nb.min[a2] + nb.max[a2]) : (corner & 2 ? nb.max[a2] : nb.min[a2]);
      points.push_back(p);
    }
    return points;
  };
  std::array<bool, 6> stuck{};  // faces: -right, +right, -up, +up, -forward, +forward
  while (!std::all_of(stuck.begin(), stuck.end(), [](bool x) { return x; })) {
    for (int face = 0; face < 6; ++face) {
      if (stuck[face]) continue;
      const int axis = face / 2;
      const bool up = face % 2 == 1;
      const double next = (up ? b.max[axis] : b.min[axis]) + (up ? s.position_step : -s.position_step);
      if (up ? next > s.reach_max[axis] + 1e-9 : next < s.reach_min[axis] - 1e-9) {
        stuck[face] = true;
        continue;
      }
      bool ok = true;
      for (const auto& p : face_points(b, axis, next))
        if (ok && est.coverage(ViewOffset{p[0], p[1], p[2], 0, 0, 0}) < s.threshold) ok = false;
      if (ok) (up ? b.max[axis] : b.min[axis]) = next;
      else stuck[face] = true;
    }
  }
  // Box and cone were each found with the other at its centre; together, a
  // turn at the edge of the box shows less. Both shrink by one factor until
  // every face's corners and centre, looking straight or at the cone's yaw and
  // pitch limits, stay covered.
  const NavigationBounds widest = b;
  auto scaled = [&](double f) {
    NavigationBounds nb = widest;
    for (int i = 0; i < 5; ++i) {
      nb.min[i] = f * widest.min[i];
      nb.max[i] = f * widest.max[i];
    }
    return nb;
  };
  auto holds = [&](const NavigationBounds& nb) {
    const std::vector<std::array<double, 2>> directions = {
        {0, 0}, {nb.min[3], 0}, {nb.max[3], 0}, {0, nb.min[4]}, {0, nb.max[4]}};
    for (int axis = 0; axis < 3; ++axis)
      for (double value : {nb.min[axis], nb.max[axis]})
        for (const auto& p : face_points(nb, axis, value))
          for (const auto& d : directions)
            if (est.coverage(ViewOffset{p[0], p[1], p[2], d[0], d[1], 0}) < s.threshold) return false;
    return true;
  };
  if (!holds(widest)) {
    double lo = 0, hi = 1;  // scaled(lo) holds (the reference view alone does)
    for (int i = 0; i < 10; ++i) {
      const double mid = 0.5 * (lo + hi);
      (holds(scaled(mid)) ? lo : hi) = mid;
    }
    b = scaled(lo);
  }
  if (progress) {
    char text[160];
    std::snprintf(text, sizeof text, "positions: right %.2f..%.2f, up %.2f..%.2f, forward %.2f..%.2f m", b.min[0],
                  b.max[0], b.min[1], b.max[1], b.min[2], b.max[2]);
    progress(text);
  }
  return b;
}

std::vector<CoverageSample> coverage_map(CoverageEstimator& est, const NavigationSearch& reach, double position_step,
                                         double angle_step,
                                         const std::function<void(size_t done, size_t total)>& progress) {
  if (!(position_step > 0) || !(angle_step > 0)) throw Error("coverage map: steps must be positive");
  auto values = [](double lo, double hi, double step) {
    std::vector<double> v;
    const long first = long(std::ceil(lo / step - 1e-9)), last = long(std::floor(hi / step + 1e-9));
    for (long k = first; k <= last; ++k) v.push_back(double(k) * step);
    return v;
  };
  std::array<std::vector<double>, 5> axes;
  for (int i = 0; i < 3; ++i) axes[i] = values(reach.reach_min[i], reach.reach_max[i], position_step);
  for (int i = 3; i < 5; ++i) axes[i] = values(reach.reach_min[i], reach.reach_max[i], angle_step);
  size_t total = 1;
  for (const auto& a : axes) total *= a.size();
  std::vector<CoverageSample> map;
  map.reserve(total);
  for (double r : axes[0])
    for (double u : axes[1])
      for (double f : axes[2])
        for (double yaw : axes[3])
          for (double pitch : axes[4]) {
            const ViewOffset o{r, u, f, yaw, pitch, 0};
            map.push_back(CoverageSample{o, est.coverage(o)});
            if (progress && (map.size() % 256 == 0 || map.size() == total)) progress(map.size(), total);
          }
  return map;
}

NavigationClamp::NavigationClamp(const Rig& rig) {
  if (!rig.navigation) return;
  bounds_ = rig.navigation;
  reference_ = rig.camera(rig.navigation->reference_camera);
}

bool NavigationClamp::apply(Pose* pose, int64_t now_ns, const std::string& source, std::string* warning) {
  warning->clear();
  if (!bounds_ || !clamp_to_navigation(*bounds_, reference_, pose)) return false;
  uint64_t count = 0;
  int64_t span = 0;
  if (limiter_.note(now_ns, &count, &span))
    *warning = describe_occurrences(count, "a pose outside the navigation bounds", "poses outside the navigation bounds",
                                    source, span) +
               (count == 1 ? " was" : " were") + " moved to the nearest allowed view (docs/navigation.md)";
  return true;
}

}  // namespace vclassroom
