#include <gst/vclassroom/vda/static_model.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <sys/stat.h>
#include <unordered_map>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/image_io.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

bool is_dir(const std::string& p) {
  struct stat st{};
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

void make_dir(const std::string& p) {
  if (is_dir(p)) return;
  if (mkdir(p.c_str(), 0755) != 0 && !is_dir(p)) throw Error(p + ": cannot create folder");
}

std::string prior_path(const std::string& folder, int id) {
  return folder + "/prior-depth/cam" + std::to_string(id) + ".png";
}

std::string measured_path(const std::string& folder, int id) {
  return folder + "/prior-measured/cam" + std::to_string(id) + ".png";
}

std::string color_path(const std::string& folder, int id) {
  return folder + "/prior-color/cam" + std::to_string(id) + ".png";
}

// Camera-frame points of a depth image (metres), NaN where there is no depth.
cv::Mat depth_points(const cv::Mat& depth, const CameraCalib& cam) {
  cv::Mat pts(depth.size(), CV_32FC3, cv::Scalar::all(std::nanf("")));
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u) {
      const int z = depth.at<uint16_t>(v, u);
      if (!z) continue;
      const Eigen::Vector3d p = cam.unproject(u, v, z * 0.001);
      pts.at<cv::Vec3f>(v, u) = cv::Vec3f(float(p.x()), float(p.y()), float(p.z()));
    }
  return pts;
}

cv::Mat depth_normals(const cv::Mat& pts) {
  cv::Mat n(pts.size(), CV_32FC3, cv::Scalar::all(std::nanf("")));
  for (int v = 1; v + 1 < pts.rows; ++v)
    for (int u = 1; u + 1 < pts.cols; ++u) {
      const cv::Vec3f a = pts.at<cv::Vec3f>(v, u + 1) - pts.at<cv::Vec3f>(v, u - 1);
      const cv::Vec3f b = pts.at<cv::Vec3f>(v + 1, u) - pts.at<cv::Vec3f>(v - 1, u);
      if (std::isnan(a[0]) || std::isnan(b[0])) continue;
      // Reject normals across depth edges.
      if (cv::norm(a) > 0.05 || cv::norm(b) > 0.05) continue;
      cv::Vec3f c = a.cross(b);
      const float len = static_cast<float>(cv::norm(c));
      if (len < 1e-9f) continue;
      c /= len;
      const cv::Vec3f p = pts.at<cv::Vec3f>(v, u);
      if (c.dot(p) > 0) c = -c;  // towards the camera
      n.at<cv::Vec3f>(v, u) = c;
    }
  return n;
}

}  // namespace

const cv::Mat& StaticModel::prior(int id) const {
  auto it = prior_depth.find(id);
  if (it == prior_depth.end()) throw Error("static model: no prior depth for camera " + std::to_string(id));
  return it->second;
}

cv::Mat StaticModel::color(int id) const {
  auto it = prior_color.find(id);
  return it == prior_color.end() ? cv::Mat() : it->second;
}

StaticPrior StaticModel::prior_for(int id) const {
  StaticPrior p;
  p.depth = prior(id);
  p.color = color(id);
  auto it = prior_measured.find(id);
  if (it != prior_measured.end()) p.measured = it->second;
  return p;
}

cv::Mat median_depth(const std::vector<cv::Mat>& frames, double min_share) {
  if (frames.empty()) throw Error("median_depth: no frames");
  const cv::Size size = frames[0].size();
  for (const cv::Mat& f : frames)
    if (f.type() != CV_16UC1 || f.size() != size) throw Error("median_depth: frames differ in size or type");
  const size_t need = std::max<size_t>(1, static_cast<size_t>(std::ceil(min_share * frames.size())));
  cv::Mat out(size, CV_16UC1, cv::Scalar(0));
  std::vector<uint16_t> vals;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      vals.clear();
      for (const cv::Mat& f : frames)
        if (uint16_t v = f.at<uint16_t>(y, x)) vals.push_back(v);
      if (vals.size() < need) continue;
      std::nth_element(vals.begin(), vals.begin() + vals.size() / 2, vals.end());
      const int med = vals[vals.size() / 2];
      // Flying pixels at depth edges jump between the surfaces from frame to
      // frame: keep a pixel only when most measurements agree with the median.
      const int tol = std::max(20, med / 50);
      size_t agree = 0;
      for (uint16_t v : vals) agree += std::abs(int(v) - med) <= tol;
      if (agree < need) continue;
      out.at<uint16_t>(y, x) = static_cast<uint16_t>(med);
    }
  return out;
}

