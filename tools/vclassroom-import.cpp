// Turns public datasets into the recorded-dataset format that rgbdfilesrc plays.
#include <cstdio>
#include <string>

#include <gst/vclassroom/datasets/middlebury.h>
#include <gst/vclassroom/datasets/posed_sequence.h>

#include "tool_options.h"

int main(int argc, char** argv) {
  gboolean noholes = FALSE;
  const GOptionEntry entries[] = {
      {"noholes", 0, 0, G_OPTION_ARG_NONE, &noholes,
       "middlebury-multiview: view 1's depth from disp1_noholes instead of disp1", nullptr},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "middlebury-multiview|middlebury-2003|posed-sequence SCENE_DIR OUT_DIR",
      "middlebury-multiview: Middlebury 2005/2006 scene (view<K>.png, disp1.png), e.g. art, aloe.\n"
      "  One camera per view (id = view number, view 1 at the rig origin, 40 mm apart,\n"
      "  f = 3740 px); view 1 gets depth from disp1 (or disp1_noholes with --noholes).\n"
      "middlebury-2003: quarter-size pair (im2/im6.png, disp2/disp6.pgm), e.g. teddy.\n"
      "posed-sequence: RGB-D frames with a pose each (rgbd.match, trajectory.log), e.g. the\n"
      "  Redwood living room; one camera per frame at its pose (id = frame number).\n"
      "OUT_DIR is made with its parents. See docs/datasets.md for the geometry.",
      entries, nullptr, 3);
  const std::string format = argv[1], scene = argv[2], out = argv[3];
  if (format != "middlebury-multiview" && format != "middlebury-2003" && format != "posed-sequence")
    vclassroom_tools::usage_error("unknown format '" + format +
                                  "': middlebury-multiview, middlebury-2003 or posed-sequence");
  if (noholes && format != "middlebury-multiview")
    vclassroom_tools::usage_error("--noholes is for middlebury-multiview only");
  if (!vclassroom_tools::make_folder(out)) return 1;
  try {
    const vclassroom::ImportSummary s = format == "middlebury-multiview" ? vclassroom::import_middlebury_multiview(scene, out, noholes)
                                        : format == "middlebury-2003"    ? vclassroom::import_middlebury_2003(scene, out)
                                                                         : vclassroom::import_posed_sequence(scene, out);
    std::printf("%s: rig '%s' with %zu cameras; %d depth pixels, %d unknown, %d beyond 65535 mm\n", out.c_str(),
                s.rig.name.c_str(), s.rig.cameras.size(), s.depth_pixels, s.unknown_pixels, s.out_of_range);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vclassroom-import: %s\n", e.what());
    return 1;
  }
  return 0;
}
