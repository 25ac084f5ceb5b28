// Importers that turn the Middlebury stereo data into recorded datasets
// (docs/datasets.md explains the geometry and why the rig is right).
#pragma once

#include <string>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// Middlebury 2005/2006 multi-view scenes (Art, Aloe, ...): rectified views
// 0..6 equally spaced, disparity of view 1 towards view 5 in disp1.png.
struct MiddleburyMultiviewGeometry {
  double focal_px = 3740.0;     // full-size focal length (Middlebury 2005/2006 documentation)
  double view_spacing_m = 0.040;  // 160 mm between views 1 and 5
};

struct ImportSummary {
  Rig rig;
  int depth_pixels = 0;     // pixels given a depth
  int unknown_pixels = 0;   // disparity 0 (unknown): depth 0
  int out_of_range = 0;     // depth beyond 65535 mm: left at 0
};

// scene_dir holds view<K>.png and disp1.png (or disp1_noholes.png with
// `noholes`). Camera ids are view numbers; view 1 is the rig origin and the
// only camera with depth. Throws Error.
ImportSummary import_middlebury_multiview(const std::string& scene_dir, const std::string& out_folder,
                                          bool noholes = false,
                                          const MiddleburyMultiviewGeometry& g = MiddleburyMultiviewGeometry());

// Middlebury 2003 pair (Teddy, Cones) at quarter size: im2.png, im6.png,
// disp2.pgm, disp6.pgm (disparity x4 between views 2 and 6). Cameras 2 and 6,
// both with depth; f = 3740/4 px and 40 mm per view step are assumed (the
// release gives none), so depth is correct up to one global scale. Throws Error.
ImportSummary import_middlebury_2003(const std::string& scene_dir, const std::string& out_folder);

// Depth in mm from a disparity (pixels) between two views `baseline_m` apart.
// 0 when the disparity is unknown (<= 0) or the depth does not fit 16 bits.
unsigned short disparity_to_depth_mm(double disparity_px, double focal_px, double baseline_m);

}  // namespace vclassroom