std::vector<ExtrinsicsChange> refine_extrinsics(Rig& rig, const std::map<int, cv::Mat>& depth,
                                                const StaticModelOptions& o) {
  std::vector<ExtrinsicsChange> changes;
  if (rig.cameras.empty()) return changes;
  const CameraCalib& ref = rig.cameras[0];
  auto rd = depth.find(ref.id);
  if (rd == depth.end()) throw Error("refine_extrinsics: no depth for the reference camera " + std::to_string(ref.id));
  const cv::Mat ref_pts = depth_points(rd->second, ref);
  const cv::Mat ref_n = depth_normals(ref_pts);
  for (size_t ci = 1; ci < rig.cameras.size(); ++ci) {
    CameraCalib& cam = rig.cameras[ci];
    auto d = depth.find(cam.id);
    if (d == depth.end()) continue;
    std::vector<Eigen::Vector3d> src;
    for (int v = 0; v < d->second.rows; v += o.icp_stride)
      for (int u = 0; u < d->second.cols; u += o.icp_stride)
        if (int z = d->second.at<uint16_t>(v, u)) src.push_back(cam.unproject(u, v, z * 0.001));
    Eigen::Isometry3d T = ref.cam_to_rig.inverse() * cam.cam_to_rig;  // cam -> ref
    const Eigen::Isometry3d T0 = T;
    ExtrinsicsChange ch;
    ch.camera_id = cam.id;
    double robust_c = o.icp_max_distance_m;
    for (int it = 0; it < o.icp_iterations; ++it) {
      const double maxd = std::max(0.03, o.icp_max_distance_m * std::pow(0.9, it));
      Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      double sse = 0;
      int n = 0;
      for (const Eigen::Vector3d& s : src) {
        const Eigen::Vector3d q = T * s;
        const auto px = ref.project(q);
        if (!px) continue;
        const int u = static_cast<int>(std::lround(px->x())), v = static_cast<int>(std::lround(px->y()));
        if (u < 0 || v < 0 || u >= ref_pts.cols || v >= ref_pts.rows) continue;
        const cv::Vec3f rp = ref_pts.at<cv::Vec3f>(v, u), rn = ref_n.at<cv::Vec3f>(v, u);
        if (std::isnan(rp[0]) || std::isnan(rn[0])) continue;
        const Eigen::Vector3d r(rp[0], rp[1], rp[2]), nn(rn[0], rn[1], rn[2]);
        if ((q - r).norm() > maxd) continue;
        const double e = nn.dot(q - r);
        // Tukey weights: occlusion boundaries and flying pixels pair wrong surfaces.
        const double ur = e / robust_c;
        if (std::abs(ur) >= 1) continue;
        const double wt = (1 - ur * ur) * (1 - ur * ur);
        Eigen::Matrix<double, 6, 1> J;
        J << q.cross(nn), nn;
        A += wt * J * J.transpose();
        b += wt * J * e;
        sse += e * e;
        ++n;
      }
      if (n < 6) break;
      const double rms = std::sqrt(sse / n) * 1000.0;
      robust_c = std::max(0.01, 3.0 * rms / 1000.0);
      if (it == 0) ch.rms_before_mm = rms;
      ch.rms_after_mm = rms;
      ch.pairs = n;
      const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(-b);
      const Eigen::Vector3d w = x.head<3>();
      Eigen::Isometry3d dT = Eigen::Isometry3d::Identity();
      if (w.norm() > 1e-12) dT.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
      dT.translation() = x.tail<3>();
      T = dT * T;
      if (x.norm() < 1e-7) break;
    }
    const Eigen::Isometry3d delta = T * T0.inverse();
    ch.translation_mm = delta.translation().norm() * 1000.0;
    ch.rotation_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / M_PI;
    cam.cam_to_rig = ref.cam_to_rig * T;
    // Keep the rotation exactly orthonormal for the rig file.
    cam.cam_to_rig.linear() = Eigen::Quaterniond(cam.cam_to_rig.linear()).normalized().toRotationMatrix();
    changes.push_back(ch);
  }
  return changes;
}

