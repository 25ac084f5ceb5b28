#include <gst/vclassroom/synthetic/board_trace.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace vclassroom {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;

CalibrationBoard trace_board() { return CalibrationBoard{9, 6, 0.08}; }

namespace {

// splitmix64: the same stops on every platform (std:: distributions are not).
struct StopRng {
  uint64_t s;
  double uniform(double lo, double hi) {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * double(z >> 11) * (1.0 / 9007199254740992.0);
  }
};

struct Stop {
  Vector3d centre;  // rig frame, where the middle of the corner grid is
  Matrix3d rotation;
};

Stop stop(const Classroom& room, int k) {
  StopRng rng{0x5EEDB0A4Dull + uint64_t(k) * 0x1000193ull};
  Stop s;
  s.centre = Vector3d(rng.uniform(-1.0, 1.0), room.floor_y() + rng.uniform(1.0, 1.6), -rng.uniform(1.8, 3.2));
  // Facing the rig's origin, rows level: z (into the board) along the line of sight.
  const Vector3d z = s.centre.normalized();
  const Vector3d x = z.cross(Vector3d::UnitY()).normalized();
  Matrix3d base;
  base << x, z.cross(x), z;
  const double deg = M_PI / 180;
  s.rotation = base * Eigen::AngleAxisd(rng.uniform(-30, 30) * deg, Vector3d::UnitX()).toRotationMatrix() *
               Eigen::AngleAxisd(rng.uniform(-30, 30) * deg, Vector3d::UnitY()).toRotationMatrix() *
               Eigen::AngleAxisd(rng.uniform(-15, 15) * deg, Vector3d::UnitZ()).toRotationMatrix();
  return s;
}

Isometry3d board_pose_at(const CalibrationBoard& board, const Vector3d& centre, const Matrix3d& rotation) {
  const Vector3d grid_centre((board.inner_cols - 1) * board.square_m / 2, (board.inner_rows - 1) * board.square_m / 2, 0);
  Isometry3d t = Isometry3d::Identity();
  t.linear() = rotation;
  t.translation() = centre - rotation * grid_centre;
  return t;
}

}  // namespace

Isometry3d board_pose_on_trace(const Classroom& room, double t) {
  t = std::max(t, 0.0);
  const int64_t n = int64_t(std::floor(t / kBoardStopSeconds));
  const int k = int(n % kBoardStops);
  const double in_period = t - double(n) * kBoardStopSeconds;
  const Stop a = stop(room, k);
  const CalibrationBoard board = trace_board();
  if (in_period < kBoardStillSeconds) return board_pose_at(board, a.centre, a.rotation);
  // Moving: eased from this stop to the next.
  const Stop b = stop(room, (k + 1) % kBoardStops);
  const double u = (in_period - kBoardStillSeconds) / kBoardMoveSeconds;
  const double e = u * u * (3 - 2 * u);
  const Eigen::Quaterniond q = Eigen::Quaterniond(a.rotation).slerp(e, Eigen::Quaterniond(b.rotation));
  return board_pose_at(board, a.centre + e * (b.centre - a.centre), q.toRotationMatrix());
}

void draw_board(const CalibrationBoard& board, const Isometry3d& board_to_rig, const CameraCalib& cam,
                RenderOutput* out) {
  CV_Assert(out->color.type() == CV_8UC3 && out->depth.type() == CV_16UC1 && out->surface.type() == CV_16UC1 &&
            out->label.type() == CV_8UC1 && out->color.size() == cv::Size(cam.width, cam.height));
  if (out->surfaces.size() >= 65535) return;
  // Board frame to camera frame.
  const Isometry3d b2c = cam.cam_to_rig.inverse() * board_to_rig;
  const Vector3d normal = b2c.linear().col(2);  // into the board
  const Vector3d origin = b2c.translation();
  const double plane_d = normal.dot(origin);  // normal . P = plane_d on the board
  if (plane_d <= 0) return;                   // seen from behind (or edge-on)
  const Matrix3d c2b = b2c.linear().transpose();

  // The sheet's corners bound the pixels to visit (all in front: clipped otherwise).
  const double xs[2] = {board.left(), board.right()}, ys[2] = {board.top(), board.bottom()};
  double umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30;
  for (double bx : xs)
    for (double by : ys) {
      const Vector3d p = b2c * Vector3d(bx, by, 0);
      if (p.z() < 0.05) return;
      const double u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
      umin = std::min(umin, u), umax = std::max(umax, u), vmin = std::min(vmin, v), vmax = std::max(vmax, v);
    }
  const int u0 = std::max(0, int(std::floor(umin))), u1 = std::min(cam.width - 1, int(std::ceil(umax)));
  const int v0 = std::max(0, int(std::floor(vmin))), v1 = std::min(cam.height - 1, int(std::ceil(vmax)));
  if (u0 > u1 || v0 > v1) return;

  const uint16_t surface_id = uint16_t(out->surfaces.size());
  SurfaceInfo info;
  info.normal_cam = (-normal).cast<float>();
  info.ir_albedo = 0.6f;  // matte paper
  info.gloss = 0;
  info.label = 0;
  bool drawn = false;
  constexpr int kSub = 4;
  constexpr double kWhite = 215, kBlack = 30;
  // Where the ray through (u, v) meets the board: z, and the point in the board frame.
  auto hit = [&](double u, double v, double* z, Vector3d* on_board) {
    const Vector3d ray((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
    const double denom = normal.dot(ray);
    if (denom <= 1e-9) return false;
    *z = plane_d / denom;
    *on_board = c2b * (*z * ray - origin);
    return on_board->x() >= board.left() && on_board->x() < board.right() && on_board->y() >= board.top() &&
           on_board->y() < board.bottom();
  };
  for (int v = v0; v <= v1; ++v) {
    uint16_t* dep = out->depth.ptr<uint16_t>(v);
    uint16_t* sid = out->surface.ptr<uint16_t>(v);
    uint8_t* lab = out->label.ptr<uint8_t>(v);
    cv::Vec3b* col = out->color.ptr<cv::Vec3b>(v);
    for (int u = u0; u <= u1; ++u) {
      const double scene_mm = dep[u] ? double(dep[u]) : 1e12;
      // Colour: the share of the pixel's samples on the board, in front of the scene.
      double sum = 0;
      int on = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          double z;
          Vector3d p;
          if (!hit(u - 0.5 + (sx + 0.5) / kSub, v - 0.5 + (sy + 0.5) / kSub, &z, &p) || z * 1000 >= scene_mm + 0.5)
            continue;
          sum += board.is_black(p.x(), p.y()) ? kBlack : kWhite;
          ++on;
        }
      if (on) {
        for (int k = 0; k < 3; ++k)
          col[u][k] = cv::saturate_cast<uint8_t>((sum + double(kSub * kSub - on) * col[u][k]) / (kSub * kSub));
      }
      double z;
      Vector3d p;
      if (hit(u, v, &z, &p) && z * 1000 < scene_mm + 0.5 && z * 1000 < 65535) {
        dep[u] = uint16_t(std::lround(z * 1000));
        sid[u] = surface_id;
        lab[u] = 0;
        drawn = true;
      }
    }
  }
  if (drawn) out->surfaces.push_back(info);
}

}  // namespace vclassroom
