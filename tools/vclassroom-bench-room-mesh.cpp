// Issue 31 (the room view's spike, docs/room-lookup-spike.md): how many triangles a mesh of each camera's
// static depth (V-DA's prior, which does not change) needs, so that the view's room depth could be rasterised
// once per view pixel from it instead of being splatted from every source pixel. A quadtree over the prior: a tile (its grid of
// pixel centres, border included, so neighbours meet) is two triangles when its depth lies on one plane
// (1/z linear in u and v, as a plane seen by a pinhole camera) within a tolerance; otherwise it splits, down
// to single pixel quads (two triangles, as the warp's mesh; a quad across a depth edge is drawn in parts
// after the leaves, counted as dropped: room_mesh.h).
//
// --raster: the meshes rasterised into 960x540 views (room_raster.h) along a walk around camera 0 (as
// vclassroom-bench-server --views walks), timed (thread CPU per view) and compared with the cameras'
// full-resolution pixel meshes rasterised at the same poses.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/vda/static_model.h>
#include <gst/vclassroom/vva/room_mesh.h>
#include <gst/vclassroom/vva/room_raster.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "cpu_clock.h"
#include "tool_options.h"

using namespace vclassroom;

namespace {

struct Variant {
  std::string name;
  std::vector<const RoomMesh*> meshes;
  int scale = 1;  // 2: the depth rasterised at half the view's size, then enlarged (nearest)
};

// One view's room depth: what is timed (callgrind: --toggle-collect='*room_view_depth*').
__attribute__((noinline)) void room_view_depth(RoomRaster& r, const CameraCalib& view, const Variant& v,
                                               cv::Mat* small, cv::Mat* depth) {
  if (v.scale == 1) {
    r.begin(view);
    for (const RoomMesh* mesh : v.meshes) r.draw(*mesh);
    r.depth(depth);
    return;
  }
  r.begin(scale_camera(view, view.width / v.scale, view.height / v.scale));
  for (const RoomMesh* mesh : v.meshes) r.draw(*mesh);
  r.depth(small);
  cv::resize(*small, *depth, cv::Size(view.width, view.height), 0, 0, cv::INTER_NEAREST);
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))];
}