namespace {

// V-DA's plane finding with the model's options.
PlaneFinding plane_finding_of(const StaticModelOptions& o) {
  PlaneFinding f;
  f.distance_m = o.plane_distance_m;
  f.max_planes = o.max_planes;
  f.min_share = o.min_plane_share;
  f.iterations = o.ransac_iterations;
  f.seed = o.seed;
  return f;
}

}  // namespace

namespace {

// The room's bounding planes: walls, floor and ceiling have (nearly) all
// the fused points on the viewpoint's side; a desk or a chair back has points
// on both sides. Plus an assumed ceiling where none was found.
std::vector<RoomPlane> room_boundary(const std::vector<RoomPlane>& planes, const std::vector<Eigen::Vector3f>& points,
                                     const Eigen::Vector3d& viewpoint, const StaticModelOptions& o) {
  std::vector<RoomPlane> bounds;
  if (points.empty()) return bounds;
  const double beyond = 2 * o.plane_distance_m;
  const size_t allowed = static_cast<size_t>(o.boundary_outlier_share * points.size());
  for (const RoomPlane& p : planes) {
    // find_planes turned every normal towards the viewpoint.
    size_t outside = 0;
    for (const Eigen::Vector3f& q : points) outside += p.normal.dot(q.cast<double>()) + p.offset < -beyond;
    if (outside <= allowed) bounds.push_back(p);
  }
  // The rig frame has Y up (DESIGN.md 2.2); a floor found among the bounds
  // says it really does, and only then is a ceiling assumed.
  auto facing = [&](double y) {
    return std::any_of(bounds.begin(), bounds.end(), [y](const RoomPlane& p) { return p.normal.y() * y > 0.9; });
  };
  if (facing(+1) && !facing(-1)) {
    // Nothing measured overhead (too grazing for the sensors): the ceiling
    // is assumed level, where the room's walls end at the top (the highest
    // of their points, but for a few strays).
    std::vector<float> heights;
    for (const RoomPlane& b : bounds) {
      if (std::abs(b.normal.y()) > 0.3) continue;  // walls only
      for (const Eigen::Vector3f& q : points)
        if (std::abs(b.normal.dot(q.cast<double>()) + b.offset) < o.plane_distance_m) heights.push_back(q.y());
    }
    if (heights.empty()) return bounds;
    const size_t k = std::min(heights.size() - 1, static_cast<size_t>(0.999 * heights.size()));
    std::nth_element(heights.begin(), heights.begin() + k, heights.end());
    const double top = heights[k];
    if (top > viewpoint.y()) {
      RoomPlane ceiling;
      ceiling.normal = -Eigen::Vector3d::UnitY();
      ceiling.offset = top;  // -y + top >= 0 below it
      ceiling.name = "ceiling";
      ceiling.inliers = 0;  // assumed, not measured
      bounds.push_back(ceiling);
    }
  }
  return bounds;
}

// The model's offline completion of a sparse image (CV_16UC1, 0 unknown) guided
// by the camera's colour: image-guided fill without its median, then
// colorization over `unknown`; the same for the prior's depth and for the
// on-the-bound mark below.
cv::Mat complete_offline(const cv::Mat& sparse, const cv::Mat& color, const cv::Mat& unknown,
                         const StaticModelOptions& o) {
  GuidedCompletionParams guided = o.guided;
  guided.median = false;
  cv::Mat filled;
  guided_completion(sparse, color, guided, filled);
  colorization_fill(filled, color, unknown, o.colorize);
  return filled;
}

// Each pixel's depth (mm) where its ray leaves the room through the nearest of
// its bounding planes (0: through none), and which of those planes is the
// assumed ceiling.
struct RoomBound {
  cv::Mat depth;    // CV_32FC1
  cv::Mat assumed;  // CV_8UC1, nonzero: the bound is the assumed ceiling
};

RoomBound room_bound(const std::vector<RoomPlane>& bounds, const CameraCalib& cam) {
  RoomBound rb{cv::Mat(cam.height, cam.width, CV_32FC1, cv::Scalar(0)),
               cv::Mat(cam.height, cam.width, CV_8UC1, cv::Scalar(0))};
  std::vector<Eigen::Vector4d> pc;
  for (const RoomPlane& b : bounds) pc.push_back(plane_in_camera(b, cam));
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      double nearest = 0;
      bool assumed = false;
      for (size_t i = 0; i < pc.size(); ++i) {
        const double z = plane_depth_mm(pc[i], cam, u, v);
        if (z > 0 && (nearest == 0 || z < nearest)) nearest = z, assumed = bounds[i].inliers == 0;
      }
      if (nearest > 0 && nearest < 65535) {
        rb.depth.at<float>(v, u) = static_cast<float>(nearest);
        rb.assumed.at<uint8_t>(v, u) = assumed ? 255 : 0;
      }
    }
  return rb;
}

