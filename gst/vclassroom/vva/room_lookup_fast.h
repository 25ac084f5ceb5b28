// Experiment (issue 31, branch wip/room-lookup): the backward room lookup of room_lookup.h as a tight loop,
// to count what it costs per view. Per camera frame (no pose): the room's depth and colour packed for the
// lookup. Per view: for each camera a 3x3 map of view pixel x depth to camera pixel, and per view row a few
// loops over whole rows, written so the compiler vectorises them (gathers for the 2x2 around each position).
// Strict cell coverage, each camera's own surface (refine steps), equal weights or the warp's cos^8 x
// distance. GStreamer-free.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/room_lookup.h>

namespace vclassroom {

// A camera's room as the fast lookup reads it, made once per camera frame.
struct RoomTexture {
  CameraCalib camera;  // no distortion
  int width = 0, height = 0;
  std::vector<float> depth;     // mm, 0 where the camera does not show the room
  std::vector<uint32_t> color;  // 0x00bbggrr
  std::vector<float> scale;     // the warp's weight scale (1, or the room layer's 0.5)
  std::vector<uint16_t> planes;  // depth (mm), r, g, b as four planes of W x H (the AVX2 gathers')
  std::vector<uint64_t> packed;  // per pixel four 16-bit lanes: depth (mm), r, g, b (the packed samplers')
};
void pack_room_texture(const RoomLookupSource& source, RoomTexture* out);
// Only the packed records (what the AVX2 loop reads), straight from a prepared frame: its depth and labels
// (width x height), the colour warped, and the background memory's room layer (may be empty).
void pack_room_records(const CameraCalib& camera, const uint16_t* depth, const uint8_t* label, const cv::Mat& color,
                       const cv::Mat& room_depth, const cv::Mat& room_color, RoomTexture* out);

struct RoomLookupFastParams {
  int refine_steps = 2;
  bool equal_weights = true;  // false: cos^8 of the ray angle x distance ratio, ^2 (viewfuse w/o magnification)
  double depth_tol_ratio = 0.03, depth_tol_mm = 30;
  // Only the best camera per pixel (the highest weight; with equal_weights the warp's cos^8 x distance then
  // picks it): one colour sample per view pixel instead of one per camera.
  bool best_only = false;
  // The 2x2 sampled from the packed records with SSE2, bilinear weights in 1/16 px, equal weights only: the
  // hand-written form of the sample, to count what it saves.
  bool packed = false;
  // 0 steps, equal weights, strict: the hand-written AVX2 loop (room_lookup_avx2.cpp) where the CPU has AVX2
  // and FMA, this loop elsewhere.
  bool avx2 = false;
  bool avx2_gather = false;  // with avx2: the 2x2 by 32-bit hardware gathers from the planes, no transpose
};

// As room_lookup() with BilinearStrict sampling. Returns 0 (the pixels written are not counted).
// `written` (optional; the AVX2 loop and the packed loop only): CV_8UC1, 255 where a colour was written.
long room_lookup_fast(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt,
                      const cv::Mat& view_depth, const cv::Mat& mask, const RoomLookupFastParams& params,
                      cv::Mat* color, cv::Mat* written = nullptr);

// The AVX2 form (params: 0 steps, equal weights; the tolerance is read). False, nothing done, where the CPU
// lacks AVX2 + FMA or the view's width is not a multiple of 8.
// `written` (optional): CV_8UC1, 255 where a colour was written, 0 elsewhere.
bool room_lookup_avx2(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt,
                      const cv::Mat& view_depth, const cv::Mat& mask, const RoomLookupFastParams& params,
                      cv::Mat* color, cv::Mat* written = nullptr);

}  // namespace vclassroom
