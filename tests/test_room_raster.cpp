// The room view's parts (room_raster.h, room_lookup.h, room_view.h): the rasterised depth's accuracy on a
// plane, the z-buffer, a mesh drawn without cracks; the lookup's two loops; a whole view against the truth.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/vva/room_lookup.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/virtual_view.h>
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
    for (const auto& p : pts)
      mesh.x.push_back(float(p[0] * z)), mesh.y.push_back(float(p[1])), mesh.z.push_back(float(z));
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

// A mesh of tiles of every size is drawn without cracks from any view, and from its own camera, whose pixel
// centres lie on the mesh's vertices and edges, every pixel to the image's border (a centre on an edge is inside:
// the triangles either side both draw it at its one depth).
TEST(RoomRaster, ATiledPlaneIsDrawnWithoutCracksToItsBorder) {
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
    long inside = 0, holes = 0;
    for (int v = 0; v < view.height; ++v)
      for (int u = 0; u < view.width; ++u) {
        const int c = coverage.at<uint8_t>(v, u);
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
  }
  RoomRaster own;
  own.begin(src);
  cv::Mat coverage(src.height, src.width, CV_8UC1, cv::Scalar(0));
  own.draw(mesh, &coverage);
  EXPECT_EQ(cv::countNonZero(coverage), src.width * src.height);
}

// A surface ends where its camera saw its edge, half a pixel past its last pixel centre, not at that centre: a
// box 2 m away before a wall 4 m away, drawn from the camera's own place with its principal point moved by 0.6
// px (every surface 0.6 px further right and down, no parallax), keeps its 10 columns and rows. Without the edge
// quads' parts it loses one each way, and views moved a little from a camera put the room's outlines a pixel
// off the truth (1.1 dB under the forward warp at 160x90, the element test of the room view).
TEST(RoomMesh, ASurfaceEndsHalfAPixelPastItsLastPixelCentre) {
  const CameraCalib src = pinhole(40, 30, 40, Eigen::Isometry3d::Identity());
  cv::Mat depth(src.height, src.width, CV_16UC1, cv::Scalar(4000));
  depth(cv::Rect(10, 8, 10, 10)).setTo(2000);
  depth.at<uint16_t>(25, 30) = 0;  // a pixel without depth: the wall reaches half a pixel into it
  RoomMesh mesh;
  const RoomMeshCount count = room_mesh(depth, 0.01, 10, 5, nullptr, &src, &mesh);
  EXPECT_GT(count.dropped, 0);
  ASSERT_LT(mesh.edge_begin, mesh.triangles());
  CameraCalib shifted = src;
  shifted.cx += 0.6, shifted.cy += 0.6;
  auto box_extent = [&](bool edges, int* columns, int* rows) {
    RoomRaster r;
    r.begin(shifted);
    if (edges) r.draw(mesh);
    else r.draw_leaves(mesh);
    cv::Mat out;
    r.depth(&out);
    *columns = cv::countNonZero(out.row(13) == 2000);
    *rows = cv::countNonZero(out.col(15) == 2000);
    return out;
  };
  int columns = 0, rows = 0;
  const cv::Mat with_edges = box_extent(true, &columns, &rows);
  EXPECT_EQ(columns, 10);
  EXPECT_EQ(rows, 10);
  EXPECT_EQ(with_edges.at<uint16_t>(13, 11), 2000);  // camera column 10.4: the box's left edge is at 9.5
  EXPECT_EQ(with_edges.at<uint16_t>(13, 20), 2000);  // 19.4 < its right edge at 19.5
  EXPECT_EQ(with_edges.at<uint16_t>(13, 21), 4000);  // 20.4: the wall
  EXPECT_EQ(with_edges.at<uint16_t>(25, 31), 4000);  // 30.4, 24.4: the wall's part of a quad with no depth at 30, 25
  EXPECT_EQ(with_edges.at<uint16_t>(26, 31), 0);     // 30.4, 25.4: that pixel's own part
  box_extent(false, &columns, &rows);
  EXPECT_EQ(columns, 9);
  EXPECT_EQ(rows, 9);
  // From the camera's own place every pixel is drawn at its own depth, edges and all, but the one without depth.
  RoomRaster own;
  own.begin(src);
  own.draw(mesh);
  cv::Mat drawn;
  own.depth(&drawn);
  cv::Mat off;
  cv::absdiff(drawn, depth, off);
  EXPECT_EQ(cv::countNonZero(off > 1), 0);
  EXPECT_EQ(drawn.at<uint16_t>(25, 30), 0);
}

