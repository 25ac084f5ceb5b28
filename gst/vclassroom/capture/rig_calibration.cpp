#include <gst/vclassroom/capture/rig_calibration.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/planes.h>

namespace vclassroom {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

namespace {

// Assumed measurement noise, which weighs corners against depth in the
// adjustment: sub-pixel corners, and a consumer sensor's depth noise.
constexpr double kCornerSigmaPx = 0.2;
double depth_sigma_m(double z_m) { return 0.001 + 0.001 * z_m * z_m; }
// Residuals beyond this many sigmas count linearly (Huber): a flying pixel
// or a mis-refined corner cannot pull the rig.
constexpr double kHuber = 3.0;

std::string camera_label(const CameraCalib& c) {
  return "camera " + std::to_string(c.id) + (c.name.empty() ? "" : " (" + c.name + ")");
}

// The pose T moved by delta in its own frame: T * exp(delta), rotation first.
Isometry3d perturbed(const Isometry3d& t, const Vector6d& delta) {
  Isometry3d d = Isometry3d::Identity();
  const Vector3d w = delta.head<3>();
  if (w.norm() > 0) d.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  d.translation() = delta.tail<3>();
  return t * d;
}

Isometry3d from_rvec_tvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  Isometry3d t = Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) t.linear()(i, j) = r(i, j);
    t.translation()(i) = tvec[i];
  }
  return t;
}

double rotation_deg(const Matrix3d& a, const Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

// The data of one camera's sighting, in the ideal pinhole camera.
struct Observation {
  int camera = 0, view = 0;
  std::vector<Eigen::Vector2d> corners;  // undistorted pixels
  std::vector<Vector3d> depth_points;    // camera frame, metres
  Isometry3d board_to_camera;            // from this sighting alone
};

struct Intrinsics {
  double fx, fy, cx, cy;
};

// Residuals of one observation given its camera's and its view's pose (both
// to the reference camera), in sigmas: corners, then depth points.
void observation_residuals(const Observation& o, const Intrinsics& k, const std::vector<cv::Point3f>& board,
                           const Isometry3d& cam_to_ref, const Isometry3d& board_to_ref, bool use_depth,
                           Eigen::VectorXd* r) {
  const Isometry3d b2c = cam_to_ref.inverse() * board_to_ref;
  const size_t nc = o.corners.size(), nd = use_depth ? o.depth_points.size() : 0;
  r->resize(Eigen::Index(2 * nc + nd));
  for (size_t i = 0; i < nc; ++i) {
    const Vector3d p = b2c * Vector3d(board[i].x, board[i].y, board[i].z);
    const double z = std::max(p.z(), 1e-6);
    (*r)(Eigen::Index(2 * i)) = (k.fx * p.x() / z + k.cx - o.corners[i].x()) / kCornerSigmaPx;
    (*r)(Eigen::Index(2 * i + 1)) = (k.fy * p.y() / z + k.cy - o.corners[i].y()) / kCornerSigmaPx;
  }
  if (!nd) return;
  const Vector3d n = b2c.linear().col(2);
  const double d = n.dot(b2c.translation());
  for (size_t j = 0; j < nd; ++j) {
    const Vector3d& p = o.depth_points[j];
    (*r)(Eigen::Index(2 * nc + j)) = (n.dot(p) - d) / depth_sigma_m(p.z());
  }
}

double huber_weight(double r) { return std::abs(r) <= kHuber ? 1.0 : kHuber / std::abs(r); }

double robust_cost(const Eigen::VectorXd& r) {
  double c = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    const double a = std::abs(r(i));
    c += a <= kHuber ? 0.5 * a * a : kHuber * (a - 0.5 * kHuber);
  }
  return c;
}

// Bundle adjustment of the camera poses (all but the reference) and the
// board poses, by Levenberg-Marquardt with the views eliminated by their
// Schur complement (each view touches only its own 6 parameters).
class Adjustment {
 public:
  Adjustment(const std::vector<Observation>& obs, const std::vector<Intrinsics>& k,
             const std::vector<cv::Point3f>& board, int reference, bool use_depth, std::vector<Isometry3d>* cams,
             std::map<int, Isometry3d>* views)
      : obs_(obs), k_(k), board_(board), ref_(reference), depth_(use_depth), cams_(cams), views_(views) {
    for (const auto& [v, pose] : *views_) view_index_[v] = int(view_index_.size());
    for (int c = 0; c < int(cams_->size()); ++c)
      if (c != ref_) cam_index_[c] = int(cam_index_.size());
  }