// Whether each unmeasured pixel lies on the room's bound or on something in
// front of it, decided as its depth is: propagated from the measured pixels by
// colour (the same completion). The depth's completion stretches a
// neighbour's depth flat across an unmeasured strip (a window's mullion
// between panes that give no depth), which on a wall seen at a slant puts
// the strip in front of the wall; a pixel whose nearest look-alikes lie on
// the wall takes the wall's depth instead (docs/vda.md).
cv::Mat on_the_bound(const cv::Mat& measured_depth, const cv::Mat& color, const cv::Mat& unknown,
                     const RoomBound& rb, const StaticModelOptions& o) {
  // 1000: in front of the bound, 2000: on it or beyond; 0: unknown (and where
  // no bound is, no vote). The completion never mixes the two marks (its
  // "agree" tolerance, 30 mm or 3 %, is far below their difference) and the
  // colorization blends them, so 1500 splits the result.
  constexpr uint16_t kInFront = 1000, kOnBound = 2000;
  static_assert(kOnBound - kInFront > 2 * 30, "the marks must not agree within the completion's tolerance");
  cv::Mat side(measured_depth.size(), CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < side.rows; ++v)
    for (int u = 0; u < side.cols; ++u) {
      const uint16_t d = measured_depth.at<uint16_t>(v, u);
      const float b = rb.depth.at<float>(v, u);
      if (!d || b <= 0) continue;
      side.at<uint16_t>(v, u) = d < b - o.plane_tolerance.at(int(b)) ? kInFront : kOnBound;
    }
  const cv::Mat filled = complete_offline(side, color, unknown, o);
  cv::Mat on;
  cv::compare(filled, (kInFront + kOnBound) / 2, on, cv::CMP_GT);
  return on & unknown;
}

// Unmeasured prior pixels (unknown != 0) beyond the room's nearest bounding
// plane along their ray are moved onto it; so are those judged to lie on it
// (`on_bound`) from no more than `max_pull` of its depth in front of it (a
// depth stretched flat strays from a slanted wall by a few per cent; an
// unmeasured chair seat that looks like the floor stands farther in front of
// it and stays); and those whose ray leaves the room through the assumed
// ceiling are put on it.
void close_room(cv::Mat& prior, const cv::Mat& unknown, const cv::Mat& on_bound, const RoomBound& rb,
                double max_pull) {
  for (int v = 0; v < prior.rows; ++v)
    for (int u = 0; u < prior.cols; ++u) {
      if (!unknown.at<uint8_t>(v, u)) continue;
      const float nearest = rb.depth.at<float>(v, u);
      uint16_t& d = prior.at<uint16_t>(v, u);
      // Beyond the room nothing is seen; and overhead, where nothing was
      // measured at all, the completion only spread the walls' depth: the
      // assumed ceiling is the better guess there.
      const bool on = !on_bound.empty() && on_bound.at<uint8_t>(v, u) && nearest - d <= max_pull * nearest;
      if (nearest > 0 && (d == 0 || d > nearest || rb.assumed.at<uint8_t>(v, u) || on))
        d = static_cast<uint16_t>(std::lround(nearest));
    }
}

}  // namespace