// A far camera's mesh where the near ones left holes (RoomRaster::draw_where_empty): its triangles over tiles
// without a hole are not drawn, those over one are drawn whole, one reaching past the image's border too.
TEST(RoomRaster, AFarMeshIsDrawnOnlyWhereTheNearOnesLeftAHole) {
  const CameraCalib view = pinhole(64, 48, 50, Eigen::Isometry3d::Identity());
  auto at_depth = [&](double u, double v, double z) {  // a rig point seen at (u, v), z metres away
    return Eigen::Vector3d((u - view.cx) / view.fx * z, (v - view.cy) / view.fy * z, z);
  };
  auto triangle = [&](RoomMesh* m, std::initializer_list<std::pair<double, double>> uv, double z) {
    const uint32_t base = uint32_t(m->vertices());
    for (const auto& [u, v] : uv) {
      const Eigen::Vector3d p = at_depth(u, v, z);
      m->x.push_back(float(p.x())), m->y.push_back(float(p.y())), m->z.push_back(float(p.z()));
    }
    m->index.insert(m->index.end(), {base, base + 1, base + 2});
  };
  RoomMesh near_mesh, far_mesh;
  triangle(&near_mesh, {{-10, -10}, {40, -10}, {-10, 60}}, 2.0);  // the near mesh: the left part of the view
  triangle(&near_mesh, {{40, -10}, {40, 60}, {-10, 60}}, 2.0);
  triangle(&far_mesh, {{2, 2}, {20, 2}, {2, 20}}, 3.0);    // over the near mesh
  triangle(&far_mesh, {{50, 10}, {80, 10}, {50, 40}}, 3.0);  // over the hole, past the right border
  RoomRaster near, far;
  near.begin(view);
  near.draw(near_mesh);
  cv::Mat near_depth;
  near.depth(&near_depth);
  constexpr int kTile = RoomRaster::kTilePx;
  const int cols = (64 + kTile - 1) / kTile, rows = (48 + kTile - 1) / kTile;
  std::vector<uint8_t> empty(size_t(cols) * rows, 0);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      if (near_depth.at<uint16_t>(y, x) == 0) empty[size_t(y / kTile) * cols + x / kTile] = 1;
  far.begin(view);
  far.draw_where_empty(far_mesh, empty);
  cv::Mat far_depth;
  far.depth(&far_depth);
  EXPECT_EQ(far.stats.skipped, 1);
  EXPECT_EQ(far_depth.at<uint16_t>(5, 5), 0) << "the triangle over the near mesh is not drawn";
  EXPECT_EQ(far_depth.at<uint16_t>(20, 60), 3000) << "the one over the hole is, to the border";
  EXPECT_EQ(near_depth.at<uint16_t>(5, 5), 2000);
  EXPECT_EQ(near_depth.at<uint16_t>(20, 60), 0);
}

