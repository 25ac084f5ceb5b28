// Experiment (issue 31, wip/room-lookup): how many triangles a mesh of each camera's static depth (V-DA's
// prior, which does not change) needs, so that the view's room depth could be rasterised once per view pixel
// from it instead of being splatted from every source pixel. A quadtree over the prior: a tile (its grid of
// pixel centres, border included, so neighbours meet) is two triangles when its depth lies on one plane
// (1/z linear in u and v, as a plane seen by a pinhole camera) within a tolerance; otherwise it splits, down
// to single pixel quads (two triangles, as the warp's mesh; a quad across a depth edge is dropped).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include <gst/vclassroom/vda/static_model.h>

#include "tool_options.h"

using namespace vclassroom;

namespace {

struct Count {
  long tiles[8] = {0};  // leaves by level (size 1 << level)
  long dropped = 0;     // pixel quads across an edge or without depth
};

// Whether the tile's grid [x0, x0 + s] x [y0, y0 + s] lies on one plane within tol (ratio of depth, >= min_mm).
bool planar(const cv::Mat& d, int x0, int y0, int s, double ratio, double min_mm) {
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
  return true;
}

// A pixel quad's four depths on one surface (the warp's link tolerance: max(15 mm, 3 %)).
bool one_surface(const cv::Mat& d, int x0, int y0) {
  int lo = 65535, hi = 0;
  for (int k = 0; k < 4; ++k) {
    const int z = d.at<uint16_t>(y0 + (k >> 1), x0 + (k & 1));
    if (z == 0) return false;
    lo = std::min(lo, z), hi = std::max(hi, z);
  }
  return hi - lo <= std::max(15.0, 0.03 * lo);
}

void split(const cv::Mat& d, int x0, int y0, int level, double ratio, double min_mm, Count* c) {
  const int s = 1 << level;
  if (x0 >= d.cols - 1 || y0 >= d.rows - 1) return;
  const int sx = std::min(s, d.cols - 1 - x0), sy = std::min(s, d.rows - 1 - y0);
  if (level == 0) {
    if (one_surface(d, x0, y0)) ++c->tiles[0];
    else ++c->dropped;
    return;
  }
  if (sx == s && sy == s && planar(d, x0, y0, s, ratio, min_mm)) {
    ++c->tiles[level];
    return;
  }
  const int h = s / 2;
  for (int k = 0; k < 4; ++k) split(d, x0 + (k & 1) * h, y0 + (k >> 1) * h, level - 1, ratio, min_mm, c);
}

}  // namespace

int main(int argc, char** argv) {
  g_autofree gchar* model = nullptr;
  int top = 5;
  const GOptionEntry entries[] = {
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model, "V-DA's model folder (vclassroom-build-model)", "DIR"},
      {"top", 0, 0, G_OPTION_ARG_INT, &top, "the largest tile, 1 << N px (default 5: 32 px)", "N"},
      {}};
  vclassroom_tools::parse_command_line(&argc, &argv, "",
                                       "Experiment (issue 31): triangles of a quadtree mesh of each camera's prior "
                                       "depth, by tolerance.",
                                       entries);
  if (!model) vclassroom_tools::usage_error("--model DIR is needed");
  const StaticModel m = load_static_model(model);
  for (const auto& [id, depth] : m.prior_depth) {
    const long pixels = long(depth.total()), known = cv::countNonZero(depth);
    std::printf("camera %d: %dx%d, prior known at %.1f %% of pixels\n", id, depth.cols, depth.rows,
                100.0 * known / pixels);
    for (const auto& [ratio, min_mm] : {std::pair<double, double>{0.001, 2}, {0.0025, 3}, {0.005, 5}, {0.01, 10}}) {
      Count c;
      const int s = 1 << top;
      for (int y = 0; y < depth.rows - 1; y += s)
        for (int x = 0; x < depth.cols - 1; x += s) split(depth, x, y, top, ratio, min_mm, &c);
      long tris = 0, covered = 0;
      std::string by;
      for (int l = 0; l <= top; ++l) {
        tris += 2 * c.tiles[l];
        covered += c.tiles[l] << (2 * l);
        by += " " + std::to_string(1 << l) + "px:" + std::to_string(c.tiles[l]);
      }
      std::printf("  tolerance max(%.0f mm, %.2f %%): %ld triangles (%.1f per 100 px), pixel quads dropped %ld;"
                  " tiles%s; %.1f %% of the quads in tiles of 8 px or more\n",
                  min_mm, 100 * ratio, tris, 100.0 * tris / pixels, c.dropped, by.c_str(),
                  100.0 * double(covered - c.tiles[0] - 4 * c.tiles[1] - 16 * c.tiles[2]) / double(covered));
    }
  }
  return 0;
}