  void run(int iterations) {
    double lambda = 1e-3;
    double cost = total_cost(*cams_, *views_);
    for (int it = 0; it < iterations; ++it) {
      const int nc = int(cam_index_.size()), nv = int(view_index_.size());
      Eigen::MatrixXd hcc = Eigen::MatrixXd::Zero(6 * nc, 6 * nc);
      Eigen::VectorXd gc = Eigen::VectorXd::Zero(6 * nc);
      std::vector<Matrix6d> hvv(size_t(nv), Matrix6d::Zero());
      std::vector<Vector6d> gv(size_t(nv), Vector6d::Zero());
      std::map<std::pair<int, int>, Matrix6d> hcv;  // (camera index, view index)
      for (const Observation& o : obs_) {
        const Isometry3d& tc = (*cams_)[size_t(o.camera)];
        const Isometry3d& wv = views_->at(o.view);
        Eigen::VectorXd r;
        observation_residuals(o, k_[size_t(o.camera)], board_, tc, wv, depth_, &r);
        Eigen::VectorXd w(r.size());
        for (Eigen::Index i = 0; i < r.size(); ++i) w(i) = huber_weight(r(i));
        const bool cam_free = o.camera != ref_;
        Eigen::MatrixXd jc(r.size(), 6), jv(r.size(), 6);
        for (int p = 0; p < 6; ++p) {
          Vector6d d = Vector6d::Zero();
          d(p) = 1e-6;
          Eigen::VectorXd rp, rm;
          if (cam_free) {
            observation_residuals(o, k_[size_t(o.camera)], board_, perturbed(tc, d), wv, depth_, &rp);
            observation_residuals(o, k_[size_t(o.camera)], board_, perturbed(tc, -d), wv, depth_, &rm);
            jc.col(p) = (rp - rm) / 2e-6;
          }
          observation_residuals(o, k_[size_t(o.camera)], board_, tc, perturbed(wv, d), depth_, &rp);
          observation_residuals(o, k_[size_t(o.camera)], board_, tc, perturbed(wv, -d), depth_, &rm);
          jv.col(p) = (rp - rm) / 2e-6;
        }
        const int vi = view_index_.at(o.view);
        const Eigen::MatrixXd wjv = w.asDiagonal() * jv;
        hvv[size_t(vi)] += jv.transpose() * wjv;
        gv[size_t(vi)] += wjv.transpose() * r;
        if (cam_free) {
          const int ci = cam_index_.at(o.camera);
          const Eigen::MatrixXd wjc = w.asDiagonal() * jc;
          hcc.block<6, 6>(6 * ci, 6 * ci) += jc.transpose() * wjc;
          gc.segment<6>(6 * ci) += wjc.transpose() * r;
          auto [slot, fresh] = hcv.try_emplace({ci, vi}, Matrix6d::Zero());
          slot->second += jc.transpose() * wjv;
        }
      }
      bool improved = false;
      for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
        // Damped normal equations; the views are eliminated first.
        std::vector<Matrix6d> hvv_inv(static_cast<size_t>(nv));
        for (int v = 0; v < nv; ++v) {
          Matrix6d h = hvv[size_t(v)];
          h.diagonal() *= 1 + lambda;
          h.diagonal().array() += 1e-9;
          hvv_inv[size_t(v)] = h.inverse();
        }
        Eigen::MatrixXd s = hcc;
        s.diagonal() *= 1 + lambda;
        s.diagonal().array() += 1e-9;
        Eigen::VectorXd b = -gc;
        for (const auto& [key, h] : hcv) {
          const auto [ci, vi] = key;
          b.segment<6>(6 * ci) += h * hvv_inv[size_t(vi)] * gv[size_t(vi)];
          for (const auto& [key2, h2] : hcv)
            if (key2.second == vi)
              s.block<6, 6>(6 * ci, 6 * key2.first) -= h * hvv_inv[size_t(vi)] * h2.transpose();
        }
        const Eigen::VectorXd dc = nc ? Eigen::VectorXd(s.ldlt().solve(b)) : Eigen::VectorXd();
        std::vector<Isometry3d> new_cams = *cams_;
        for (const auto& [c, ci] : cam_index_) new_cams[size_t(c)] = perturbed((*cams_)[size_t(c)], dc.segment<6>(6 * ci));
        std::map<int, Isometry3d> new_views = *views_;
        for (const auto& [v, vi] : view_index_) {
          Vector6d rhs = -gv[size_t(vi)];
          for (const auto& [key, h] : hcv)
            if (key.second == vi) rhs -= h.transpose() * dc.segment<6>(6 * key.first);
          new_views[v] = perturbed(views_->at(v), hvv_inv[size_t(vi)] * rhs);
        }
        const double new_cost = total_cost(new_cams, new_views);
        if (std::isfinite(new_cost) && new_cost < cost) {
          improved = true;
          const double gain = cost - new_cost;
          *cams_ = std::move(new_cams);
          *views_ = std::move(new_views);
          cost = new_cost;
          lambda = std::max(lambda / 10, 1e-9);
          if (gain < 1e-9 * cost) return;
        } else {
          lambda *= 10;
        }
      }
      if (!improved) return;
    }
  }

 private:
  double total_cost(const std::vector<Isometry3d>& cams, const std::map<int, Isometry3d>& views) const {
    double c = 0;
    Eigen::VectorXd r;
    for (const Observation& o : obs_) {
      observation_residuals(o, k_[size_t(o.camera)], board_, cams[size_t(o.camera)], views.at(o.view), depth_, &r);
      c += robust_cost(r);
    }
    return c;
  }

  const std::vector<Observation>& obs_;
  const std::vector<Intrinsics>& k_;
  const std::vector<cv::Point3f>& board_;
  int ref_;
  bool depth_;
  std::vector<Isometry3d>* cams_;
  std::map<int, Isometry3d>* views_;
  std::map<int, int> view_index_, cam_index_;
};

