#include <gst/vclassroom/capture/depth_registration.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

// floor and ceil for the footprints' small coordinates, without the library
// calls (this loop runs once per depth pixel).
inline int floor_int(float v) {
  const int i = int(v);
  return i - (v < float(i));
}
inline int ceil_int(float v) { return -floor_int(-v); }

// A footprint larger than 16 px is a grazing artefact.
constexpr float kMaxHalf = 8.0f;
// One depth pixel covers (colour f / depth f) * (depth z / colour z) colour
// pixels across; a hair more, so that neighbours at one depth always meet.
constexpr float kOverlap = 0.01f;

// Eight lanes of GCC's vector extensions: each target_clones copy compiles
// them to its own instructions (two SSE2 halves, or one AVX2 / AVX-512 op).
typedef float F8 __attribute__((vector_size(32)));
typedef int32_t I8 __attribute__((vector_size(32)));
typedef uint16_t U8 __attribute__((vector_size(16)));

struct Projection {
  float tx, ty, tz, fx, fy, cx, cy, half_x, half_y;
  float right_limit, bottom_limit;  // footprints are clipped to a band around the image, so ints stay in range
  int32_t width, height;            // the colour image's
};

// Where eight depth pixels land in an undistorted colour camera: the colour
// pixel centres their footprints cover (x0..x1, y0..y1; the band, not yet the
// image), their depth there in mm (0: nothing lands), and, for a footprint of
// exactly one pixel inside the image (most of them), that pixel's index in the
// colour image (else -1).
VCLASSROOM_SIMD_INLINE void project8(const uint16_t* d, const float* rx, const float* ry, const float* rz,
                                     const Projection& p, int32_t* x0, int32_t* x1, int32_t* y0, int32_t* y1,
                                     int32_t* zc, int32_t* single) {
  U8 raw;
  F8 ax, ay, az;
  std::memcpy(&raw, d, sizeof raw);
  std::memcpy(&ax, rx, sizeof ax);
  std::memcpy(&ay, ry, sizeof ay);
  std::memcpy(&az, rz, sizeof az);
  const F8 z = __builtin_convertvector(__builtin_convertvector(raw, I8), F8) * 0.001f;
  const F8 qx = ax * z + p.tx, qy = ay * z + p.ty, qz = az * z + p.tz;
  const F8 safe_qz = qz > 1e-6f ? qz : F8{} + 1e-6f;
  const F8 inv = 1.0f / safe_qz;
  const F8 u = p.fx * qx * inv + p.cx, v = p.fy * qy * inv + p.cy;
  const F8 zr = z * inv;
  F8 hw = p.half_x * zr + kOverlap, hh = p.half_y * zr + kOverlap;
  hw = hw < kMaxHalf ? hw : F8{} + kMaxHalf;
  hh = hh < kMaxHalf ? hh : F8{} + kMaxHalf;
  // (Written out, not as helpers: a function passing 32-byte vectors has another ABI in the SSE2 copy.)
  const F8 lo = F8{} - 2 * kMaxHalf, right_limit = F8{} + p.right_limit, bottom_limit = F8{} + p.bottom_limit;
  F8 left = u - hw, right = u + hw, top = v - hh, bottom = v + hh;
  left = left > lo ? left : lo, right = right > lo ? right : lo, top = top > lo ? top : lo;
  bottom = bottom > lo ? bottom : lo;
  left = left < right_limit ? left : right_limit, right = right < right_limit ? right : right_limit;
  top = top < bottom_limit ? top : bottom_limit, bottom = bottom < bottom_limit ? bottom : bottom_limit;
  // Conversion truncates towards zero; a compare's -1 turns that into ceil (left, top) or floor (right, bottom).
  const I8 tl = __builtin_convertvector(left, I8), tr = __builtin_convertvector(right, I8);
  const I8 tt = __builtin_convertvector(top, I8), tb = __builtin_convertvector(bottom, I8);
  const I8 l = tl - (__builtin_convertvector(tl, F8) < left), r = tr + (__builtin_convertvector(tr, F8) > right);
  const I8 t = tt - (__builtin_convertvector(tt, F8) < top), b = tb + (__builtin_convertvector(tb, F8) > bottom);
  const F8 mm = qz * 1000.0f + 0.5f;
  const F8 mm_safe = mm < 65536.0f ? mm : F8{};
  const I8 lands = (z > 0) & (qz > 0) & (mm >= 1.0f) & (mm < 65536.0f);
  const I8 depth = __builtin_convertvector(mm_safe, I8) & lands;
  const I8 one = (l == r) & (t == b) & (l >= 0) & (l < p.width) & (t >= 0) & (t < p.height);
  const I8 index = (t * p.width + l) | ~one;  // -1 where not a single pixel inside
  std::memcpy(x0, &l, sizeof l);
  std::memcpy(x1, &r, sizeof r);
  std::memcpy(y0, &t, sizeof t);
  std::memcpy(y1, &b, sizeof b);
  std::memcpy(zc, &depth, sizeof depth);
  std::memcpy(single, &index, sizeof index);
}

// One row of depth pixels: project8 over whole groups of eight (the row
// arrays are padded to a multiple of eight).
VCLASSROOM_SIMD_CLONES void project_row(const uint16_t* d, const float* rx, const float* ry, const float* rz, int groups,
                                        const Projection& p, int32_t* x0, int32_t* x1, int32_t* y0, int32_t* y1,
                                        int32_t* zc, int32_t* single) {
  for (int g = 0; g < groups; ++g) {
    const int i = 8 * g;
    project8(d + i, rx + i, ry + i, rz + i, p, x0 + i, x1 + i, y0 + i, y1 + i, zc + i, single + i);
  }
}

}  // namespace

