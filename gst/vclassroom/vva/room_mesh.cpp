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

// Two depths (mm, both > 0) on one surface: within max(15 mm, 3 %) of each other.
bool same_surface(int a, int b) { return std::abs(a - b) <= std::max(15.0, 0.03 * std::min(a, b)); }

// The tile's grid (s + 1 points a side) has depth everywhere and spans no edge: max - min within
// max(15 mm, 3 %).
bool one_surface(const cv::Mat& d, int x0, int y0, int s = 1) {
  int lo = 65535, hi = 0;
  for (int y = y0; y <= y0 + s; ++y)
    for (int x = x0; x <= x0 + s; ++x) {
      const int z = d.at<uint16_t>(y, x);
      if (z == 0) return false;
      lo = std::min(lo, z), hi = std::max(hi, z);
    }
  return same_surface(lo, hi);
}

struct Leaf {
  int x0, y0, level;
};

struct Quadtree {
  const cv::Mat& d;
  double ratio, min_mm;
  cv::Mat* planar;
  RoomMeshCount count;
  std::vector<Leaf>* leaves;  // optional: every leaf that is drawn
  std::vector<Leaf>* edges;   // optional: the pixel quads across an edge or beside a pixel without depth
  int floor_level = 0;        // tiles of this level that span no edge are leaves even when not planar

  void split(int x0, int y0, int level) {
    const int s = 1 << level;
    if (x0 >= d.cols - 1 || y0 >= d.rows - 1) return;
    if (level == 0) {
      if (one_surface(d, x0, y0)) {
        ++count.tiles[0];
        if (leaves) leaves->push_back({x0, y0, 0});
      } else {
        ++count.dropped;
        if (edges) edges->push_back({x0, y0, 0});
      }
      return;
    }
    Eigen::Vector3d p;
    if (x0 + s <= d.cols - 1 && y0 + s <= d.rows - 1 && planar_tile(d, x0, y0, s, ratio, min_mm, &p)) {
      ++count.tiles[level];
      if (leaves) leaves->push_back({x0, y0, level});
      if (planar)
        for (int y = y0; y <= y0 + s; ++y)
          for (int x = x0; x <= x0 + s; ++x)
            planar->at<uint16_t>(y, x) =
                cv::saturate_cast<uint16_t>(1000.0 / p.dot(Eigen::Vector3d(x - x0, y - y0, 1)));
      return;
    }
    if (level == floor_level && x0 + s <= d.cols - 1 && y0 + s <= d.rows - 1 && one_surface(d, x0, y0, s)) {
      ++count.tiles[level];
      if (leaves) leaves->push_back({x0, y0, level});
      return;
    }
    const int h = s / 2;
    for (int k = 0; k < 4; ++k) split(x0 + (k & 1) * h, y0 + (k >> 1) * h, level - 1);
  }
};

// A pixel quad across a depth edge, or with a corner without depth: the camera's pixels own the parts of the
// quad nearest to them, so each run of ring-neighbour corners on one surface is drawn as the polygon from the
// middle of the side where it begins, through its corners, to the middle of the side where it ends and the
// quad's centre, fanned from the centre. A surface then ends half a pixel past its last pixel centre, where the
// camera saw its edge: dropped, the nearer side of every edge would be drawn half a pixel short, and views
// moved a little from the camera put the room's outlines a pixel off the truth. The runs behind the quad's
// nearest surface are drawn too: left to the view's gap closing (room_view.cpp), which gives a gap its
// neighbour's depth, not the surface's own, they saved 0.6 ms a view (vclassroom-bench-server --room-view)
// but cost 0.13 dB at the cameras' own places and 0.2 through the elements at 160x90 (2026-11-28).
template <typename AddVertex, typename Tri>
void emit_edge_quad(const cv::Mat& d, int x0, int y0, const int32_t (&corner)[4], AddVertex&& add, Tri&& tri) {
  const int cx[4] = {x0, x0 + 1, x0 + 1, x0}, cy[4] = {y0, y0, y0 + 1, y0 + 1};  // clockwise from the top left
  int z[4];
  for (int i = 0; i < 4; ++i) z[i] = d.at<uint16_t>(cy[i], cx[i]);
  bool link[4];  // corner i and i + 1 on one surface
  int links = 0;
  for (int i = 0; i < 4; ++i) links += link[i] = z[i] > 0 && z[(i + 1) % 4] > 0 && same_surface(z[i], z[(i + 1) % 4]);
  if (links == 4) {  // a steep surface, not an edge: the quad's two triangles
    const uint32_t a = uint32_t(corner[0]), b = uint32_t(corner[1]), c = uint32_t(corner[2]), e = uint32_t(corner[3]);
    tri(a, b, c), tri(a, c, e);
    return;
  }
  int start = 0;  // a corner whose link from the one before is broken: runs begin there
  while (link[(start + 3) % 4]) ++start;
  const double mx = x0 + 0.5, my = y0 + 0.5;
  for (int k = 0; k < 4;) {
    const int first = (start + k) % 4;
    int n = 1;
    while (k + n < 4 && link[(first + n - 1) % 4]) ++n;
    k += n;
    if (z[first] == 0) continue;
    const int last = (first + n - 1) % 4, before = (first + 3) % 4, after = (last + 1) % 4;
    const uint32_t begin = add(0.5 * (cx[before] + cx[first]), 0.5 * (cy[before] + cy[first]), double(z[first]));
    const uint32_t end = add(0.5 * (cx[last] + cx[after]), 0.5 * (cy[last] + cy[after]), double(z[last]));
    if (n == 2) {  // half the quad, a rectangle: the centre lies on its side from `begin` to `end`
      tri(begin, uint32_t(corner[first]), uint32_t(corner[last])), tri(begin, uint32_t(corner[last]), end);
      continue;
    }
    double zsum = 0;
    for (int i = 0; i < n; ++i) zsum += z[(first + i) % 4];
    const uint32_t centre = add(mx, my, zsum / n);
    uint32_t prev = begin;
    for (int i = 0; i < n; ++i) {
      const uint32_t c = uint32_t(corner[(first + i) % 4]);
      tri(centre, prev, c);
      prev = c;
    }
    tri(centre, prev, end);
  }
}