// A far camera's mesh is drawn into a view only where the near cameras' meshes leave a hole, and those holes
// lie on what the near cameras do not see: so only its triangles that no near camera sees are drawn
// (RoomShape::unseen_by, made once per set of near cameras and kept). In the holes near camera 0 leaves, at
// poses around it, the far mesh's part gives the depth the whole far mesh gives (in 98 % of the pixels), while
// holding well under half of its triangles; a raster cleared and read in the hole tiles alone gives it there.
TEST(RoomShape, AFarCamerasPartUnseenByTheNearOnesFillsTheirHolesAsItsWholeMesh) {
  const Classroom empty(ClassroomConfig{2, 0, 2.0});
  const Rig rig = default_classroom_rig();
  std::vector<std::shared_ptr<RoomShape>> shapes;
  for (int k = 0; k < 2; ++k) {
    const CameraCalib cam = scale_camera(rig.camera(k), 320, 180);
    shapes.push_back(std::make_shared<RoomShape>(cam, render(empty, 0.0, cam).depth));
  }
  const std::vector<const RoomShape*> near{shapes[0].get()};
  const std::shared_ptr<const RoomMesh> part = shapes[1]->unseen_by(near);
  EXPECT_EQ(shapes[1]->unseen_by(near), part) << "made once, then kept";
  EXPECT_NE(shapes[1]->unseen_by({}), part) << "another set of near cameras, another part";
  const RoomMesh& whole = shapes[1]->mesh();
  EXPECT_LT(std::min(part->edge_begin, part->triangles()), std::min(whole.edge_begin, whole.triangles()) / 2);
  RoomRaster reused;
  cv::Mat reused_depth;
  for (const Sliders& s : {Sliders{20, 50, 45, 70, 50, 50}, Sliders{35, 50, 45, 60, 50, 50},
                           Sliders{65, 55, 55, 40, 45, 50}, Sliders{80, 45, 60, 30, 55, 50}}) {
    const CameraCalib view =
        virtual_camera(scale_camera(rig.camera(0), 320, 180), sliders_to_pose(s, rig.camera(0)).cam_to_rig(), NAN);
    RoomRaster near_raster, by_whole, by_part;
    near_raster.begin(view);
    near_raster.draw(shapes[0]->mesh());
    cv::Mat near_depth, whole_depth, part_depth;
    near_raster.depth(&near_depth);
    std::vector<uint8_t> holes;
    RoomRaster::empty_tiles(near_depth, &holes);
    by_whole.begin(view);
    by_whole.draw_where_empty(whole, holes);
    by_whole.depth(&whole_depth);
    by_part.begin(view);
    by_part.draw_where_empty(*part, holes);
    by_part.depth(&part_depth);
    const cv::Mat hole = near_depth == 0, filled = hole & (whole_depth != 0);
    ASSERT_GT(cv::countNonZero(filled), 100) << format_sliders(s) << ": the far camera should fill holes";
    // Begun and read in the hole tiles only (as RoomViewRenderer draws the far meshes), by a raster that drew
    // other views before: the same depth in the holes.
    SampleTiles hole_tiles;
    hole_tiles.set_marked(holes.data(), size_t((view.width + 7) / 8), view.width, view.height);
    reused.begin_in_tiles(view, hole_tiles);
    reused.draw_where_empty(*part, holes);
    reused.depth_in_tiles(&reused_depth, hole_tiles);
    EXPECT_EQ(cv::countNonZero(hole & (reused_depth != part_depth)), 0) << format_sliders(s);
    cv::Mat differ;
    cv::absdiff(whole_depth, part_depth, differ);
    const int same = cv::countNonZero(filled & (differ <= 0.01 * whole_depth));
    // 98.97-99.56 % measured: the rest lie along outlines, where the whole far mesh draws a foreground surface
    // that camera 0 sees (its outline a pixel off from camera 0's) over the holes beside it.
    EXPECT_GE(same, 0.98 * cv::countNonZero(filled)) << format_sliders(s);
  }
}

