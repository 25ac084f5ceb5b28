// Experiment (issue 31, wip/room-lookup): the room's depth at a view by rasterising room_mesh's triangles
// (room_raster.h): accuracy on a plane, the z-buffer, and that a mesh is drawn without cracks or overlaps.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/room_mesh.h>
#include <gst/vclassroom/vva/room_raster.h>

using namespace vclassroom;

namespace {

CameraCalib pinhole(int w, int h, double f, const Eigen::Isometry3d& cam_to_rig) {
  CameraCalib c;
  c.width = w, c.height = h;
  c.fx = c.fy = f;
  c.cx = (w - 1) / 2.0, c.cy = (h - 1) / 2.0;
  c.cam_to_rig = cam_to_rig;
  return c;
}

Eigen::Isometry3d pose(double x, double y, double z, double yaw_deg, double pitch_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(pitch_deg * M_PI / 180, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// A plane n . p = d (rig frame, metres).
struct Plane {
  Eigen::Vector3d n;
  double d;
  // The depth (metres along the camera's axis) where the ray of pixel (u, v) meets it; <= 0: it does not.
  double depth_at(const CameraCalib& c, double u, double v) const {
    const Eigen::Vector3d ray_cam((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1);
    const Eigen::Vector3d o = c.cam_to_rig.translation(), r = c.cam_to_rig.linear() * ray_cam;
    const double den = n.dot(r);
    if (std::fabs(den) < 1e-12) return -1;
    return (d - n.dot(o)) / den;  // ray_cam has z = 1: the parameter is the depth
  }
};

cv::Mat plane_depth(const CameraCalib& c, const Plane& p) {
  cv::Mat d(c.height, c.width, CV_16UC1);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) d.at<uint16_t>(v, u) = cv::saturate_cast<uint16_t>(1000 * p.depth_at(c, u, v));
  return d;
}

const Plane kSlanted{Eigen::Vector3d(0.25, -0.3, -1).normalized(), 0};

Plane slanted_through(const Eigen::Vector3d& point) {
  Plane p = kSlanted;
  p.d = p.n.dot(point);
  return p;
}

}  // namespace

TEST(RoomRaster, SlantedPlaneMatchesItsDepthAtTheView) {
  const CameraCalib src = pinhole(320, 240, 300, Eigen::Isometry3d::Identity());
  const Plane plane = slanted_through(Eigen::Vector3d(0, 0, 2.5));
  const cv::Mat depth = plane_depth(src, plane);
  const CameraCalib view = pinhole(320, 240, 280, pose(0.25, -0.1, 0.2, 8, -5));
  for (const auto& [ratio, min_mm, top] : {std::tuple<double, double, int>{0.01, 10, 5}, {0.005, 5, 5}, {0, 0, 0}}) {
    RoomMesh mesh;
    const RoomMeshCount count = room_mesh(depth, ratio, min_mm, top, nullptr, &src, &mesh);
    if (top > 0) {
      EXPECT_LT(count.triangles(), 2 * 80 * 60);
    }
    RoomRaster r;
    r.begin(view);
    r.draw(mesh);
    cv::Mat out;
    r.depth(&out);
    long drawn = 0, bad = 0;
    double worst = 0;
    for (int v = 0; v < view.height; ++v)
      for (int u = 0; u < view.width; ++u) {
        const int z = out.at<uint16_t>(v, u);
        if (!z) continue;
        ++drawn;
        const double truth = 1000 * plane.depth_at(view, u, v), err = std::fabs(z - truth);
        worst = std::max(worst, err - 0.001 * truth);
        if (err > 1 + 0.001 * truth) ++bad;
      }
    EXPECT_GT(drawn, long(0.5 * view.width * view.height)) << "top " << top;
    EXPECT_EQ(bad, 0) << "top " << top << ": worst " << worst << " mm beyond 0.1 %";
    EXPECT_EQ(r.stats.near, 0);
  }
}

TEST(RoomRaster, TheNearerTriangleWins) {
  const CameraCalib view = pinhole(64, 48, 60, Eigen::Isometry3d::Identity());
  RoomMesh mesh;
  // Two triangles in front of the view, the first at 3 m, the second at 2 m, overlapping in the middle.
  auto add = [&](double z, double x0, double x1) {
    const uint32_t base = uint32_t(mesh.x.size());
    const double pts[3][2] = {{x0, -0.8 * z}, {x1, -0.8 * z}, {0.5 * (x0 + x1), 0.8 * z}};
    for (const auto& p : pts) mesh.x.push_back(float(p[0] * z)), mesh.y.push_back(float(p[1])), mesh.z.push_back(float(z));
    mesh.index.insert(mesh.index.end(), {base, base + 1, base + 2});
  };
  add(3.0, -0.9, 0.5);
  add(2.0, -0.5, 0.9);
  RoomMesh reversed = mesh;  // the same triangles drawn in the other order
  std::swap_ranges(reversed.index.begin(), reversed.index.begin() + 3, reversed.index.begin() + 3);
  for (const RoomMesh* m : {&mesh, &reversed}) {
    RoomRaster r;
    r.begin(view);
    r.draw(*m);
    cv::Mat out;
    r.depth(&out);
    EXPECT_EQ(out.at<uint16_t>(24, 32), 2000);  // both cover the centre
    // Row 10: the far one spans x/z -0.65..0.25, the near one -0.25..0.65.
    EXPECT_EQ(out.at<uint16_t>(10, int(std::lround(view.cx + view.fx * -0.5))), 3000);
    EXPECT_EQ(out.at<uint16_t>(10, int(std::lround(view.cx + view.fx * 0.5))), 2000);
    EXPECT_EQ(out.at<uint16_t>(47, 2), 0);
  }
  // A triangle whose screen box spans 1024 px or more (the 64-bit loop) behind both: it fills the rest.
  const uint32_t base = uint32_t(mesh.x.size());
  for (const auto& p : {std::pair<double, double>{-40, -20}, {40, -20}, {0, 40}})
    mesh.x.push_back(float(p.first)), mesh.y.push_back(float(p.second)), mesh.z.push_back(4.0f);
  mesh.index.insert(mesh.index.end(), {base, base + 2, base + 1});
  RoomRaster r;
  r.begin(view);
  r.draw(mesh);
  cv::Mat out;
  r.depth(&out);
  EXPECT_EQ(r.stats.large, 1);
  EXPECT_EQ(out.at<uint16_t>(47, 2), 4000);
  EXPECT_EQ(out.at<uint16_t>(24, 32), 2000);
  EXPECT_EQ(out.at<uint16_t>(10, int(std::lround(view.cx + view.fx * -0.5))), 3000);
}

TEST(RoomRaster, ATiledPlaneIsDrawnWithoutCracksOrOverlaps) {
  const CameraCalib src = pinhole(320, 240, 300, Eigen::Isometry3d::Identity());
  const Plane plane = slanted_through(Eigen::Vector3d(0, 0, 2.5));
  cv::Mat depth = plane_depth(src, plane);
  // Smooth bumps, so that the quadtree splits around them: tiles of every size side by side (T-junctions).
  for (int v = 0; v < src.height; ++v)
    for (int u = 0; u < src.width; ++u) {
      double bump = 0;
      for (const auto& [bu, bv] : {std::pair<double, double>{80, 70}, {210, 150}, {250, 50}})
        bump += 30 * std::exp(-((u - bu) * (u - bu) + (v - bv) * (v - bv)) / (2 * 22.0 * 22.0));
      depth.at<uint16_t>(v, u) = cv::saturate_cast<uint16_t>(depth.at<uint16_t>(v, u) - bump);
    }
  RoomMesh mesh;
  const RoomMeshCount count = room_mesh(depth, 0.001, 2, 5, nullptr, &src, &mesh);
  EXPECT_EQ(count.dropped, 0);
  int levels = 0;
  for (long n : count.tiles) levels += n > 0;
  EXPECT_GE(levels, 4);
  EXPECT_GT(long(mesh.triangles()), count.triangles());  // fans at the T-junctions
  for (const CameraCalib& view : {pinhole(320, 240, 280, pose(0.2, -0.1, 0.1, 6, -4)),
                                  pinhole(400, 300, 250, pose(-0.3, 0.2, -0.4, -10, 7)), src}) {
    RoomRaster r;
    r.begin(view);
    cv::Mat coverage(view.height, view.width, CV_8UC1, cv::Scalar(0));
    r.draw(mesh, &coverage);
    long inside = 0, holes = 0, twice = 0;
    for (int v = 0; v < view.height; ++v)
      for (int u = 0; u < view.width; ++u) {
        const int c = coverage.at<uint8_t>(v, u);
        twice += c > 1;
        // Inside: the base plane's point there is 3 px or more inside the source image (the bumps move it less).
        const double z = plane.depth_at(view, u, v);
        if (z <= 0) continue;
        const Eigen::Vector3d p_rig =
            view.cam_to_rig * Eigen::Vector3d((u - view.cx) / view.fx * z, (v - view.cy) / view.fy * z, z);
        const Eigen::Vector3d p = src.cam_to_rig.inverse() * p_rig;
        const double su = src.cx + src.fx * p.x() / p.z(), sv = src.cy + src.fy * p.y() / p.z();
        if (su < 3 || sv < 3 || su > src.width - 4 || sv > src.height - 4) continue;
        ++inside;
        holes += c == 0;
      }
    EXPECT_GT(inside, long(0.3 * view.width * view.height));
    EXPECT_EQ(holes, 0) << "of " << inside;
    EXPECT_EQ(twice, 0);
  }
}
