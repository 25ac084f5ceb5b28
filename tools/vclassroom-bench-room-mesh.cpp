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

#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/vva/room_mesh.h>

#include "tool_options.h"

using namespace vclassroom;

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
      const RoomMeshCount c = room_mesh(depth, ratio, min_mm, top);
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