// The room's planes in one camera's depth (V-DA's plane finder, in the
// camera's frame: normals towards the camera), and its points, every third
// pixel each way.
struct RoomView {
  std::vector<Eigen::Vector3f> points;
  std::vector<RoomPlane> planes;
};

// The plane with most points whose normal passes `accept`; nullptr if none.
template <class Accept>
const RoomPlane* largest_plane(const std::vector<RoomPlane>& planes, Accept accept) {
  const RoomPlane* best = nullptr;
  for (const RoomPlane& p : planes)
    if (accept(p.normal) && (!best || p.inliers > best->inliers)) best = &p;
  return best;
}

RoomView room_view(const CameraCalib& cam, const cv::Mat& depth_mm) {
  RoomView view;
  if (depth_mm.empty() || depth_mm.type() != CV_16UC1) return view;
  for (int v = 0; v < depth_mm.rows; v += 3) {
    const uint16_t* row = depth_mm.ptr<uint16_t>(v);
    for (int u = 0; u < depth_mm.cols; u += 3)
      if (row[u]) view.points.push_back(cam.unproject(u, v, row[u] * 0.001).cast<float>());
  }
  view.planes = find_planes(view.points, Vector3d::Zero(), PlaneFinding());
  return view;
}

}  // namespace

std::vector<cv::Point3f> board_depth_samples(const CalibrationBoard& board, const std::vector<cv::Point2f>& corners,
                                             const cv::Mat& depth_mm) {
  std::vector<cv::Point3f> out;
  if (int(corners.size()) != board.corner_count() || depth_mm.type() != CV_16UC1) return out;
  std::vector<cv::Point2f> plane;
  for (const auto& p : board.corners()) plane.emplace_back(p.x, p.y);
  const cv::Mat h = cv::findHomography(plane, corners);
  if (h.empty()) return out;
  std::vector<cv::Point2f> on_board, in_image;
  for (int j = 0; j + 1 < board.inner_rows; ++j)
    for (int i = 0; i + 1 < board.inner_cols; ++i)
      for (double fy : {0.25, 0.75})
        for (double fx : {0.25, 0.75})
          on_board.emplace_back(float((i + fx) * board.square_m), float((j + fy) * board.square_m));
  cv::perspectiveTransform(on_board, in_image, h);
  for (const auto& p : in_image) {
    const int u = int(std::lround(p.x)), v = int(std::lround(p.y));
    if (u < 0 || v < 0 || u >= depth_mm.cols || v >= depth_mm.rows) continue;
    const uint16_t z = depth_mm.at<uint16_t>(v, u);
    if (z) out.emplace_back(float(u), float(v), float(z));
  }
  return out;
}

