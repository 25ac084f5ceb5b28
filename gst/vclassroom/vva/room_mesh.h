// The room view's mesh (room_view.h): a quadtree mesh of a camera's static depth (V-DA's prior, which does
// not change): a tile (its grid of pixel centres, border included, so neighbours meet) is two triangles when
// its depth lies on one plane (1/z linear in u and v, as a plane seen by a pinhole camera) within a
// tolerance; otherwise it splits, down to single pixel quads (two triangles, as the warp's mesh). A pixel quad
// across a depth edge (beyond max(15 mm, 3 %)) or beside a pixel without depth is drawn in parts, after all the
// leaves (RoomMesh::edge_begin): each surface to the middle of the quad's sides and its centre, the part of the
// quad nearest its pixels, so that a surface ends where the camera saw its edge, half a pixel past its last
// pixel centre. GStreamer-free.
//
// The triangles themselves (RoomMesh, optional): the vertices are the grid points the leaves' corners stand on,
// each at the prior's depth there, shared by every leaf that has it as a corner. A leaf whose side holds a
// smaller neighbour's corner (a T-junction) is drawn as a fan through every vertex on its border, from a corner
// whose two sides hold no other vertex (2 + k triangles for k such vertices), else from its centre pixel
// (4 + k), so that neighbours share whole edges and a rasteriser with a fill rule leaves no crack; a leaf
// without one is the quadtree's two triangles. The corners of the edge quads are vertices too (on a leaf's
// side, in its fan); their parts add vertices at the middles of their sides and their centres, after all
// others (RoomMesh::edge_vertex_begin).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

struct RoomMeshCount {
  long tiles[8] = {0};  // leaves by level (size 1 << level px)
  long dropped = 0;     // pixel quads across an edge or without depth (with a mesh: drawn in parts)
  long triangles() const {
    long t = 0;
    for (long n : tiles) t += 2 * n;
    return t;
  }
};

// Triangles in 3-D: vertices (metres, in the frame room_mesh was given: the rig's) as three arrays, and three
// vertex indices per triangle.
struct RoomMesh {
  std::vector<float> x, y, z;
  std::vector<uint32_t> index;
  // The triangles before this one are the leaves'; those from it on, the edge quads' parts (room_mesh; a mesh
  // made otherwise has none). Likewise the vertices: those from edge_vertex_begin on are the parts' alone.
  size_t edge_begin = SIZE_MAX, edge_vertex_begin = SIZE_MAX;
  size_t vertices() const { return x.size(); }
  size_t triangles() const { return index.size() / 3; }
};

// The quadtree of `depth` (CV_16UC1 mm) with tiles of at most 1 << top px, planar within
// max(min_mm, ratio * z). `planar` (optional): the depth as the mesh gives it at each pixel centre (a tile's
// plane inside it; the depth itself in single pixel quads). `mesh` (optional, with `cam`, the camera whose
// depth it is): the triangles, vertices in the rig frame (cam.cam_to_rig); the counts are the quadtree's
// either way (mesh->triangles() adds the fans' extra triangles and the edge quads' parts). `floor_level` > 0:
// a tile of 1 << floor_level px that is not planar but spans no depth edge (its grid within max(15 mm, 3 %))
// is a leaf all the same, its two triangles through its corners (coarser than the tolerance; the pixel quads
// stay at the edges).
RoomMeshCount room_mesh(const cv::Mat& depth, double ratio, double min_mm, int top, cv::Mat* planar = nullptr,
                        const CameraCalib* cam = nullptr, RoomMesh* mesh = nullptr, int floor_level = 0);

// The triangles of `mesh` (camera k's) that no earlier camera j already sees: a triangle is left out when one
// camera j (its pose and its static depth) sees all three of its vertices on its own depth (within
// max(20 mm, 2 %)). Pose-independent: made once with the meshes, so a view draws each surface about once.
RoomMesh room_mesh_unseen_by(const RoomMesh& mesh, const std::vector<std::pair<CameraCalib, cv::Mat>>& earlier);

}  // namespace vclassroom