cv::Mat splat_depth(const std::vector<Eigen::Vector3f>& points, const CameraCalib& cam, double voxel_m) {
  cv::Mat z(cam.height, cam.width, CV_16UC1, cv::Scalar(0));
  const Eigen::Isometry3d to_cam = cam.cam_to_rig.inverse();
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3d q = to_cam * p.cast<double>();
    if (q.z() <= 0.05) continue;
    const auto px = cam.project(q);
    if (!px) continue;
    const int r = static_cast<int>(std::ceil(cam.fx * voxel_m / q.z() / 2.0));
    const int u0 = static_cast<int>(std::lround(px->x())), v0 = static_cast<int>(std::lround(px->y()));
    const int zmm = static_cast<int>(std::lround(q.z() * 1000.0));
    if (zmm > 65535) continue;
    for (int v = std::max(0, v0 - r); v <= std::min(cam.height - 1, v0 + r); ++v)
      for (int u = std::max(0, u0 - r); u <= std::min(cam.width - 1, u0 + r); ++u) {
        uint16_t& o = z.at<uint16_t>(v, u);
        if (!o || zmm < o) o = static_cast<uint16_t>(zmm);
      }
  }
  // Points of hidden surfaces show through the gaps between the splats of
  // nearer ones: drop pixels much farther than the nearest splat around them.
  cv::Mat inv(z.size(), CV_16UC1), near_inv;
  for (int v = 0; v < z.rows; ++v)
    for (int u = 0; u < z.cols; ++u) {
      const int d = z.at<uint16_t>(v, u);
      inv.at<uint16_t>(v, u) = d ? static_cast<uint16_t>(65535 - d) : 0;
    }
  cv::dilate(inv, near_inv, cv::Mat::ones(7, 7, CV_8U));
  for (int v = 0; v < z.rows; ++v)
    for (int u = 0; u < z.cols; ++u) {
      uint16_t& d = z.at<uint16_t>(v, u);
      const int nearest = 65535 - near_inv.at<uint16_t>(v, u);
      if (d && d > nearest * 1.05 + 20) d = 0;
    }
  return z;
}