namespace {

using SightingIndex = std::map<std::pair<int, int>, const Observation*>;  // (camera, view) -> its sighting

// The capture's shape checked and each camera's views counted: a camera that shares no view, or too few,
// with another is an error naming it.
void check_views(const CalibrationCapture& capture, const RigCalibrationOptions& options,
                 RigCalibrationReport* report) {
  const int ncam = int(capture.cameras.size());
  if (ncam < 1 || ncam > Rig::kMaxCameras)
    throw Error("calibration: " + std::to_string(ncam) + " cameras; expected 1.." + std::to_string(Rig::kMaxCameras));
  if (options.reference < 0 || options.reference >= ncam)
    throw Error("calibration: reference camera index " + std::to_string(options.reference) + " out of range");
  for (const auto& v : capture.views)
    if (int(v.size()) != ncam) throw Error("calibration: a view has " + std::to_string(v.size()) + " cameras, not " + std::to_string(ncam));
  report->views.assign(size_t(ncam), 0);

  // Which views each camera shares with another.
  std::vector<int> shared(size_t(ncam), 0);
  for (const auto& v : capture.views) {
    int seen = 0;
    for (const auto& s : v) seen += s.has_value();
    for (int c = 0; c < ncam; ++c) {
      if (v[size_t(c)]) {
        ++report->views[size_t(c)];
        if (seen >= 2) ++shared[size_t(c)];
      }
    }
  }
  for (int c = 0; c < ncam && ncam > 1; ++c) {
    if (shared[size_t(c)] == 0)
      throw Error("calibration: " + camera_label(capture.cameras[size_t(c)]) +
                  " saw the board in no view that another camera saw too: hold the board where it and its "
                  "neighbour both see it whole");
    if (shared[size_t(c)] < options.min_shared_views)
      throw Error("calibration: " + camera_label(capture.cameras[size_t(c)]) + " shares only " +
                  std::to_string(shared[size_t(c)]) + " views with another camera; at least " +
                  std::to_string(options.min_shared_views) + " are needed: show it the board in more places");
  }
}

// Each camera's intrinsics: the device's, or the board's (from at least 8 views).
std::vector<CameraCalib> find_intrinsics(const CalibrationCapture& capture, const RigCalibrationOptions& options,
                                         const std::vector<cv::Point3f>& board, RigCalibrationReport* report) {
  const int ncam = int(capture.cameras.size());
  std::vector<CameraCalib> cams = capture.cameras;
  for (int c = 0; c < ncam; ++c) {
    CameraCalib& cam = cams[size_t(c)];
    if (cam.width <= 0 || cam.height <= 0) throw Error("calibration: " + camera_label(cam) + " has no image size");
    if (cam.fx > 0 && !options.intrinsics_from_board) continue;
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    for (const auto& v : capture.views)
      if (v[size_t(c)]) object.push_back(board), image.push_back(v[size_t(c)]->corners);
    if (image.size() < 8)
      throw Error("calibration: " + camera_label(cam) + " gives no intrinsics and saw the board in only " +
                  std::to_string(image.size()) + " views; the board gives them from 8 views turned different ways");
    cv::Mat k, dist;
    std::vector<cv::Mat> rvecs, tvecs;
    cv::calibrateCamera(object, image, cv::Size(cam.width, cam.height), k, dist, rvecs, tvecs, cv::CALIB_FIX_K3);
    cam.fx = k.at<double>(0, 0), cam.fy = k.at<double>(1, 1), cam.cx = k.at<double>(0, 2), cam.cy = k.at<double>(1, 2);
    for (int i = 0; i < 5 && i < int(dist.total()); ++i) cam.distortion[size_t(i)] = dist.at<double>(i);
    report->intrinsics_from_board[size_t(c)] = true;
  }
  return cams;
}

// Every sighting in the ideal pinhole camera, with its own board pose.
std::vector<Observation> observe_board(const CalibrationCapture& capture, const std::vector<CameraCalib>& cams,
                                       const std::vector<cv::Point3f>& board) {
  const int ncam = int(cams.size());
  std::vector<Observation> obs;
  for (int v = 0; v < int(capture.views.size()); ++v) {
    for (int c = 0; c < ncam; ++c) {
      const auto& s = capture.views[size_t(v)][size_t(c)];
      if (!s || int(s->corners.size()) != capture.board.corner_count()) continue;
      const CameraCalib& cam = cams[size_t(c)];
      const cv::Matx33d km(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
      std::vector<cv::Point2f> ideal;
      std::array<double, 5> distortion = cam.distortion;  // cv::Mat wraps writable data
      cv::undistortPoints(s->corners, ideal, km, cv::Mat(1, 5, CV_64F, distortion.data()), cv::noArray(), km);
      cv::Vec3d rvec, tvec;
      if (!cv::solvePnP(board, ideal, km, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE)) continue;
      cv::solvePnPRefineLM(board, ideal, km, cv::noArray(), rvec, tvec);
      Observation o;
      o.camera = c;
      o.view = v;
      o.board_to_camera = from_rvec_tvec(rvec, tvec);
      for (const auto& p : ideal) o.corners.emplace_back(p.x, p.y);
      const double scale = cam.depth_scale > 0 ? cam.depth_scale : 1.0;
      for (const auto& d : s->depth_samples) o.depth_points.push_back(cam.unproject(d.x, d.y, d.z * scale * 0.001));
      obs.push_back(std::move(o));
    }
  }
  return obs;
}

// The cameras' first poses in the reference camera's frame, outward from it through shared views: each
// shared view proposes a pose, and the one nearest the others wins.
std::vector<Isometry3d> chain_cameras(const std::vector<Observation>& obs, const std::vector<CameraCalib>& cams,
                                      int reference, const SightingIndex& by_cam_view) {
  const int ncam = int(cams.size());
  std::vector<Isometry3d> cam_to_ref(size_t(ncam), Isometry3d::Identity());
  std::vector<bool> known(size_t(ncam), false);
  known[size_t(reference)] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (int c = 0; c < ncam; ++c) {
      if (known[size_t(c)]) continue;
      // Each shared view proposes a pose; the one nearest the others wins.
      std::vector<Isometry3d> proposals;
      for (const auto& o : obs) {
        if (o.camera != c) continue;
        for (int a = 0; a < ncam; ++a) {
          if (!known[size_t(a)]) continue;
          auto it = by_cam_view.find({a, o.view});
          if (it == by_cam_view.end()) continue;
          proposals.push_back(cam_to_ref[size_t(a)] * it->second->board_to_camera * o.board_to_camera.inverse());
        }
      }
      if (proposals.empty()) continue;
      size_t best = 0;
      double best_sum = 1e300;
      for (size_t i = 0; i < proposals.size(); ++i) {
        double sum = 0;
        for (const auto& q : proposals)
          sum += (q.translation() - proposals[i].translation()).norm() + rotation_deg(q.linear(), proposals[i].linear()) * 0.01;
        if (sum < best_sum) best_sum = sum, best = i;
      }
      cam_to_ref[size_t(c)] = proposals[best];
      known[size_t(c)] = true;
      grew = true;
    }
  }
  for (int c = 0; c < ncam; ++c)
    if (!known[size_t(c)])
      throw Error("calibration: " + camera_label(cams[size_t(c)]) +
                  " is not linked to the reference camera by any chain of shared views");
  return cam_to_ref;
}

// The bundle adjustment over the views two cameras saw (only those join it), then with the depth too:
// refines the camera poses and returns the board poses and the sightings it used.
std::vector<Observation> adjust_rig(const std::vector<Observation>& obs, const std::vector<Intrinsics>& k,
                                    const std::vector<cv::Point3f>& board, const RigCalibrationOptions& options,
                                    int ncam, std::vector<Isometry3d>* cam_to_ref,
                                    std::map<int, Isometry3d>* board_to_ref) {
  std::map<int, int> seen_by;
  for (const auto& o : obs) ++seen_by[o.view];
    std::vector<Observation> joint;
  for (const auto& o : obs) {
    if (ncam > 1 && seen_by[o.view] < 2) continue;
    if (!board_to_ref->count(o.view)) (*board_to_ref)[o.view] = (*cam_to_ref)[size_t(o.camera)] * o.board_to_camera;
    joint.push_back(o);
  }
  if (joint.empty()) throw Error("calibration: no view of the board to calibrate from");
  Adjustment(joint, k, board, options.reference, false, cam_to_ref, board_to_ref).run(50);
  if (options.depth_refine) Adjustment(joint, k, board, options.reference, true, cam_to_ref, board_to_ref).run(50);

  return joint;
}

// What the adjustment leaves, per camera: the corners' reprojection and the depth's distance from the board.
void report_residuals(const std::vector<Observation>& joint, const std::vector<Intrinsics>& k,
                      const std::vector<cv::Point3f>& board, const std::vector<Isometry3d>& cam_to_ref,
                      const std::map<int, Isometry3d>& board_to_ref, RigCalibrationReport* report) {
  const int ncam = int(cam_to_ref.size());
  report->reprojection_px.assign(size_t(ncam), 0);
  report->depth_plane_mm.assign(size_t(ncam), 0);
  std::vector<double> corner_sq(size_t(ncam), 0), depth_sq(size_t(ncam), 0);
  std::vector<size_t> corner_n(size_t(ncam), 0), depth_n(size_t(ncam), 0);
  for (const auto& o : joint) {
    const Isometry3d b2c = cam_to_ref[size_t(o.camera)].inverse() * board_to_ref.at(o.view);
    for (size_t i = 0; i < o.corners.size(); ++i) {
      const Vector3d p = b2c * Vector3d(board[i].x, board[i].y, board[i].z);
      const Intrinsics& ki = k[size_t(o.camera)];
      const Eigen::Vector2d e(ki.fx * p.x() / p.z() + ki.cx - o.corners[i].x(), ki.fy * p.y() / p.z() + ki.cy - o.corners[i].y());
      corner_sq[size_t(o.camera)] += e.squaredNorm();
      ++corner_n[size_t(o.camera)];
    }
    const Vector3d n = b2c.linear().col(2);
    const double d = n.dot(b2c.translation());
    for (const auto& p : o.depth_points) {
      const double e = (n.dot(p) - d) * 1000;
      depth_sq[size_t(o.camera)] += e * e;
      ++depth_n[size_t(o.camera)];
    }
  }
  for (int c = 0; c < ncam; ++c) {
    if (corner_n[size_t(c)]) report->reprojection_px[size_t(c)] = std::sqrt(corner_sq[size_t(c)] / double(corner_n[size_t(c)]));
    if (depth_n[size_t(c)]) report->depth_plane_mm[size_t(c)] = std::sqrt(depth_sq[size_t(c)] / double(depth_n[size_t(c)]));
  }
}

// Up: the floor (or what lies parallel to it, desks) in each camera's depth; the reference camera's height
// above the floor and how far the cameras' floors disagree go to the report.
Vector3d find_up(const CalibrationCapture& capture, const std::vector<CameraCalib>& cams,
                 const std::vector<Isometry3d>& cam_to_ref, int reference, RigCalibrationReport* report) {
  const int ncam = int(cams.size());
  const CameraCalib& ref_cam = cams[size_t(reference)];
  Vector3d up_sum = Vector3d::Zero();
  std::vector<Vector3d> ups(size_t(ncam), Vector3d::Zero());
  std::vector<Vector3d> ref_floor;
  for (int c = 0; c < ncam; ++c) {
    if (size_t(c) >= capture.room_depth.size()) break;
    const RoomView room = room_view(cams[size_t(c)], capture.room_depth[size_t(c)]);
    // A camera stands about upright: its floor's normal is within 50 degrees of its -y.
    // (The largest such plane may be the desk tops: parallel to the floor, which is all Y needs.)
    const RoomPlane* level = largest_plane(room.planes, [](const Vector3d& n) { return -n.y() > std::cos(50 * M_PI / 180); });
    if (!level) continue;
    const Vector3d n = level->normal;
    ups[size_t(c)] = cam_to_ref[size_t(c)].linear() * n;
    up_sum += double(level->inliers) * ups[size_t(c)];
    if (c == reference) {
      // The floor is the lowest level with a wide area: heights of all points along the normal.
      std::vector<double> below;
      for (const auto& p : room.points) below.push_back(-n.dot(p.cast<double>()));
      std::sort(below.begin(), below.end());
      const size_t floor_at = below.size() - std::max<size_t>(1, below.size() / 50);
      report->camera_height_m = below[floor_at];
    }
  }
  if (up_sum.norm() == 0)
    throw Error("calibration: no floor found in the cameras' depth (" + camera_label(ref_cam) +
                " and the others): the cameras must see some floor or desk tops");
  const Vector3d y_axis = up_sum.normalized();
  for (const auto& u : ups)
    if (u.norm() > 0) report->floor_spread_deg = std::max(report->floor_spread_deg, std::acos(std::clamp(u.dot(y_axis), -1.0, 1.0)) * 180 / M_PI);
  return y_axis;
}

// X: along the front wall (or as the options say), level, pointing the reference camera's way.
Vector3d find_x_axis(const CalibrationCapture& capture, const CameraCalib& ref_cam, const Vector3d& y_axis,
                     const RigCalibrationOptions& options, RigCalibrationReport* report) {
  Vector3d x_axis;
  const Vector3d camera_x = Vector3d::UnitX();  // the reference camera's own x, in its frame
  if (options.x_axis == XAxisFrom::Points) {
    x_axis = options.x_to - options.x_from;
    report->x_axis_from = "the two points given";
  } else if (options.x_axis == XAxisFrom::Camera) {
    x_axis = camera_x;
    report->x_axis_from = "the reference camera's x axis, levelled";
  } else {
    const RoomView room = size_t(options.reference) < capture.room_depth.size()
                              ? room_view(ref_cam, capture.room_depth[size_t(options.reference)])
                              : RoomView();
    // A wall: upright within 10 degrees, facing the camera (the front wall, or the back wall parallel to it).
    const RoomPlane* wall = largest_plane(room.planes, [&](const Vector3d& n) {
      return std::abs(n.dot(y_axis)) < std::sin(10 * M_PI / 180) && -n.z() > 0.5;
    });
    if (!wall)
      throw Error("calibration: no wall facing " + camera_label(ref_cam) +
                  " in its depth: give the X axis as two points along the front wall (--x-axis), or take the "
                  "camera's own (--x-axis camera)");
    x_axis = y_axis.cross(wall->normal);
    report->x_axis_from = "the wall facing the reference camera (" + std::to_string(wall->inliers) + " depth points)";
  }
  x_axis -= x_axis.dot(y_axis) * y_axis;
  if (x_axis.norm() < 1e-6) throw Error("calibration: the X axis given runs straight up");
  x_axis.normalize();
  if (x_axis.dot(camera_x) < 0 && options.x_axis != XAxisFrom::Points) x_axis = -x_axis;
  return x_axis;
}

// How well pairs agree: the corners each camera places alone, compared in the rig.
void report_pair_agreement(const std::vector<Observation>& obs, const SightingIndex& by_cam_view,
                           const std::vector<Isometry3d>& cam_to_ref, const std::vector<cv::Point3f>& board,
                           RigCalibrationReport* report) {
  const int ncam = int(cam_to_ref.size());
  for (int a = 0; a < ncam; ++a)
    for (int b = a + 1; b < ncam; ++b) {
      RigCalibrationReport::Pair pair;
      pair.a = a, pair.b = b;
      double sum = 0;
      size_t n = 0;
      for (const auto& o : obs) {
        if (o.camera != a) continue;
        auto it = by_cam_view.find({b, o.view});
        if (it == by_cam_view.end()) continue;
        ++pair.views;
        const Isometry3d pa = cam_to_ref[size_t(a)] * o.board_to_camera, pb = cam_to_ref[size_t(b)] * it->second->board_to_camera;
        for (const auto& p : board) {
          const Vector3d q(p.x, p.y, p.z);
          sum += (pa * q - pb * q).norm() * 1000;
          ++n;
        }
      }
      if (n) pair.agreement_mm = sum / double(n);
      report->pairs.push_back(pair);
    }
}

}  // namespace