// The view made as viewfuse's room-view makes it: the room from three cameras' meshes of the empty room's
// depth, its colour looked up in their frames, the learners and the room's pixels beside them warped forward
// and fused over it. Against the truth at poses around camera 0 it is as good as the full forward warp of
// every camera (within 0.3 dB, the learners' pixels within 0.7), and at camera 0's own place better (there the
// room is camera 0's own picture: the cameras' colour is the background memory's, so the view's place is
// weighed), while the forward warps hold well under half of the pixels.
TEST(RoomView, TheRoomDrawnFromMeshesAndTheLearnersWarpedAloneMakeTheFullWarpsView) {
  const Classroom room(ClassroomConfig{2, 5, 2.0});
  const Classroom empty(ClassroomConfig{2, 0, 2.0});
  const Rig rig = default_classroom_rig();
  const double t = 1.0;
  std::vector<CameraCalib> cams;
  std::vector<RenderOutput> frames;
  std::vector<FramePreparer> preparers(3);
  std::vector<std::shared_ptr<PreparedFrame>> prepared;
  for (int k = 0; k < 3; ++k) {
    cams.push_back(scale_camera(rig.camera(k), 320, 180));
    frames.push_back(render(room, t, cams.back()));
    preparers[size_t(k)].set_static_depth(render(empty, 0.0, cams.back()).depth);
    preparers[size_t(k)].set_memory(4, cv::Mat());  // as server.sh: the room's colour steady, the place weighed
    prepared.push_back(preparers[size_t(k)].prepare(cams.back(), frames.back().color, frames.back().depth,
                                                    frames.back().label, WarpParams()));
    ASSERT_NE(prepared.back()->room_shape, nullptr) << "camera " << k;
  }
  WarpParams learners_only;
  learners_only.learners_only = true;
  FuseParams base;
  base.first_is_base = true;
  RoomViewRenderer renderer;
  for (const Sliders& s : {Sliders{50, 50, 50, 50, 50, 50}, Sliders{35, 50, 45, 60, 50, 50},
                           Sliders{65, 55, 55, 40, 45, 50}}) {
    const CameraCalib virt =
        virtual_camera(scale_camera(rig.camera(0), 320, 180), sliders_to_pose(s, rig.camera(0)).cam_to_rig(), NAN);
    const RenderOutput truth = render(room, t, virt);
    std::vector<WarpedView> full(3), learners(3);
    std::vector<RoomCamera> room_cams;
    WarpedView room_part;
    for (size_t k = 0; k < 3; ++k) {
      const WarpSource src = FramePreparer::source_of(*prepared[k], frames[k].color, frames[k].depth, frames[k].label);
      ViewWarper().warp_prepared(cams[k], src, prepared[k]->source, virt, WarpParams(), &full[k]);
      ViewWarper().warp_prepared(cams[k], src, prepared[k]->source, virt, learners_only, &learners[k]);
      room_cams.push_back(RoomCamera{prepared[k]->room_shape.get(), &prepared[k]->room_texture(frames[k].color)});
      // Only the learners and the room's pixels beside them go forward.
      EXPECT_LT(cv::countNonZero(learners[k].depth), cv::countNonZero(full[k].depth) / 2) << format_sliders(s);
    }
    renderer.render(room_cams, virt, RoomLookupParams(), &room_part);
    FusedView today, by_room;
    fuse_views({&full[0], &full[1], &full[2]}, FuseParams(), &today);
    fuse_views({&room_part, &learners[0], &learners[1], &learners[2]}, base, &by_room);
    const double psnr_today = psnr_rgb(today.color, truth.color), psnr_room = psnr_rgb(by_room.color, truth.color);
    EXPECT_GT(psnr_room, psnr_today - 0.3) << format_sliders(s) << ": today " << psnr_today;
    if (s[0] == 50 && s[3] == 50) {
      EXPECT_GT(psnr_room, psnr_today + 1) << "at camera 0's place";
    }
    EXPECT_EQ(cv::countNonZero((room_part.weight != 0) & (room_part.depth == 0)), 0) << "seen without a depth";
    const cv::Mat learner_pixels = truth.label != 0;
    ASSERT_GT(cv::countNonZero(learner_pixels), 500) << "the learners should be in view";
    // The learners come forward as in the full warp, but the cracks around them close against the room's mesh,
    // not against the room's own warped pixels: 0.52 dB lower at the pose 30 cm left, 0.64 since camera 0's
    // surfaces reach to their edges (RoomMesh::edge_begin; the room's own pixels there gained 0.15; 2026-11-28).
    EXPECT_GT(psnr_rgb_masked(by_room.color, truth.color, learner_pixels),
              psnr_rgb_masked(today.color, truth.color, learner_pixels) - 0.7)
        << format_sliders(s);
  }
}

