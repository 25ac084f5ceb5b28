#include <gst/vclassroom/vva/room_lookup.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/core/utility.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

// One row of pack_room_records: the room's depth and colour where the label is 0, the memory's room where a
// learner hides it, else nothing (depth 0).
VCLASSROOM_SIMD_CLONES
void room_records_row(int n, const uint16_t* __restrict depth, const uint8_t* __restrict label,
                      const uint8_t* __restrict color, const uint16_t* __restrict room_depth,
                      const uint8_t* __restrict room_color, uint64_t* __restrict out) {
  if (!room_depth || !room_color) {
    for (int x = 0; x < n; ++x) {
      const uint64_t d = label[x] == 0 ? depth[x] : 0;
      out[x] = d | uint64_t(color[3 * x]) << 16 | uint64_t(color[3 * x + 1]) << 32 | uint64_t(color[3 * x + 2]) << 48;
    }
    return;
  }
  for (int x = 0; x < n; ++x) {
    const bool seen = label[x] == 0 && depth[x] != 0;
    const uint64_t d = seen ? depth[x] : room_depth[x];
    const uint64_t r = seen ? color[3 * x] : room_color[3 * x], g = seen ? color[3 * x + 1] : room_color[3 * x + 1],
                   b = seen ? color[3 * x + 2] : room_color[3 * x + 2];
    out[x] = d | r << 16 | g << 32 | b << 48;
  }
}

}  // namespace

void pack_room_records(const CameraCalib& camera, const uint16_t* depth, const uint8_t* label, const cv::Mat& color,
                       const cv::Mat& room_depth, const cv::Mat& room_color, RoomTexture* out) {
  const int W = camera.width, H = camera.height;
  if (camera.has_distortion() || color.type() != CV_8UC3 || color.cols != W || color.rows != H)
    throw Error("camera " + std::to_string(camera.id) + "'s room cannot be packed: not pinhole, or its colour is " +
                "not RGB of its size");
  const bool room = room_depth.type() == CV_16UC1 && room_depth.size() == color.size() &&
                    room_color.type() == CV_8UC3 && room_color.size() == color.size();
  out->camera = camera;
  out->width = W, out->height = H;
  out->packed.resize(size_t(W) * H);
  for (int y = 0; y < H; ++y) {
    const uint16_t* depth_row = depth + size_t(y) * W;
    const uint8_t *label_row = label + size_t(y) * W, *color_row = color.ptr<uint8_t>(y);
    const uint16_t* room_depth_row = room ? room_depth.ptr<uint16_t>(y) : nullptr;
    const uint8_t* room_color_row = room ? room_color.ptr<uint8_t>(y) : nullptr;
    uint64_t* out_row = out->packed.data() + size_t(y) * W;
    // The first pixels with AVX2 (the row loop does not vectorise), the rest by the row loop.
    const int x = room_lookup_detail::room_records_avx2(W, depth_row, label_row, color_row, room_depth_row,
                                                        room_color_row, out_row);
    room_records_row(W - x, depth_row + x, label_row + x, color_row + 3 * x,
                     room_depth_row ? room_depth_row + x : nullptr, room_color_row ? room_color_row + 3 * x : nullptr,
                     out_row + x);
  }
}

float room_place_weight(const Eigen::Vector3d& camera_centre, const Eigen::Vector3d& view_centre, double sigma_m) {
  const double sigma2 = sigma_m * sigma_m;
  if (sigma2 <= 0) return 1.0f;
  return float(sigma2 / ((camera_centre - view_centre).squaredNorm() + sigma2));
}

float room_place_weight(const CameraCalib& camera, const CameraCalib& view, double sigma_m) {
  return room_place_weight(camera.center_in_rig(), view.center_in_rig(), sigma_m);
}