// The leaves' triangles: a vertex per grid point that is a leaf's corner (and per fan centre); then the edge
// quads' parts (emit_edge_quad).
void emit_mesh(const cv::Mat& d, const std::vector<Leaf>& leaves, const std::vector<Leaf>& edges,
               const CameraCalib& cam, RoomMesh* mesh) {
  const int W = d.cols;
  std::vector<int32_t> vid(d.total(), -1);
  mesh->x.clear(), mesh->y.clear(), mesh->z.clear(), mesh->index.clear();
  const Eigen::Matrix3d R = cam.cam_to_rig.linear();
  const Eigen::Vector3d t = cam.cam_to_rig.translation();
  auto add_point = [&](double x, double y, double z_mm) {
    const double z = z_mm * 1e-3;
    const Eigen::Vector2d n = cam.has_distortion() ? cam.normalized(x, y)
                                                   : Eigen::Vector2d((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy);
    const Eigen::Vector3d p = R * Eigen::Vector3d(n.x() * z, n.y() * z, z) + t;
    mesh->x.push_back(float(p.x())), mesh->y.push_back(float(p.y())), mesh->z.push_back(float(p.z()));
    return uint32_t(mesh->x.size() - 1);
  };
  auto add_vertex = [&](int x, int y) { return int32_t(add_point(x, y, d.at<uint16_t>(y, x))); };
  auto corner = [&](int x, int y) {
    int32_t& v = vid[size_t(y) * W + x];
    if (v < 0) v = add_vertex(x, y);
    return v;
  };
  for (const Leaf& l : leaves) {
    const int s = 1 << l.level;
    corner(l.x0, l.y0), corner(l.x0 + s, l.y0), corner(l.x0, l.y0 + s), corner(l.x0 + s, l.y0 + s);
  }
  // The edge quads' corners with depth: on a leaf's side (its grid, on its plane) they join its fan.
  for (const Leaf& e : edges)
    for (int k = 0; k < 4; ++k) {
      const int x = e.x0 + (k & 1), y = e.y0 + (k >> 1);
      if (d.at<uint16_t>(y, x) != 0) corner(x, y);
    }
  auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
    mesh->index.push_back(a), mesh->index.push_back(b), mesh->index.push_back(c);
  };
  std::vector<uint32_t> ring;
  for (const Leaf& l : leaves) {
    const int s = 1 << l.level, x0 = l.x0, y0 = l.y0, x1 = x0 + s, y1 = y0 + s;
    auto at = [&](int x, int y) { return vid[size_t(y) * W + x]; };
    ring.clear();
    if (s > 1) {  // the border clockwise from the top left corner, the vertices on it
      for (int x = x0; x < x1; ++x)
        if (at(x, y0) >= 0) ring.push_back(uint32_t(at(x, y0)));
      for (int y = y0; y < y1; ++y)
        if (at(x1, y) >= 0) ring.push_back(uint32_t(at(x1, y)));
      for (int x = x1; x > x0; --x)
        if (at(x, y1) >= 0) ring.push_back(uint32_t(at(x, y1)));
      for (int y = y1; y > y0; --y)
        if (at(x0, y) >= 0) ring.push_back(uint32_t(at(x0, y)));
    }
    if (ring.size() <= 4) {
      const uint32_t a = uint32_t(at(x0, y0)), b = uint32_t(at(x1, y0)), c = uint32_t(at(x1, y1)),
                     e = uint32_t(at(x0, y1));
      tri(a, b, c), tri(a, c, e);
      continue;
    }
    // A corner whose two sides hold no other vertex sees the whole border: a fan from it (2 + k triangles);
    // else a fan from the centre pixel (4 + k).
    const int32_t corners[4] = {at(x0, y0), at(x1, y0), at(x1, y1), at(x0, y1)};
    size_t cpos[4], k = 0;
    for (size_t i = 0; i < ring.size() && k < 4; ++i)
      if (int32_t(ring[i]) == corners[k]) cpos[k++] = i;
    const size_t n = ring.size();
    int from = -1;
    for (int c = 0; c < 4 && from < 0; ++c) {
      const size_t before = (cpos[c] + n - cpos[(c + 3) % 4]) % n, after = (cpos[(c + 1) % 4] + n - cpos[c]) % n;
      if (before == 1 && after == 1) from = c;
    }
    if (from >= 0) {
      const size_t o = cpos[from];
      for (size_t i = 1; i + 1 < n; ++i) tri(ring[o], ring[(o + i) % n], ring[(o + i + 1) % n]);
      continue;
    }
    const uint32_t centre = uint32_t(add_vertex(x0 + s / 2, y0 + s / 2));
    for (size_t i = 0; i < n; ++i) tri(centre, ring[i], ring[(i + 1) % n]);
  }
  mesh->edge_begin = mesh->triangles(), mesh->edge_vertex_begin = mesh->vertices();
  for (const Leaf& e : edges) {
    const int32_t corners[4] = {vid[size_t(e.y0) * W + e.x0], vid[size_t(e.y0) * W + e.x0 + 1],
                                vid[size_t(e.y0 + 1) * W + e.x0 + 1], vid[size_t(e.y0 + 1) * W + e.x0]};
    emit_edge_quad(d, e.x0, e.y0, corners, add_point, tri);
  }
}

}  // namespace