RigCalibrationReport calibrate_rig(const CalibrationCapture& capture, const RigCalibrationOptions& options) {
  validate_board(capture.board);
  RigCalibrationReport report;
  check_views(capture, options, &report);
  const int ncam = int(capture.cameras.size());
  const std::vector<cv::Point3f> board = capture.board.corners();
  report.intrinsics_from_board.assign(size_t(ncam), false);
  const std::vector<CameraCalib> cams = find_intrinsics(capture, options, board, &report);
  std::vector<Intrinsics> k;
  for (const auto& cam : cams) k.push_back({cam.fx, cam.fy, cam.cx, cam.cy});
  const std::vector<Observation> obs = observe_board(capture, cams, board);
  SightingIndex by_cam_view;
  for (const auto& o : obs) by_cam_view[{o.camera, o.view}] = &o;
  std::vector<Isometry3d> cam_to_ref = chain_cameras(obs, cams, options.reference, by_cam_view);
  std::map<int, Isometry3d> board_to_ref;
  const std::vector<Observation> joint = adjust_rig(obs, k, board, options, ncam, &cam_to_ref, &board_to_ref);
  report_residuals(joint, k, board, cam_to_ref, board_to_ref, &report);
  const Vector3d y_axis = find_up(capture, cams, cam_to_ref, options.reference, &report);
  const Vector3d x_axis = find_x_axis(capture, cams[size_t(options.reference)], y_axis, options, &report);
  const Vector3d z_axis = x_axis.cross(y_axis);
  Isometry3d rig_from_ref = Isometry3d::Identity();
  rig_from_ref.linear().row(0) = x_axis.transpose();
  rig_from_ref.linear().row(1) = y_axis.transpose();
  rig_from_ref.linear().row(2) = z_axis.transpose();

  report.rig.name = "calibrated";
  for (int c = 0; c < ncam; ++c) {
    CameraCalib cam = cams[size_t(c)];
    cam.cam_to_rig = rig_from_ref * cam_to_ref[size_t(c)];
    report.rig.cameras.push_back(cam);
  }
  validate_rig(report.rig, "calibrated rig");
  report_pair_agreement(obs, by_cam_view, cam_to_ref, board, &report);
  return report;
}