namespace room_lookup_detail {

namespace {
constexpr int kBands = 4;           // of rows, for the threads: a few per core of a small machine, for balance
}  // namespace

std::vector<LookupCamera> lookup_cameras(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt,
                                         const RoomLookupParams& params) {
  std::vector<LookupCamera> out;
  for (const RoomTexture* t : cameras) {
    const CameraCalib& cam = t->camera;
    const Eigen::Isometry3d T = cam.cam_to_rig.inverse() * virt.cam_to_rig;  // view -> camera
    const Eigen::Matrix3d M = cam.K() * T.linear() * virt.K().inverse();
    const Eigen::Vector3d tt = cam.K() * T.translation() * 1000.0;
    const Eigen::Vector3d b = M * Eigen::Vector3d(0, 0, 1), s = M.col(0);
    LookupCamera c{};
    for (int j = 0; j < 3; ++j)
      c.b[j] = float(b[j]), c.s[j] = float(s[j]), c.t[j] = float(tt[j]), c.dy[j] = float(M(j, 1));
    c.cx = float(cam.cx), c.cy = float(cam.cy), c.ifx = float(1 / cam.fx), c.ify = float(1 / cam.fy);
    c.base2 = float((cam.center_in_rig() - virt.center_in_rig()).squaredNorm() * 1e6);
    c.place = room_place_weight(cam, virt, params.place_sigma_m);
    c.rec = t->packed.data(), c.W = t->width, c.H = t->height;
    out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const LookupCamera& a, const LookupCamera& b) { return a.place > b.place; });
  return out;
}

LookupView lookup_view(const CameraCalib& virt, const RoomLookupParams& params,
                       const std::vector<LookupCamera>& cameras) {
  int first_far = int(cameras.size());
  while (first_far > 1 && room_camera_is_far(cameras[size_t(first_far) - 1].place, cameras[0].place)) --first_far;
  return LookupView{float(virt.cx),           float(virt.cy),
                    float(1 / virt.fx),       float(1 / virt.fy),
                    float(params.depth_tol_mm), float(params.depth_tol_ratio),
                    first_far};
}

namespace {

constexpr int kOne = 32767;        // 1 in the bilinear weights' Q15
constexpr int kStrictReach = 655;  // a fiftieth of a pixel in Q15
constexpr float kOnlySeen = 1.0f / 65536;

inline int mulhrs(int a, int b) { return (a * b + 16384) >> 15; }

// One camera's view of the point at view pixel (x, y), depth z (mm): its bilinear colour sums over the
// members that agree (`sum`, exact integers, and their weight `fw`), and its weight in the blend (0: it does
// not see the point).
float camera_sample(const LookupCamera& c, const LookupView& v, float x, float y, float z, float view_dist2,
                    int sum[3], int* fw, bool* strict) {
  *strict = false;
  // In the AVX2 loop's operations and order (fused multiply-adds), so that both take the same depth decisions.
  const float a0 = std::fma(x, c.s[0], c.b[0] + y * c.dy[0]), a1 = std::fma(x, c.s[1], c.b[1] + y * c.dy[1]),
              a2 = std::fma(x, c.s[2], c.b[2] + y * c.dy[2]);
  const float h0 = std::fma(z, a0, c.t[0]), h1 = std::fma(z, a1, c.t[1]), h2 = std::fma(z, a2, c.t[2]);
  const float ih = 1.0f / std::max(h2, 1.0f);
  const float u = h0 * ih, w = h1 * ih;
  if (!(u >= -0.5f && w >= -0.5f && u <= float(c.W) - 0.5f && w <= float(c.H) - 0.5f && h2 >= 50.0f)) return 0;
  const float uc = std::clamp(u, 0.0f, float(c.W) - 1.001f), vc = std::clamp(w, 0.0f, float(c.H) - 1.001f);
  const int iu = int(uc), iv = int(vc);
  const uint64_t* top = c.rec + size_t(iv) * c.W + iu;
  const uint64_t* const members[4] = {top, top + 1, top + c.W, top + c.W + 1};
  // The depths that agree: lo .. lo + width (integer mm), as 16-bit lanes hold them.
  const float lo = std::min(h2 - v.tol_mm, h2 * (1.0f / (1.0f + v.tol_ratio))),
              hi = std::max(h2 + v.tol_mm, h2 * (1.0f + v.tol_ratio));
  const int lo_i = int(std::ceil(lo));
  const int lo16 = std::clamp(lo_i, 0, 65535), width = std::clamp(int(hi) - lo_i, 0, 65535);
  const int fx = int(std::lrint((uc - float(iu)) * float(kOne))), fy = int(std::lrint((vc - float(iv)) * float(kOne)));
  const int xw[4] = {kOne - fx, fx, kOne - fx, fx}, yw[4] = {kOne - fy, kOne - fy, fy, fy};
  bool out = false;
  *fw = 0;
  sum[0] = sum[1] = sum[2] = 0;
  for (int m = 0; m < 4; ++m) {
    const uint64_t r = *members[m];
    const bool ok = ((int(r & 0xffff) - lo16) & 0xffff) <= width;
    out |= !ok && std::min(xw[m], yw[m]) > kStrictReach;
    if (!ok) continue;
    const int wm = mulhrs(xw[m], yw[m]);
    *fw += wm;
    for (int ch = 0; ch < 3; ++ch) sum[ch] += wm * int((r >> (16 * (ch + 1))) & 0xffff);
  }
  if (*fw <= 0) return 0;
  // The angle at the point in the triangle view - camera - point: cos = (a^2 + c^2 - b^2) / 2ac.
  const float du = (u - c.cx) * c.ifx, dv = (w - c.cy) * c.ify;
  const float cam_dist2 = h2 * h2 * (1.0f + du * du + dv * dv);
  const float iac = 1.0f / std::sqrt(std::max(view_dist2 * cam_dist2, 1.0f));
  const float cs = (view_dist2 + cam_dist2 - c.base2) * iac * 0.5f;
  const float cs2 = cs * cs, cs4 = cs2 * cs2, cs8 = cs4 * cs4;
  const float q = std::max(cs8, 0.02f) * std::min(1.0f, view_dist2 * iac);
  *strict = !out;
  return (out ? kOnlySeen : 1.0f) * c.place * q * q;
}

}  // namespace