RoomMeshCount room_mesh(const cv::Mat& depth, double ratio, double min_mm, int top, cv::Mat* planar,
                        const CameraCalib* cam, RoomMesh* mesh, int floor_level) {
  CV_Assert(depth.type() == CV_16UC1 && top >= 0 && top < 8);
  CV_Assert(!mesh || cam);
  if (planar) depth.copyTo(*planar);
  std::vector<Leaf> leaves, edges;
  Quadtree q{depth, ratio, min_mm, planar, {}, mesh ? &leaves : nullptr, mesh ? &edges : nullptr, floor_level};
  const int s = 1 << top;
  for (int y = 0; y < depth.rows - 1; y += s)
    for (int x = 0; x < depth.cols - 1; x += s) q.split(x, y, top);
  if (mesh) emit_mesh(depth, leaves, edges, *cam, mesh);
  return q.count;
}

// The triangles of `mesh` (camera k's) that no earlier camera j already sees: a triangle is left out when one
// camera j sees all three of its vertices on its own mesh (within max(20 mm, 2 %) of its depth there).
RoomMesh room_mesh_unseen_by(const RoomMesh& mesh, const std::vector<std::pair<CameraCalib, cv::Mat>>& earlier) {
  const size_t nv = mesh.vertices();
  std::vector<uint8_t> seen(nv * earlier.size(), 0);
  for (size_t j = 0; j < earlier.size(); ++j) {
    const CameraCalib& c = earlier[j].first;
    const cv::Mat& d = earlier[j].second;
    const Eigen::Isometry3d to_cam = c.cam_to_rig.inverse();
    for (size_t i = 0; i < nv; ++i) {
      const Eigen::Vector3d p = to_cam * Eigen::Vector3d(mesh.x[i], mesh.y[i], mesh.z[i]);
      if (p.z() <= 0.05) continue;
      const int u = int(std::lround(c.cx + c.fx * p.x() / p.z())), v = int(std::lround(c.cy + c.fy * p.y() / p.z()));
      if (u < 0 || v < 0 || u >= d.cols || v >= d.rows) continue;
      const double z = d.at<uint16_t>(v, u), mm = 1000 * p.z();
      seen[i * earlier.size() + j] = z > 0 && std::fabs(z - mm) <= std::max(20.0, 0.02 * mm);
    }
  }
  RoomMesh out = mesh;
  out.index.clear();
  for (size_t t = 0; t < mesh.triangles(); ++t) {
    if (t == mesh.edge_begin) out.edge_begin = out.triangles();  // the edge parts still come last
    const uint32_t* v = &mesh.index[3 * t];
    bool covered = false;
    for (size_t j = 0; j < earlier.size() && !covered; ++j)
      covered = seen[v[0] * earlier.size() + j] && seen[v[1] * earlier.size() + j] && seen[v[2] * earlier.size() + j];
    if (!covered) out.index.insert(out.index.end(), v, v + 3);
  }
  if (mesh.edge_begin >= mesh.triangles()) out.edge_begin = std::min(mesh.edge_begin, out.triangles());
  return out;
}

}  // namespace vclassroom