// A camera far from the view among the room's cameras (its place weight under 0.3 of the nearest one's, as
// the lookup calls a camera far) leaves its learners to the nearer ones; a camera that is lost is not among
// them, and then the others are near again. Its learners' view, warp_nothing's, holds nothing: the fuse gives
// the room alone, as without it, though the planes held a learners' view before.
TEST(RoomView, AFarCameraLeavesItsLearnersToTheNearerOnesAndItsEmptyViewChangesNothing) {
  const Rig rig = default_classroom_rig();
  std::vector<Eigen::Vector3d> centres;
  for (int k = 0; k < 3; ++k) centres.push_back(rig.camera(k).center_in_rig());
  const Eigen::Vector3d at0 = centres[0], between01 = 0.5 * (centres[0] + centres[1]);
  EXPECT_FALSE(learners_left_to_nearer(centres[0], centres, at0));
  EXPECT_TRUE(learners_left_to_nearer(centres[1], centres, at0));
  EXPECT_TRUE(learners_left_to_nearer(centres[2], centres, at0));
  EXPECT_FALSE(learners_left_to_nearer(centres[0], centres, between01));
  EXPECT_FALSE(learners_left_to_nearer(centres[1], centres, between01));
  EXPECT_TRUE(learners_left_to_nearer(centres[2], centres, between01));
  EXPECT_FALSE(learners_left_to_nearer(centres[1], {centres[1], centres[2]}, at0)) << "camera 0 lost";
  EXPECT_FALSE(learners_left_to_nearer(centres[2], {centres[1], centres[2]}, at0)) << "camera 0 lost";
  // As a warp asks it: the ids of the near cameras a far one leaves its learners to, none for a near one.
  const std::vector<RoomCameraPlace> named{{0, centres[0]}, {1, centres[1]}, {2, centres[2]}};
  const CameraCalib view_at0 = rig.camera(0);
  EXPECT_EQ(cameras_taking_learners(rig.camera(1), named, view_at0), std::vector<int>{0});
  EXPECT_TRUE(cameras_taking_learners(rig.camera(0), named, view_at0).empty());
  EXPECT_TRUE(cameras_taking_learners(rig.camera(1), {named[1], named[2]}, view_at0).empty()) << "camera 0 lost";

  const Classroom room(ClassroomConfig{2, 5, 2.0}), empty(ClassroomConfig{2, 0, 2.0});
  const CameraCalib cam = scale_camera(rig.camera(1), 320, 180);
  const RenderOutput frame = render(room, 1.0, cam);
  FramePreparer preparer;
  preparer.set_static_depth(render(empty, 0.0, cam).depth);
  const auto prepared = preparer.prepare(cam, frame.color, frame.depth, frame.label, WarpParams());
  const WarpSource src = FramePreparer::source_of(*prepared, frame.color, frame.depth, frame.label);
  const CameraCalib virt = scale_camera(rig.camera(0), 320, 180);
  WarpParams learners_only;
  learners_only.learners_only = true;
  ViewWarper warper;
  WarpedView learners;
  warper.warp_prepared(cam, src, prepared->source, virt, learners_only, &learners);
  ASSERT_GT(cv::countNonZero(learners.depth), 500) << "camera 1's learners in view";
  warper.warp_nothing(virt, &learners);
  ASSERT_EQ(learners.depth.size(), cv::Size(320, 180));
  EXPECT_EQ(cv::countNonZero(learners.depth), 0);
  EXPECT_EQ(cv::countNonZero(learners.weight), 0);
  EXPECT_EQ(cv::countNonZero(learners.label), 0);
  EXPECT_EQ(cv::countNonZero(learners.color.reshape(1)), 0);
  EXPECT_TRUE(learners.tiles.fit(320, 180) && learners.tiles.spans.empty()) << "tiles that mark nothing";
  RoomViewRenderer renderer;
  WarpedView room_part;
  const RoomShape shape(cam, render(empty, 0.0, cam).depth);
  renderer.render({RoomCamera{&shape, &prepared->room_texture(frame.color)}}, virt, RoomLookupParams(), &room_part);
  FuseParams base;
  base.first_is_base = true;
  FusedView alone, with_empty;
  fuse_views({&room_part}, base, &alone);
  fuse_views({&room_part, &learners}, base, &with_empty);
  EXPECT_EQ(cv::norm(alone.color, with_empty.color, cv::NORM_INF), 0.0);
}