RigError compare_rigs(const Rig& calibrated, const Rig& truth, int reference_id) {
  RigError e;
  const Matrix3d cal_ref = calibrated.camera(reference_id).cam_to_rig.linear();
  const Matrix3d true_ref = truth.camera(reference_id).cam_to_rig.linear();
  // Each rig's up axis seen from the reference camera.
  const Vector3d up_cal = cal_ref.transpose() * Vector3d::UnitY(), up_true = true_ref.transpose() * Vector3d::UnitY();
  e.floor_deg = std::acos(std::clamp(up_cal.dot(up_true), -1.0, 1.0)) * 180 / M_PI;
  for (const CameraCalib& c : calibrated.cameras) {
    const CameraCalib& t = truth.camera(c.id);
    // Positions relative to the reference camera, so that a rig placed elsewhere compares alike.
    const Vector3d pc = c.cam_to_rig.translation() - calibrated.camera(reference_id).cam_to_rig.translation();
    const Vector3d pt = t.cam_to_rig.translation() - truth.camera(reference_id).cam_to_rig.translation();
    e.max_position_cm = std::max(e.max_position_cm, (pc - pt).norm() * 100);
    e.max_rotation_deg = std::max(e.max_rotation_deg, rotation_deg(c.cam_to_rig.linear(), t.cam_to_rig.linear()));
  }
  return e;
}

}  // namespace vclassroom
