#include <gst/vclassroom/capture/depth_registration.h>

#include <algorithm>
#include <cmath>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

DepthRegistration::DepthRegistration(const CameraCalib& depth, const CameraCalib& color,
                                     const Eigen::Isometry3d& depth_to_color)
    : depth_(depth), color_(color) {
  validate_camera(depth, "depth camera");
  validate_camera(color, "colour camera");
  rotation_ = depth_to_color.linear().cast<float>();
  translation_ = depth_to_color.translation().cast<float>();
  // Each depth pixel's ray through its centre (distortion undone once here).
  corner_x_.resize(size_t(depth.width) * depth.height);
  corner_y_.resize(corner_x_.size());
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) {
      const Eigen::Vector2d n = depth.normalized(x, y);
      corner_x_[size_t(y) * depth.width + x] = float(n.x());
      corner_y_[size_t(y) * depth.width + x] = float(n.y());
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
  for (int y = 0; y < depth_.height; ++y) {
    const uint16_t* d = depth_mm.ptr<uint16_t>(y);
    for (int x = 0; x < depth_.width; ++x) {
      if (!d[x]) continue;
      const float z = float(d[x]) * 0.001f;
      const size_t i = size_t(y) * depth_.width + x;
      const Eigen::Vector3f q = rotation_ * Eigen::Vector3f(corner_x_[i] * z, corner_y_[i] * z, z) + translation_;
      if (!(q.z() > 0)) continue;
      float u, v;
      if (distorted) {
        const auto p = color_.project(q.cast<double>());
        if (!p) continue;
        u = float(p->x());
        v = float(p->y());
      } else {
        u = fx * q.x() / q.z() + cx;
        v = fy * q.y() / q.z() + cy;
      }
      const float half_w = std::min(kMaxHalf, 0.5f * scale_x * z / q.z() + kOverlap);
      const float half_h = std::min(kMaxHalf, 0.5f * scale_y * z / q.z() + kOverlap);
      const int x0 = std::max(0, int(std::ceil(u - half_w))), x1 = std::min(W - 1, int(std::floor(u + half_w)));
      const int y0 = std::max(0, int(std::ceil(v - half_h))), y1 = std::min(H - 1, int(std::floor(v + half_h)));
      if (x0 > x1 || y0 > y1) continue;
      const float mm = std::round(q.z() * 1000.0f);
      if (mm < 1 || mm > 65535) continue;
      const uint16_t zc = uint16_t(mm);
      for (int yy = y0; yy <= y1; ++yy) {
        uint16_t* row = zbuffer_.ptr<uint16_t>(yy);
        for (int xx = x0; xx <= x1; ++xx)
          if (!row[xx] || zc < row[xx]) row[xx] = zc;
      }
    }
  }
  zbuffer_.copyTo(*out);
}

}  // namespace vclassroom
