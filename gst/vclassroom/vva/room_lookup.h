// Experiment (issue 31, branch wip/room-lookup): the room's colour blended per VIEW pixel by backward lookup.
// For each view pixel whose visible surface is the room, its 3-D point (the view's depth along its ray) is
// projected into every camera; the cameras whose room depth there agrees with the point (viewfuse's
// tolerance) see it, their colour is sampled at the projected position and blended with weights formed as
// the warp and viewfuse form them. One resampling per camera, as the forward warp's; no splat.
// GStreamer-free.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// One camera as the lookup reads it: the colour the warp draws the room from and the depth it draws it at.
struct RoomLookupSource {
  CameraCalib camera;
  cv::Mat color;       // CV_8UC3 RGB
  cv::Mat depth;       // CV_16UC1 mm along the camera's axis; 0 where the camera does not show the room
  cv::Mat remembered;  // CV_8UC1, non-zero where the colour is the background memory's (the warp's room layer,
                       // weighted by kRoomLayerWeight); may be empty
};

enum class RoomSampling {
  Nearest,   // the nearest source pixel, if its depth agrees
  Bilinear,  // the 2x2 around the position, each neighbour whose depth agrees, bilinear weights renormalised
  // As Bilinear, but a camera counts only where every neighbour of the 2x2 around the position (those more
  // than a fiftieth of a pixel away from it) agrees: the coverage of the warp's cells, which end at their
  // pixel centre towards a depth edge; where no camera covers a pixel so, the cameras as with Bilinear.
  BilinearStrict,
  BilinearAll,  // seen when a neighbour of the 2x2 agrees; the colour bilinear over all four, as the warp's
                // sampler takes it (across a depth edge too: the cameras' own images mix the two sides there)
};

enum class RoomWeights {
  Fuse,           // as the warp and viewfuse: cos^8 of the ray angle x distance ratio / sqrt(magnification),
                  // a byte, then ^weight_power
  FuseNoStretch,  // the same without the magnification term (no neighbours needed: the tight loop's choice)
  Angle,          // cos^8 of the angle between the view ray and the camera ray alone, ^weight_power
  Equal,          // every camera that sees the point alike
};

struct RoomLookupParams {
  RoomSampling sampling = RoomSampling::Bilinear;
  RoomWeights weights = RoomWeights::Fuse;
  double depth_tol_ratio = 0.03;  // FuseParams' visibility tolerance
  double depth_tol_mm = 30;
  double weight_power = 2.0;        // FuseParams::weight_power
  float remembered_weight = 0.5f;   // view_warp.cpp's kRoomLayerWeight
  // Each camera's own surface: the point moved along the view ray onto the camera's room depth (this many
  // steps, each taking the depth around the projected position as if the surface faced the camera), as the
  // forward warp draws each camera from its own depth; 0: the view's depth as it is.
  int refine_steps = 0;
};

struct RoomLookupStats {
  long candidates = 0;  // masked pixels with a depth
  long replaced = 0;    // of those, seen by at least one camera and written
  long by_one = 0;      // written from one camera only
};

// Writes into `color` (the view, CV_8UC3) the looked-up colour of every pixel where `mask` (CV_8UC1) is
// non-zero and `view_depth` (CV_16UC1 mm along the view's axis) is known and some camera sees the point;
// other pixels are left alone. `replaced` (optional, CV_8UC1): how many cameras saw each pixel written (0: not
// written). `virt` has no distortion.
RoomLookupStats room_lookup(const std::vector<RoomLookupSource>& sources, const CameraCalib& virt,
                            const cv::Mat& view_depth, const cv::Mat& mask, const RoomLookupParams& params,
                            cv::Mat* color, cv::Mat* replaced = nullptr);

}  // namespace vclassroom