// A fuse's rounds: a camera is told to the warps once its room has been in kSteadyRounds rounds in a row, and
// a round has its learners when every camera a frame left them to drew its own in it: not when that camera is
// missing, left its own learners too (two warps that read different poses), or shares its id with another
// camera. A frame warped whole drew its learners but has no room to be told.
TEST(RoomView, ACameraIsToldOnceSteadyAndARoundHasItsLearnersWhenTheCamerasLeftThemToDrewThem) {
  const RoomCameraPlace c0{0, Eigen::Vector3d(0, 0, 0)}, c1{1, Eigen::Vector3d(-0.8, 0, 0)};
  const RoundFrame drew0{c0, true, {}}, drew1{c1, true, {}}, left1_to0{c1, true, {0}}, left0_to1{c0, true, {1}};
  auto ids = [](const LearnerRounds& r) {
    std::vector<int> out;
    for (const RoomCameraPlace& c : r.steady()) out.push_back(c.id);
    return out;
  };
  LearnerRounds rounds;
  EXPECT_TRUE(rounds.take({drew0, drew1}));
  EXPECT_TRUE(rounds.take({drew0, drew1}));
  EXPECT_TRUE(ids(rounds).empty()) << "two rounds: not steady yet";
  EXPECT_TRUE(rounds.take({drew0, left1_to0}));
  EXPECT_EQ(ids(rounds), (std::vector<int>{0, 1}));
  EXPECT_EQ(rounds.steady()[1].centre, c1.centre);
  EXPECT_FALSE(rounds.take({left1_to0})) << "camera 0 missing";
  EXPECT_EQ(ids(rounds), (std::vector<int>{1})) << "camera 0 steady again only after three rounds";
  EXPECT_FALSE(rounds.take({left0_to1, left1_to0})) << "each left its learners to the other";
  EXPECT_TRUE(rounds.take({RoundFrame{c0, false, {}}, left1_to0})) << "camera 0 warped whole drew them";
  EXPECT_EQ(ids(rounds), (std::vector<int>{1})) << "a camera warped whole has no room to be told";
  EXPECT_FALSE(rounds.take({drew0, RoundFrame{RoomCameraPlace{0, c1.centre}, true, {0}}})) << "ids repeat";
  EXPECT_TRUE(rounds.take({drew0, drew0})) << "ids repeat, but nobody left learners";
  for (int i = 0; i < LearnerRounds::kSteadyRounds; ++i) EXPECT_TRUE(rounds.take({drew0, drew0, drew1}));
  EXPECT_EQ(ids(rounds), (std::vector<int>{1})) << "a repeated id is never named";
  rounds.clear();
  EXPECT_TRUE(rounds.steady().empty());
}