StaticModel build_static_model(const Rig& rig, const std::vector<CameraCapture>& captures,
                               const StaticModelOptions& o) {
  StaticModel m;
  m.rig = rig;
  std::map<int, cv::Mat> depth;
  std::map<int, cv::Mat> color;
  for (const CameraCapture& c : captures) {
    const CameraCalib* cam = rig.find(c.camera_id);
    if (!cam) throw Error("static model: capture of camera " + std::to_string(c.camera_id) + " is not in the rig");
    if (c.depth.empty()) throw Error("static model: camera " + std::to_string(c.camera_id) + " has no depth frames");
    for (const cv::Mat& d : c.depth)
      if (d.cols != cam->width || d.rows != cam->height || d.type() != CV_16UC1)
        throw Error("static model: camera " + std::to_string(c.camera_id) + " depth is " + std::to_string(d.cols) +
                    "x" + std::to_string(d.rows) + ", the rig says " + std::to_string(cam->width) + "x" +
                    std::to_string(cam->height));
    depth[c.camera_id] = median_depth(c.depth);
    color[c.camera_id] = c.color;
  }
  for (const CameraCalib& cam : rig.cameras)
    if (!depth.count(cam.id)) throw Error("static model: no capture of camera " + std::to_string(cam.id));
  if (o.refine_extrinsics) m.refinement = refine_extrinsics(m.rig, depth, o);

  // Fusion: every camera's median depth in the rig frame, averaged per voxel.
  struct Acc {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    int n = 0;
  };
  std::unordered_map<int64_t, Acc> grid;
  const double inv_voxel = 1.0 / o.voxel_m;
  for (const CameraCalib& cam : m.rig.cameras) {
    const cv::Mat& d = depth[cam.id];
    const cv::Mat& col = color[cam.id];
    for (int v = 0; v < d.rows; v += 2)
      for (int u = 0; u < d.cols; u += 2) {
        const int z = d.at<uint16_t>(v, u);
        if (!z) continue;
        const Eigen::Vector3d p = cam.cam_to_rig * cam.unproject(u, v, z * 0.001);
        const int64_t ix = static_cast<int64_t>(std::floor(p.x() * inv_voxel)) + (1 << 20);
        const int64_t iy = static_cast<int64_t>(std::floor(p.y() * inv_voxel)) + (1 << 20);
        const int64_t iz = static_cast<int64_t>(std::floor(p.z() * inv_voxel)) + (1 << 20);
        Acc& a = grid[(ix << 42) | (iy << 21) | iz];
        a.p += p;
        if (!col.empty()) {
          const cv::Vec3b c = col.at<cv::Vec3b>(v, u);
          a.c += Eigen::Vector3d(c[0], c[1], c[2]);
        }
        ++a.n;
      }
  }
  m.points.reserve(grid.size());
  m.colors.reserve(grid.size());
  for (const auto& [key, a] : grid) {
    (void)key;
    m.points.push_back((a.p / a.n).cast<float>());
    const Eigen::Vector3d c = a.c / a.n;
    m.colors.emplace_back(cv::saturate_cast<uint8_t>(c.x()), cv::saturate_cast<uint8_t>(c.y()),
                          cv::saturate_cast<uint8_t>(c.z()));
  }
  m.planes = find_planes(m.points, m.rig.cameras[0].center_in_rig(), plane_finding_of(o));
  const std::vector<RoomPlane> bounds =
      o.close_room ? room_boundary(m.planes, m.points, m.rig.cameras[0].center_in_rig(), o) : std::vector<RoomPlane>();
  for (const RoomPlane& b : bounds)
    if (b.inliers == 0) m.planes.push_back(b);  // the assumed ceiling, so the prior's ceiling is snapped to it

  // Priors: the camera's own median depth, holes filled from the fused cloud,
  // then offline completion guided by the camera's colour, then plane snapping.
  for (const CameraCalib& cam : m.rig.cameras) {
    cv::Mat prior = depth[cam.id].clone();
    if (o.fill_from_other_cameras) {
      const cv::Mat splat = splat_depth(m.points, cam, o.voxel_m);
      for (int v = 0; v < prior.rows; ++v)
        for (int u = 0; u < prior.cols; ++u)
          if (!prior.at<uint16_t>(v, u)) prior.at<uint16_t>(v, u) = splat.at<uint16_t>(v, u);
    }
    cv::Mat unknown;
    cv::compare(prior, 0, unknown, cv::CMP_EQ);
    m.prior_measured[cam.id] = unknown == 0;
    const cv::Mat& col = color[cam.id].empty() ? cv::Mat() : color[cam.id];
    // The same order as per frame (depth_complete): the median last.
    cv::Mat filled = complete_offline(prior, col, unknown, o);
    if (o.guided.median) filled_median(filled, unknown, o.guided.median_size, col, o.guided.median_color_distance);
    if (!bounds.empty()) {
      const RoomBound rb = room_bound(bounds, cam);
      const cv::Mat on = o.unmeasured_side_by_colour && !col.empty() ? on_the_bound(prior, col, unknown, rb, o)
                                                                      : cv::Mat();
      close_room(filled, unknown, on, rb, o.unmeasured_max_pull);
    }
    if (o.snap_planes) {
      const PlaneMaps maps = plane_maps_for_camera(m.planes, cam, filled, o.plane_tolerance);
      plane_refine(filled, maps, cv::Mat(), o.plane_tolerance, filled);
    }
    m.prior_depth[cam.id] = filled;
    if (!col.empty()) m.prior_color[cam.id] = col;
  }
  return m;
}

