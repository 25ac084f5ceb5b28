// The room's colour at a view, looked up backward (docs/vva.md, "How a view is made"): each view pixel whose
// room depth is known (room_raster.h) is a point in the room; it is projected into every camera, and the
// cameras whose room depth there agrees with the point see it. Each such camera's colour is sampled bilinearly
// over the members of the 2x2 around the projected position that agree, and the cameras are blended.
// GStreamer-free.
//
// Which cameras, and how much each:
// - A camera sees the point strictly when the members of its 2x2 that disagree take no part in the bilinear
//   sample: the position lies within a fiftieth of a pixel of the agreeing members' row or column (the
//   coverage of the forward warp's cells, which end at their pixel centre towards a depth edge). Where some
//   camera sees the point strictly, the others that only see it count 2^-16 as much.
// - Each camera is weighed as the forward warp weighs its samples and viewfuse blends them: cos^8 of the angle
//   between the view's ray and the camera's (at least 0.02), times how much nearer the view is (at most 1),
//   squared.
// - ... and by where the view stands: sigma^2 / (d^2 + sigma^2) for a camera d metres from the view's centre.
//   A view at a camera's own place is that camera's own picture (the others, seen through the room's mesh, are
//   a pixel off where the mesh is), and a view between cameras blends them as the angles say.
// - A camera whose place weight is under 0.3 of the nearest camera's is not looked at where a nearer camera
//   sees the point strictly (a lecturer within 25 cm of a camera, on the line to one 0.8 m away: the lookup
//   reads one camera instead of two; vclassroom-eval-views --room-view, 2026-11-28: near camera 0 from all
//   three cameras 26.782 dB against 26.790 at 0.15, Table I and the novel poses the same to three decimals,
//   and along vclassroom-bench-server's walk no view draws two cameras' whole meshes where a quarter did).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

// A camera's room as the lookup reads it, made once per camera frame: per pixel one record of four 16-bit
// lanes, depth (mm, 0: the camera does not show the room there), r, g, b.
struct RoomTexture {
  CameraCalib camera;  // pinhole
  int width = 0, height = 0;
  std::vector<uint64_t> packed;
  // The colour is the background memory's, averaged over frames (not one frame's sensor noise).
  bool steady = false;
};

// The records of a camera frame: the room's `depth` (width x height, mm) where `label` (likewise) is 0, with
// the frame's `color` (RGB); where a learner hides the room, the background memory's room layer (`room_depth`,
// `room_color`; may be empty: nothing there). Throws Error for a camera with distortion or images of another
// size than the camera's.
void pack_room_records(const CameraCalib& camera, const uint16_t* depth, const uint8_t* label, const cv::Mat& color,
                       const cv::Mat& room_depth, const cv::Mat& room_color, RoomTexture* out);

struct RoomLookupParams {
  // A camera's depth agrees with the point within max(depth_tol_mm, depth_tol_ratio x depth) (viewfuse's).
  double depth_tol_ratio = 0.03, depth_tol_mm = 30;
  // The view's place in the weights (metres; 0: the angles alone). It sharpens a view near a camera but
  // averages less of the cameras' noise: RoomViewRenderer uses it where every camera's colour is steady.
  double place_sigma_m = 0.2;
};

// Writes into `color` (the view's size, CV_8UC3 RGB; made when it is not) the looked-up colour of every
// pixel where `view_depth` (CV_16UC1 mm along the view's axis) is known and some camera sees the point, black
// into the others. `written` (CV_8UC1, made): 255 where a colour was looked up, 0 elsewhere. `virt` is
// pinhole. With AVX2 and FMA, 8 view pixels at a time; elsewhere (and for the last pixels of a row whose width
// is not a multiple of 8) pixel by pixel, giving the same colours within a grey level.
void room_lookup(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt, const cv::Mat& view_depth,
                 const RoomLookupParams& params, cv::Mat* color, cv::Mat* written);

// A camera's weight for where the view stands: sigma^2 / (d^2 + sigma^2), d the distance between their
// centres (metres); 1 with sigma 0.
float room_place_weight(const Eigen::Vector3d& camera_centre, const Eigen::Vector3d& view_centre, double sigma_m);
float room_place_weight(const CameraCalib& camera, const CameraCalib& view, double sigma_m);
// A camera under this share of the nearest camera's place weight is far: looked at only where no nearer camera
// sees the point strictly, and its mesh drawn only where the near ones leave a hole (room_view.h).
constexpr float kRoomFarPlace = 0.3f;
inline bool room_camera_is_far(float place, float nearest_place) { return place < kRoomFarPlace * nearest_place; }

namespace room_lookup_detail {

// One camera for one view: view pixel (x, y) at view depth z (mm) lands at camera pixel h / h.z with
// h = z * (b + y * dy + x * s) + t, h.z its depth in the camera (mm); what the weights need.
struct LookupCamera {
  float b[3], s[3], t[3], dy[3];
  float cx, cy, ifx, ify;  // the camera's pinhole
  float base2;             // its centre's squared distance from the view's (mm^2)
  float place;             // the view's place weight for it
  const uint64_t* rec;
  int W, H;
};
struct LookupView {
  float cx, cy, ifx, ify;  // the view's pinhole
  float tol_mm, tol_ratio;
  // The cameras (lookup_cameras' order: nearest first) from this one on are skipped where one before it sees
  // the point strictly.
  int first_far_camera;
};
// The cameras, nearest to the view first.
std::vector<LookupCamera> lookup_cameras(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt,
                                         const RoomLookupParams& params);
LookupView lookup_view(const CameraCalib& virt, const RoomLookupParams& params,
                       const std::vector<LookupCamera>& cameras);

// Pixels [x_begin, x_end) of row y, one by one (the reference and the fallback); black where not seen.
void lookup_row_portable(const std::vector<LookupCamera>& cams, const LookupView& view, int y, int x_begin,
                         int x_end, const uint16_t* depth_row, uint8_t* color_row, uint8_t* written_row);
// Rows [y_begin, y_end) of the view 8 pixels at a time (the rest of each row by lookup_row_portable). False,
// nothing done, where the CPU lacks AVX2 and FMA.
bool lookup_avx2(const std::vector<LookupCamera>& cams, const LookupView& view, const cv::Mat& view_depth,
                 int y_begin, int y_end, cv::Mat* color, cv::Mat* written);

// The first pixels of a row of pack_room_records, 4 at a time with AVX2 (the same records as the row loop):
// how many it packed (a multiple of 4; when it packs any, at least two pixels are left, so that no load reads
// past the row's colour); 0 where the CPU lacks AVX2. `room_depth`, `room_color`: both or neither.
int room_records_avx2(int n, const uint16_t* depth, const uint8_t* label, const uint8_t* color,
                      const uint16_t* room_depth, const uint8_t* room_color, uint64_t* out);

}  // namespace room_lookup_detail

}  // namespace vclassroom