namespace {

// Camera k of the classroom at 320x180 with its room packed as viewprep packs it (static depth: the empty
// room's), and the room's depth at `view` rasterised from the three cameras' meshes.
struct LookupScene {
  std::vector<CameraCalib> cams;
  std::vector<RenderOutput> frames;
  std::vector<RoomTexture> textures;
  std::vector<std::shared_ptr<RoomShape>> shapes;
  LookupScene(int width, int height) {
    const Classroom room(ClassroomConfig{4, 5, 2.0}), empty(ClassroomConfig{4, 0, 2.0});
    textures.resize(3);
    for (int k = 0; k < 3; ++k) {
      cams.push_back(scale_camera(default_classroom_rig().camera(k), width, height));
      frames.push_back(render(room, 0.5, cams.back()));
      const cv::Mat room_depth = render(empty, 0.0, cams.back()).depth;
      shapes.push_back(std::make_shared<RoomShape>(cams.back(), room_depth));
      pack_room_records(cams.back(), room_depth.ptr<uint16_t>(), frames.back().label.ptr<uint8_t>(),
                        frames.back().color, cv::Mat(), cv::Mat(), &textures[size_t(k)]);
    }
  }
  cv::Mat depth_at(const CameraCalib& view) const {
    RoomRaster raster;
    raster.begin(view);
    for (const auto& s : shapes) raster.draw(s->mesh());
    cv::Mat d;
    raster.depth(&d);
    return d;
  }
  std::vector<const RoomTexture*> all() const { return {&textures[0], &textures[1], &textures[2]}; }
};

}  // namespace

// The lookup runs 8 pixels at a time where the CPU has AVX2 and pixel by pixel elsewhere (and for a row's last
// pixels when its width is not a multiple of 8): both give the same pixels, the colours within a grey level
// (the vector loop's square root is approximate).
TEST(RoomLookup, TheVectorLoopGivesThePixelLoopsPicture) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma"))
    GTEST_SKIP() << "this CPU has no AVX2 and FMA: the pixel loop is the only one";
  using namespace room_lookup_detail;
  // Near camera 0 (the far cameras skipped where it sees strictly), near camera 2 from camera 0's side, and
  // between the cameras looking up and turned; at a width that is a multiple of 8 and one that is not.
  const Sliders poses[] = {{40, 50, 55, 55, 50, 50}, {85, 50, 45, 45, 50, 50}, {30, 55, 60, 65, 42, 50}};
  for (const auto& [w, h] : {std::pair{320, 180}, std::pair{317, 180}}) {
    const LookupScene scene(w, h);
    for (const Sliders& s : poses) {
      const CameraCalib view =
          virtual_camera(scene.cams[0], sliders_to_pose(s, scene.cams[0]).cam_to_rig(), NAN);
      const cv::Mat depth = scene.depth_at(view);
      cv::Mat fast, fast_written;
      room_lookup(scene.all(), view, depth, RoomLookupParams(), &fast, &fast_written);
      const std::vector<LookupCamera> cams = lookup_cameras(scene.all(), view, RoomLookupParams());
      const LookupView lv = lookup_view(view, RoomLookupParams(), cams);
      cv::Mat slow(depth.size(), CV_8UC3, cv::Scalar::all(0)), slow_written(depth.size(), CV_8UC1);
      for (int y = 0; y < depth.rows; ++y)
        lookup_row_portable(cams, lv, y, 0, depth.cols, depth.ptr<uint16_t>(y), slow.ptr<uint8_t>(y),
                            slow_written.ptr<uint8_t>(y));
      ASSERT_GT(cv::countNonZero(slow_written), w * h / 3) << format_sliders(s) << ": the view should see the room";
      EXPECT_EQ(cv::countNonZero(fast_written != slow_written), 0) << w << " " << format_sliders(s);
      cv::Mat diff;
      cv::absdiff(fast, slow, diff);
      diff.setTo(0, slow_written == 0);
      double worst = 0;
      cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
      EXPECT_LE(worst, 1.0) << w << " " << format_sliders(s);
    }
  }
}