bool align_model_to_room(StaticModel& m) {
  const RoomPlane* floor = nullptr;
  const RoomPlane* wall = nullptr;
  for (const RoomPlane& p : m.planes) {
    if (p.name == "floor") floor = &p;
    if (p.name == "wall" && (!wall || p.inliers > wall->inliers)) wall = &p;
  }
  if (!floor) return false;
  const Eigen::Vector3d y = floor->normal.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  if (wall) x = y.cross(wall->normal);
  x = (x - x.dot(y) * y).normalized();
  if (x.x() < 0) x = -x;  // keep X roughly where it was
  const Eigen::Vector3d z = x.cross(y);
  Eigen::Matrix3d r;
  r.row(0) = x.transpose();
  r.row(1) = y.transpose();
  r.row(2) = z.transpose();
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  a.linear() = r;
  for (CameraCalib& c : m.rig.cameras) {
    c.cam_to_rig = a * c.cam_to_rig;
    c.cam_to_rig.linear() = Eigen::Quaterniond(c.cam_to_rig.linear()).normalized().toRotationMatrix();
  }
  for (RoomPlane& p : m.planes) p.normal = r * p.normal;
  for (Eigen::Vector3f& p : m.points) p = (r * p.cast<double>()).cast<float>();
  return true;
}

void write_ply(const std::string& path, const std::vector<Eigen::Vector3f>& points,
               const std::vector<cv::Vec3b>& colors) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot write");
  f << "ply\nformat binary_little_endian 1.0\ncomment gst-vclassroom static classroom model, rig frame, metres\n"
    << "element vertex " << points.size()
    << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  for (size_t i = 0; i < points.size(); ++i) {
    f.write(reinterpret_cast<const char*>(points[i].data()), 3 * sizeof(float));
    const cv::Vec3b c = i < colors.size() ? colors[i] : cv::Vec3b(200, 200, 200);
    f.write(reinterpret_cast<const char*>(&c[0]), 3);
  }
  if (!f) throw Error(path + ": write failed");
}

void save_static_model(const StaticModel& m, const std::string& folder) {
  make_dir(folder);
  make_dir(folder + "/prior-depth");
  save_rig(m.rig, folder + "/rig.yaml");
  {
    std::ofstream f(folder + "/planes.csv");
    if (!f) throw Error(folder + "/planes.csv: cannot write");
    f.precision(17);
    f << "name,nx,ny,nz,offset_m,inliers\n";
    for (const RoomPlane& p : m.planes)
      f << p.name << ',' << p.normal.x() << ',' << p.normal.y() << ',' << p.normal.z() << ',' << p.offset << ','
        << p.inliers << '\n';
  }
  {
    std::ofstream f(folder + "/refinement.csv");
    f << "camera,translation_mm,rotation_deg,pairs,rms_before_mm,rms_after_mm\n";
    for (const ExtrinsicsChange& c : m.refinement)
      f << c.camera_id << ',' << c.translation_mm << ',' << c.rotation_deg << ',' << c.pairs << ',' << c.rms_before_mm
        << ',' << c.rms_after_mm << '\n';
  }
  for (const auto& [id, prior] : m.prior_depth)
    if (!cv::imwrite(prior_path(folder, id), prior)) throw Error(prior_path(folder, id) + ": cannot write");
  if (!m.prior_measured.empty()) make_dir(folder + "/prior-measured");
  for (const auto& [id, mask] : m.prior_measured)
    if (!cv::imwrite(measured_path(folder, id), mask)) throw Error(measured_path(folder, id) + ": cannot write");
  if (!m.prior_color.empty()) make_dir(folder + "/prior-color");
  for (const auto& [id, col] : m.prior_color) {
    cv::Mat bgr;
    cv::cvtColor(col, bgr, cv::COLOR_RGB2BGR);
    if (!cv::imwrite(color_path(folder, id), bgr)) throw Error(color_path(folder, id) + ": cannot write");
  }
  if (!m.points.empty()) write_ply(folder + "/fused.ply", m.points, m.colors);
}

std::string model_stream_mismatch(const StaticModel& m, const std::string& folder, int camera_id, int width,
                                  int height) {
  const CameraCalib* cam = m.rig.find(camera_id);
  if (!cam) {
    std::string ids;
    for (const CameraCalib& c : m.rig.cameras) ids += (ids.empty() ? "" : ", ") + std::to_string(c.id);
    return "static model folder '" + folder + "' has no camera " + std::to_string(camera_id) +
           " (the stream's camera-id); it has camera(s) " + ids;
  }
  if (cam->width == width && cam->height == height) return "";
  return "static model folder '" + folder + "': camera " + std::to_string(cam->id) + " is " +
         std::to_string(cam->width) + "x" + std::to_string(cam->height) + " but the stream is " +
         std::to_string(width) + "x" + std::to_string(height) + " (rebuild the model at the stream's size)";
}

