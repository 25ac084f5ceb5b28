// Turns public datasets into the recorded-dataset format that rgbdfilesrc plays.
#include <cstdio>
#include <cstring>
#include <string>

#include <gst/vclassroom/middlebury.h>

namespace {

int usage() {
  std::fprintf(stderr,
               "usage: vclassroom-import middlebury-multiview SCENE_DIR OUT_DIR [--noholes]\n"
               "       vclassroom-import middlebury-2003 SCENE_DIR OUT_DIR\n"
               "\n"
               "middlebury-multiview: Middlebury 2005/2006 scene (view<K>.png, disp1.png), e.g. art, aloe.\n"
               "  One camera per view (id = view number, view 1 at the rig origin, 40 mm apart,\n"
               "  f = 3740 px); view 1 gets depth from disp1 (or disp1_noholes with --noholes).\n"
               "middlebury-2003: quarter-size pair (im2/im6.png, disp2/disp6.pgm), e.g. teddy.\n"
               "See docs/datasets.md for the geometry.\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return usage();
  const std::string cmd = argv[1];
  try {
    vclassroom::ImportSummary s;
    if (cmd == "middlebury-multiview") {
      const bool noholes = argc > 4 && std::strcmp(argv[4], "--noholes") == 0;
      s = vclassroom::import_middlebury_multiview(argv[2], argv[3], noholes);
    } else if (cmd == "middlebury-2003") {
      s = vclassroom::import_middlebury_2003(argv[2], argv[3]);
    } else {
      return usage();
    }
    std::printf("%s: rig '%s' with %zu cameras; %d depth pixels, %d unknown, %d beyond 65535 mm\n", argv[3],
                s.rig.name.c_str(), s.rig.cameras.size(), s.depth_pixels, s.unknown_pixels, s.out_of_range);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vclassroom-import: %s\n", e.what());
    return 1;
  }
  return 0;
}