// A camera frame's packed records (room_lookup.h): the frame's depth and colour where it shows the room (label
// 0, depth known), the background memory's room layer elsewhere, or, without that layer, the frame's colour
// with the room's depth where the label is 0. Rows of every width from 1 px, so that the AVX2 loop's 4 pixels
// and the row loop's last ones are both checked, with the label, the depth and the colour random.
TEST(RoomLookup, PackedRecordsHoldTheFramesRoomAndTheMemorysBehindTheLearners) {
  cv::RNG rng(35);
  for (int width : {1, 2, 3, 5, 6, 7, 9, 10, 13, 64, 317}) {
    const int height = 3;
    CameraCalib cam;
    cam.width = width, cam.height = height, cam.fx = cam.fy = 100, cam.cx = width / 2.0, cam.cy = 1;
    cv::Mat depth(height, width, CV_16UC1), label(height, width, CV_8UC1), color(height, width, CV_8UC3);
    cv::Mat room_depth(height, width, CV_16UC1), room_color(height, width, CV_8UC3);
    rng.fill(depth, cv::RNG::UNIFORM, 0, 65536);
    rng.fill(room_depth, cv::RNG::UNIFORM, 0, 65536);
    rng.fill(color, cv::RNG::UNIFORM, 0, 256);
    rng.fill(room_color, cv::RNG::UNIFORM, 0, 256);
    rng.fill(label, cv::RNG::UNIFORM, 0, 3);  // 0: the room, 1 and 2: learners
    depth.setTo(0, depth < 8000);               // an eighth without depth
    if (__builtin_cpu_supports("avx2")) {  // the AVX2 loop takes a row's first pixels (all but the last 2-5)
      std::vector<uint64_t> scratch(static_cast<size_t>(width));
      const int packed = room_lookup_detail::room_records_avx2(width, depth.ptr<uint16_t>(), label.ptr<uint8_t>(),
                                                               color.ptr<uint8_t>(), nullptr, nullptr, scratch.data());
      EXPECT_EQ(packed, width >= 6 ? (width - 2) / 4 * 4 : 0) << "width " << width;
    }
    for (const bool with_room : {true, false}) {
      RoomTexture tex;
      pack_room_records(cam, depth.ptr<uint16_t>(), label.ptr<uint8_t>(), color, with_room ? room_depth : cv::Mat(),
                        with_room ? room_color : cv::Mat(), &tex);
      ASSERT_EQ(tex.packed.size(), size_t(width) * height);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const int d = depth.at<uint16_t>(y, x), l = label.at<uint8_t>(y, x);
          const bool frame_room = l == 0 && d != 0;
          const cv::Vec3b c = with_room && !frame_room ? room_color.at<cv::Vec3b>(y, x) : color.at<cv::Vec3b>(y, x);
          const uint64_t z = with_room ? (frame_room ? d : room_depth.at<uint16_t>(y, x)) : (l == 0 ? d : 0);
          const uint64_t want = z | uint64_t(c[0]) << 16 | uint64_t(c[1]) << 32 | uint64_t(c[2]) << 48;
          ASSERT_EQ(tex.packed[size_t(y) * width + x], want)
              << "width " << width << " at " << x << "," << y << (with_room ? " with" : " without")
              << " the room layer";
        }
    }
  }
}

// A view standing at a camera's place is that camera's picture where it sees the room (the others, drawn
// through the room's mesh, are a pixel off where the mesh is); with the angles alone (place_sigma_m 0) the
// others blend in.
TEST(RoomLookup, AViewAtACamerasPlaceShowsThatCamerasPicture) {
  const LookupScene scene(320, 180);
  const CameraCalib& view = scene.cams[0];
  const cv::Mat depth = scene.depth_at(view);
  // The room camera 0 shows, off its depth edges (there the mesh's depth is the other side's; the forward warp
  // draws them).
  cv::Mat off_edges;
  cv::absdiff(depth, scene.shapes[0]->static_depth(), off_edges);
  const cv::Mat own_room = (scene.frames[0].label == 0) & (off_edges < 10) & (depth != 0);
  auto psnr_at = [&](double sigma) {
    RoomLookupParams p;
    p.place_sigma_m = sigma;
    cv::Mat color, written;
    room_lookup(scene.all(), view, depth, p, &color, &written);
    return psnr_rgb_masked(color, scene.frames[0].color, own_room & (written != 0));
  };
  const double by_place = psnr_at(RoomLookupParams().place_sigma_m), by_angles = psnr_at(0);
  EXPECT_GT(by_place, 40.0);
  EXPECT_GT(by_place, by_angles + 3) << "angles alone: " << by_angles;
}