DepthRegistration::DepthRegistration(const CameraCalib& depth, const CameraCalib& color,
                                     const Eigen::Isometry3d& depth_to_color)
    : depth_(depth), color_(color) {
  validate_camera(depth, "depth camera");
  validate_camera(color, "colour camera");
  rotation_ = depth_to_color.linear().cast<float>();
  translation_ = depth_to_color.translation().cast<float>();
  // Each depth pixel's ray through its centre (distortion undone once here),
  // already turned into the colour camera's orientation: a point at depth z
  // is then z * ray + translation.
  // (Eight more at the end: the last row is read in whole groups of eight.)
  ray_x_.resize(size_t(depth.width) * depth.height + 8);
  ray_y_.resize(ray_x_.size());
  ray_z_.resize(ray_x_.size());
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) {
      const Eigen::Vector2d n = depth.normalized(x, y);
      const Eigen::Vector3f r = rotation_ * Eigen::Vector3f(float(n.x()), float(n.y()), 1.0f);
      const size_t i = size_t(y) * depth.width + x;
      ray_x_[i] = r.x();
      ray_y_[i] = r.y();
      ray_z_[i] = r.z();
    }
}

void DepthRegistration::register_depth(const cv::Mat& depth_mm, cv::Mat* out) {
  if (depth_mm.type() != CV_16UC1 || depth_mm.cols != depth_.width || depth_mm.rows != depth_.height)
    throw Error("depth registration: depth image is not " + std::to_string(depth_.width) + "x" +
                std::to_string(depth_.height) + " 16-bit");
  zbuffer_.create(color_.height, color_.width, CV_16UC1);
  zbuffer_.setTo(0);
  const bool distorted = color_.has_distortion();
  const int W = color_.width, H = color_.height;
  const float scale_x = float(color_.fx / depth_.fx), scale_y = float(color_.fy / depth_.fy);
  const Projection proj{translation_.x(), translation_.y(), translation_.z(), float(color_.fx), float(color_.fy),
                        float(color_.cx), float(color_.cy), 0.5f * scale_x, 0.5f * scale_y,
                        float(W) + 2 * kMaxHalf, float(H) + 2 * kMaxHalf, W, H};
  const int n = depth_.width, groups = (n + 7) / 8;
  const size_t padded = size_t(groups) * 8;
  row_depth_.assign(padded, 0);
  x0_.resize(padded), x1_.resize(padded), y0_.resize(padded), y1_.resize(padded), zc_.resize(padded);
  single_.assign(padded, -1);
  for (int y = 0; y < depth_.height; ++y) {
    std::memcpy(row_depth_.data(), depth_mm.ptr<uint16_t>(y), size_t(n) * sizeof(uint16_t));
    const uint16_t* d = row_depth_.data();
    const size_t row = size_t(y) * depth_.width;
    const float* rx = ray_x_.data() + row;
    const float* ry = ray_y_.data() + row;
    const float* rz = ray_z_.data() + row;
    if (!distorted) {
      project_row(d, rx, ry, rz, groups, proj, x0_.data(), x1_.data(), y0_.data(), y1_.data(), zc_.data(),
                  single_.data());
    } else {
      // Through the colour lens's distortion, one pixel at a time.
      for (int x = 0; x < n; ++x) {
        zc_[size_t(x)] = 0;
        if (!d[x]) continue;
        const float z = float(d[x]) * 0.001f;
        const float qx = rx[x] * z + proj.tx, qy = ry[x] * z + proj.ty, qz = rz[x] * z + proj.tz;
        if (!(qz > 0)) continue;
        const auto p = color_.project(Eigen::Vector3d(qx, qy, qz));
        if (!p || !(std::abs(p->x()) < 1e6) || !(std::abs(p->y()) < 1e6)) continue;
        const float u = float(p->x()), v = float(p->y()), zr = z / qz;
        const float half_w = std::min(kMaxHalf, proj.half_x * zr + kOverlap);
        const float half_h = std::min(kMaxHalf, proj.half_y * zr + kOverlap);
        const float mm = qz * 1000.0f + 0.5f;
        if (mm < 1 || mm >= 65536) continue;
        x0_[size_t(x)] = ceil_int(u - half_w), x1_[size_t(x)] = floor_int(u + half_w);
        y0_[size_t(x)] = ceil_int(v - half_h), y1_[size_t(x)] = floor_int(v + half_h);
        zc_[size_t(x)] = int32_t(mm);
      }
    }
    // The footprints into the z-buffer, nearest first; most cover one colour pixel.
    uint16_t* const zb = zbuffer_.ptr<uint16_t>();  // continuous: created above
    for (int x = 0; x < n; ++x) {
      const int32_t zc = zc_[size_t(x)];
      if (!zc) continue;
      const uint16_t z16 = uint16_t(zc);
      if (const int32_t i = single_[size_t(x)]; i >= 0) {
        if (uint16_t(zb[i] - 1) >= z16) zb[i] = z16;  // 0 (empty) wraps to 65535: taken
        continue;
      }
      const int xa = std::max(0, x0_[size_t(x)]), xb = std::min(W - 1, x1_[size_t(x)]);
      const int ya = std::max(0, y0_[size_t(x)]), yb = std::min(H - 1, y1_[size_t(x)]);
      for (int yy = ya; yy <= yb; ++yy) {
        uint16_t* out_row = zb + size_t(yy) * size_t(W);
        for (int xx = xa; xx <= xb; ++xx)
          if (uint16_t(out_row[xx] - 1) >= z16) out_row[xx] = z16;  // 0 (empty) wraps to 65535: taken
      }
    }
  }
  zbuffer_.copyTo(*out);
}

}  // namespace vclassroom
