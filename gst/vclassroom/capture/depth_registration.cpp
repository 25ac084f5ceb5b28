#include <gst/vclassroom/capture/depth_registration.h>

#include <algorithm>
#include <cmath>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

// floor and ceil for the footprints' small coordinates, without the library
// calls (this loop runs once per depth pixel).
inline int floor_int(float v) {
  const int i = int(v);
  return i - (v < float(i));
}
inline int ceil_int(float v) { return -floor_int(-v); }

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
  ray_x_.resize(size_t(depth.width) * depth.height);
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
  const float fx = float(color_.fx), fy = float(color_.fy), cx = float(color_.cx), cy = float(color_.cy);
  // A depth pixel's footprint in the colour image: one depth pixel is
  // (color f / depth f) * (depth z / colour z) colour pixels across; a hair
  // more, so neighbours at one depth always meet.
  const float scale_x = float(color_.fx / depth_.fx), scale_y = float(color_.fy / depth_.fy);
  constexpr float kOverlap = 0.01f;
  constexpr float kMaxHalf = 8.0f;  // a footprint larger than 16 px is a grazing artefact
  const int W = color_.width, H = color_.height;
  const float tx = translation_.x(), ty = translation_.y(), tz = translation_.z();
  for (int y = 0; y < depth_.height; ++y) {
    const uint16_t* d = depth_mm.ptr<uint16_t>(y);
    const size_t row = size_t(y) * depth_.width;
    const float* rx = ray_x_.data() + row;
    const float* ry = ray_y_.data() + row;
    const float* rz = ray_z_.data() + row;
    for (int x = 0; x < depth_.width; ++x) {
      if (!d[x]) continue;
      const float z = float(d[x]) * 0.001f;
      const float qx = rx[x] * z + tx, qy = ry[x] * z + ty, qz = rz[x] * z + tz;
      if (!(qz > 0)) continue;
      const float inv = 1.0f / qz;
      float u, v;
      if (distorted) {
        const auto p = color_.project(Eigen::Vector3d(qx, qy, qz));
        if (!p) continue;
        u = float(p->x());
        v = float(p->y());
      } else {
        u = fx * qx * inv + cx;
        v = fy * qy * inv + cy;
      }
      const float zr = z * inv;
      const float half_w = std::min(kMaxHalf, 0.5f * scale_x * zr + kOverlap);
      const float half_h = std::min(kMaxHalf, 0.5f * scale_y * zr + kOverlap);
      // Colour pixel centres (integers) inside [u - half_w, u + half_w].
      const float left = u - half_w, top = v - half_h;
      if (left > float(W - 1) || top > float(H - 1) || u + half_w < 0 || v + half_h < 0) continue;
      const int x0 = std::max(0, ceil_int(left)), x1 = std::min(W - 1, floor_int(u + half_w));
      const int y0 = std::max(0, ceil_int(top)), y1 = std::min(H - 1, floor_int(v + half_h));
      const float mm = qz * 1000.0f + 0.5f;
      if (mm < 1 || mm >= 65536) continue;
      const uint16_t zc = uint16_t(mm);
      for (int yy = y0; yy <= y1; ++yy) {
        uint16_t* out_row = zbuffer_.ptr<uint16_t>(yy);
        for (int xx = x0; xx <= x1; ++xx)
          if (uint16_t(out_row[xx] - 1) >= zc) out_row[xx] = zc;  // 0 (empty) wraps to 65535: taken
      }
    }
  }
  zbuffer_.copyTo(*out);
}

}  // namespace vclassroom