void lookup_row_portable(const std::vector<LookupCamera>& cams, const LookupView& view, int y, int x_begin,
                         int x_end, const uint16_t* depth_row, uint8_t* color_row, uint8_t* written_row) {
  const float ry = (float(y) - view.cy) * view.ify;
  for (int x = x_begin; x < x_end; ++x) {
    written_row[x] = 0;
    for (int ch = 0; ch < 3; ++ch) color_row[3 * x + ch] = 0;
    const float z = float(depth_row[x]);
    if (z == 0) continue;
    const float rx = (float(x) - view.cx) * view.ifx;
    const float view_dist2 = z * z * (1.0f + rx * rx + ry * ry);
    float acc[3] = {0, 0, 0}, n = 0;
    bool seen_strictly = false;
    for (size_t k = 0; k < cams.size(); ++k) {
      if (int(k) >= view.first_far_camera && seen_strictly) break;
      int sum[3], fw;
      bool strict;
      const float wt = camera_sample(cams[k], view, float(x), float(y), z, view_dist2, sum, &fw, &strict);
      seen_strictly |= strict;
      if (wt <= 0) continue;
      const float per_weight = wt / float(std::max(fw, 1));
      for (int ch = 0; ch < 3; ++ch) acc[ch] += float(sum[ch]) * per_weight;
      n += wt;
    }
    if (n <= 0) continue;
    for (int ch = 0; ch < 3; ++ch) color_row[3 * x + ch] = uint8_t(std::min(255.0f, acc[ch] / n + 0.5f));
    written_row[x] = 255;
  }
}

}  // namespace room_lookup_detail

void room_lookup(const std::vector<const RoomTexture*>& cameras, const CameraCalib& virt, const cv::Mat& view_depth,
                 const RoomLookupParams& params, cv::Mat* color, cv::Mat* written) {
  using namespace room_lookup_detail;
  CV_Assert(view_depth.type() == CV_16UC1 && !virt.has_distortion());
  if (color->size() != view_depth.size() || color->type() != CV_8UC3) color->create(view_depth.size(), CV_8UC3);
  written->create(view_depth.size(), CV_8UC1);
  const std::vector<LookupCamera> cams = lookup_cameras(cameras, virt, params);
  const LookupView view = lookup_view(virt, params, cams);
  const int rows = view_depth.rows;
  cv::parallel_for_(cv::Range(0, kBands), [&](const cv::Range& bands) {
    const int y_begin = rows * bands.start / kBands, y_end = rows * bands.end / kBands;
    if (lookup_avx2(cams, view, view_depth, y_begin, y_end, color, written)) return;
    for (int y = y_begin; y < y_end; ++y)
      lookup_row_portable(cams, view, y, 0, view_depth.cols, view_depth.ptr<uint16_t>(y), color->ptr<uint8_t>(y),
                          written->ptr<uint8_t>(y));
  });
}

}  // namespace vclassroom