void raster_bench(const StaticModel& m, int views, int rounds, bool reference, const std::string& only) {
  cv::setNumThreads(1);
  const CameraCalib& ref = m.rig.camera(0);
  std::vector<CameraCalib> poses;
  for (int i = 0; i < views; ++i) {
    // vclassroom-bench-server --views: a sideways walk with a head turn, each view's start moved right and up.
    const int v = i % 4;
    const double s = i / 6.0;
    const Pose p = sliders_to_pose(Sliders{40 + s + 4 * v, 50.0 + 3 * v, 50, 50 + s, 50, 50}, ref);
    poses.push_back(virtual_camera(ref, p.cam_to_rig(), NAN));
  }
  std::vector<int> ids;
  for (const auto& kv : m.prior_depth) ids.push_back(kv.first);
  std::printf("%zu cameras, %d views of %dx%d (camera 0's intrinsics), %d rounds\n", ids.size(), views,
              ref.width, ref.height, rounds);
  std::map<std::string, RoomMesh> meshes;
  std::vector<Variant> variants;
  for (const auto& [ratio, min_mm, floor_level] :
       {std::tuple<double, double, int>{0.01, 10, 0}, {0.005, 5, 0}, {0.01, 10, 1}}) {
    char tol[64];
    std::snprintf(tol, sizeof tol, "max(%.0f mm, %.1f %%)%s", min_mm, 100 * ratio,
                  floor_level ? ", 2 px tiles off the edges" : "");
    Variant all{std::string("3 cameras, ") + tol, {}}, one{std::string("camera 0 alone, ") + tol, {}},
        cover{std::string("camera 0 + what it does not see, ") + tol, {}};
    std::vector<std::pair<CameraCalib, cv::Mat>> earlier;
    for (int id : ids) {
      const CameraCalib& cam = m.rig.camera(id);
      RoomMesh& mesh = meshes[std::to_string(id) + tol];
      const double t0 = vclassroom_tools::thread_cpu_ms();
      const RoomMeshCount c = room_mesh(m.prior(id), ratio, min_mm, 5, nullptr, &cam, &mesh, floor_level);
      std::printf("camera %d at %s: %ld quadtree triangles, %zu with the fans, %zu vertices (%.0f ms to build)\n", id,
                  tol, c.triangles(), mesh.triangles(), mesh.vertices(), vclassroom_tools::thread_cpu_ms() - t0);
      all.meshes.push_back(&mesh);
      if (earlier.empty()) {
        one.meshes.push_back(&mesh);
        cover.meshes.push_back(&mesh);
      } else {
        RoomMesh& rest = meshes[std::to_string(id) + tol + " uncovered"];
        rest = room_mesh_unseen_by(mesh, earlier);
        std::printf("  of which not seen by an earlier camera: %zu triangles\n", rest.triangles());
        cover.meshes.push_back(&rest);
      }
      RoomRaster own;
      own.begin(cam);
      own.draw(mesh);
      cv::Mat d;
      own.depth(&d);
      earlier.emplace_back(cam, d);
    }
    Variant all_half = all, cover_half = cover;
    all_half.name += ", at half size", cover_half.name += ", at half size";
    all_half.scale = cover_half.scale = 2;
    for (Variant* v : {&all, &cover, &one, &all_half, &cover_half})
      if (only.empty() || v->name.find(only) != std::string::npos) variants.push_back(*v);
  }
  {
    // --only names one variant exactly, or all that hold it.
    std::vector<Variant> exact;
    for (const Variant& v : variants)
      if (v.name == only) exact.push_back(v);
    if (!exact.empty()) variants = exact;
  }
  // The reference: every camera's full-resolution pixel mesh.
  std::vector<cv::Mat> truth;
  if (reference) {
    std::vector<RoomMesh> full(ids.size());
    long tris = 0;
    for (size_t k = 0; k < ids.size(); ++k) {
      room_mesh(m.prior(ids[k]), 0, 0, 0, nullptr, &m.rig.camera(ids[k]), &full[k]);
      tris += long(full[k].triangles());
    }
    std::printf("reference: the cameras' full-resolution pixel meshes, %ld triangles\n", tris);
    RoomRaster r;
    for (const CameraCalib& view : poses) {
      r.begin(view);
      for (const RoomMesh& f : full) r.draw(f);
      truth.emplace_back();
      r.depth(&truth.back());
    }
  }
  std::vector<std::vector<double>> ms(variants.size());
  std::vector<RoomRasterStats> stats(variants.size());
  // within 1 %, 1-5 %, beyond 5 %, missing, extra
  std::vector<std::array<double, 5>> acc(variants.size(), {0, 0, 0, 0, 0});
  RoomRaster r;
  cv::Mat depth, small;
  for (int round = 0; round < rounds; ++round)
    for (size_t k = 0; k < variants.size(); ++k)
      for (int i = 0; i < views; ++i) {
        const double t0 = vclassroom_tools::thread_cpu_ms();
        room_view_depth(r, poses[size_t(i)], variants[k], &small, &depth);
        ms[k].push_back(vclassroom_tools::thread_cpu_ms() - t0);
        if (round > 0) continue;
        RoomRasterStats& s = stats[k];
        s.triangles += r.stats.triangles, s.near += r.stats.near, s.empty += r.stats.empty,
            s.drawn += r.stats.drawn, s.large += r.stats.large, s.box_pixels += r.stats.box_pixels;
        if (!reference) continue;
        const cv::Mat& t = truth[size_t(i)];
        for (int y = 0; y < depth.rows; ++y) {
          const uint16_t* a = depth.ptr<uint16_t>(y);
          const uint16_t* b = t.ptr<uint16_t>(y);
          for (int x = 0; x < depth.cols; ++x) {
            if (!b[x]) {
              acc[k][4] += a[x] > 0;
            } else if (!a[x]) {
              acc[k][3] += 1;
            } else {
              const int e = std::abs(int(a[x]) - int(b[x]));
              acc[k][e <= 0.01 * b[x] ? 0 : e <= 0.05 * b[x] ? 1 : 2] += 1;
            }
          }
        }
      }
  const double px = double(views) * ref.width * ref.height;
  for (size_t k = 0; k < variants.size(); ++k) {
    const RoomRasterStats& s = stats[k];
    std::printf("\n%s:\n  thread CPU per view: median %.2f ms (10 %%: %.2f, 90 %%: %.2f, min %.2f, max %.2f; "
                "%zu views)\n",
                variants[k].name.c_str(), percentile(ms[k], 0.5), percentile(ms[k], 0.1), percentile(ms[k], 0.9),
                percentile(ms[k], 0), percentile(ms[k], 1), ms[k].size());
    std::printf("  per view: %.0f triangles, %.0f dropped at the near plane, %.0f with no pixel centre, %.0f drawn "
                "(%.0f by the 64-bit loop), %.0f box pixels scanned\n",
                double(s.triangles) / views, double(s.near) / views, double(s.empty) / views, double(s.drawn) / views,
                double(s.large) / views, double(s.box_pixels) / views);
    if (reference) {
      const double seen = acc[k][0] + acc[k][1] + acc[k][2] + acc[k][3];
      std::printf("  against the pixel meshes (%.1f %% of the view drawn there): within 1 %% %.2f %%, 1-5 %% %.2f %%, "
                  "beyond 5 %% %.2f %%, not drawn %.2f %% (of the pixels drawn there); drawn where they draw nothing "
                  "%.3f %% of the view\n",
                  100 * seen / px, 100 * acc[k][0] / seen, 100 * acc[k][1] / seen, 100 * acc[k][2] / seen,
                  100 * acc[k][3] / seen, 100 * acc[k][4] / px);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  g_autofree gchar* model = nullptr;
  int top = 5, views = 60, rounds = 3;
  gboolean raster = FALSE, no_reference = FALSE;
  g_autofree gchar* only = nullptr;
  const GOptionEntry entries[] = {
      {"model", 0, 0, G_OPTION_ARG_FILENAME, &model, "V-DA's model folder (vclassroom-build-model)", "DIR"},
      {"top", 0, 0, G_OPTION_ARG_INT, &top, "the largest tile, 1 << N px (default 5: 32 px)", "N"},
      {"raster", 0, 0, G_OPTION_ARG_NONE, &raster,
       "rasterise the meshes at max(10 mm, 1 %) and max(5 mm, 0.5 %) into views, timed and compared with the "
       "pixel meshes", nullptr},
      {"views", 0, 0, G_OPTION_ARG_INT, &views, "with --raster: views (default 60)", "N"},
      {"rounds", 0, 0, G_OPTION_ARG_INT, &rounds, "with --raster: times each view this often (default 3)", "N"},
      {"only", 0, 0, G_OPTION_ARG_STRING, &only,
       "with --raster: only the variant named TEXT, or those whose name holds it", "TEXT"},
      {"no-reference", 0, 0, G_OPTION_ARG_NONE, &no_reference,
       "with --raster: no comparison with the pixel meshes (for callgrind)", nullptr},
      {}};
  vclassroom_tools::parse_command_line(&argc, &argv, "",
                                       "Issue 31: triangles of a quadtree mesh of each camera's prior "
                                       "depth, by tolerance.",
                                       entries);
  if (!model) vclassroom_tools::usage_error("--model DIR is needed");
  const StaticModel m = load_static_model(model);
  if (raster) {
    if (views < 1 || rounds < 1) vclassroom_tools::usage_error("--views and --rounds must be at least 1");
    raster_bench(m, views, rounds, !no_reference, vclassroom_tools::text_of(only));
    return 0;
  }
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
      std::printf("  tolerance max(%.0f mm, %.2f %%): %ld triangles (%.1f per 100 px), pixel quads across an edge %ld;"
                  " tiles%s; %.1f %% of the quads in tiles of 8 px or more\n",
                  min_mm, 100 * ratio, tris, 100.0 * tris / pixels, c.dropped, by.c_str(),
                  100.0 * double(covered - c.tiles[0] - 4 * c.tiles[1] - 16 * c.tiles[2]) / double(covered));
    }
  }
  return 0;
}