StaticModel load_static_model(const std::string& folder) {
  const std::string where = "static model folder '" + folder + "'";
  if (folder.empty()) throw Error("static model: no model folder given");
  if (!is_dir(folder)) throw Error(where + ": no such folder");
  StaticModel m;
  try {
    m.rig = load_rig(folder + "/rig.yaml");
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  std::ifstream f(folder + "/planes.csv");
  if (!f) throw Error(where + ": planes.csv is missing");
  std::string line;
  std::getline(f, line);
  int n = 1;
  // A room has a handful of planes; a file with thousands is not a model.
  constexpr size_t kMaxPlanes = 1000;
  while (std::getline(f, line)) {
    ++n;
    if (line.empty()) continue;
    if (m.planes.size() >= kMaxPlanes)
      throw Error(where + ": planes.csv line " + std::to_string(n) + ": more than " + std::to_string(kMaxPlanes) +
                  " planes");
    std::stringstream ss(line);
    std::string field;
    std::vector<std::string> fields;
    while (fields.size() <= 6 && std::getline(ss, field, ',')) fields.push_back(field);
    RoomPlane p;
    try {
      if (fields.size() != 6) throw std::invalid_argument("fields");
      p.name = fields[0];
      p.normal = Eigen::Vector3d(std::stod(fields[1]), std::stod(fields[2]), std::stod(fields[3]));
      p.offset = std::stod(fields[4]);
      p.inliers = std::stoi(fields[5]);
    } catch (const std::exception&) {  // std::stod/stoi: invalid_argument, out_of_range
      throw Error(where + ": planes.csv line " + std::to_string(n) +
                  ": expected name,nx,ny,nz,offset_m,inliers, got '" + line.substr(0, 200) + "'");
    }
    if (!p.normal.allFinite() || !std::isfinite(p.offset) || p.inliers < 0)
      throw Error(where + ": planes.csv line " + std::to_string(n) + ": expected finite numbers and inliers >= 0");
    if (std::abs(p.normal.norm() - 1.0) > 1e-3)
      throw Error(where + ": planes.csv line " + std::to_string(n) + ": the normal is not a unit vector");
    m.planes.push_back(p);
  }
  // Images through the dataset reader: sizes checked (a PNG from its header,
  // before decoding), OpenCV's exceptions turned into Errors naming the file.
  auto exists = [](const std::string& p) {
    struct stat st;
    return stat(p.c_str(), &st) == 0;
  };
  for (const CameraCalib& cam : m.rig.cameras) {
    const cv::Size size(cam.width, cam.height);
    const std::string camera_name = "rig.yaml's camera " + std::to_string(cam.id);
    const std::string path = prior_path(folder, cam.id);
    if (!exists(path))
      throw Error(where + ": prior depth of camera " + std::to_string(cam.id) + " (" + path + ") is missing");
    try {
      cv::Mat prior = read_image(path, cv::IMREAD_UNCHANGED, "prior depth", size, camera_name);
      if (prior.type() != CV_16UC1) throw Error(path + " is not a 16-bit single-channel depth image (mm)");
      m.prior_depth[cam.id] = prior;
      // Optional: without it every prior pixel counts as measured.
      if (exists(measured_path(folder, cam.id)))
        m.prior_measured[cam.id] =
            read_image(measured_path(folder, cam.id), cv::IMREAD_GRAYSCALE, "measured mask", size, camera_name);
      // Optional: without it depthcomplete skips its colour test.
      if (exists(color_path(folder, cam.id))) {
        const cv::Mat bgr = read_color_image(color_path(folder, cam.id), "prior colour", size, camera_name);
        cv::Mat rgb;
        cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
        m.prior_color[cam.id] = rgb;
      }
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
  }
  return m;
}

}  // namespace vclassroom
