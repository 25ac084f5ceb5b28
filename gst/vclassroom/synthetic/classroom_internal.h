// Internals shared by classroom_scene.cpp, classroom_learners.cpp and
// classroom_render.cpp. Not installed.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <gst/vclassroom/synthetic/classroom.h>

namespace vclassroom {
namespace classroom_detail {

// RGB texture with power-of-two sides, so lookups wrap with a mask.
struct Texture {
  cv::Mat img;  // CV_8UC3
  int wmask = 0, hmask = 0;
};

inline constexpr int kMaxPolyVerts = 8;

// A planar convex polygon in the rig frame.
struct Face {
  int n = 0;
  std::array<Eigen::Vector3d, kMaxPolyVerts> v;
  Eigen::Vector3d normal;  // unit, pointing to the side that is drawn
  // Texel coordinates of a point p on the face: (tu.p + tu0, tv.p + tv0).
  Eigen::Vector3d tu, tv;
  double tu0 = 0, tv0 = 0;
  int texture = 0;
  // Colour multiplier per channel in 1/256 (lighting and tint baked in).
  std::array<uint16_t, 3> tint{{256, 256, 256}};
  float ir_albedo = 0.5f;
  float gloss = 0;
  uint8_t label = 0;
};

// Material of a solid: what texture and how it reflects.
struct Material {
  int texture = 0;
  Eigen::Vector3d color{1, 1, 1};  // multiplies the texture (before lighting)
  double texels_per_m = 256;
  float ir_albedo = 0.5f;
  float gloss = 0;
  bool emissive = false;  // ignores lighting (lamps, windows)
};

struct Light {
  Eigen::Vector3d pos;
  double power;
};

// Builds faces with lighting applied.
class FaceBuilder {
 public:
  FaceBuilder(const std::vector<Light>* lights, double ambient, const Eigen::Vector3d* sun_dir, double sun,
              std::vector<Face>* out)
      : lights_(lights), ambient_(ambient), sun_dir_(sun_dir), sun_(sun), out_(out) {}

  uint8_t label = 0;
  // Irradiance at a point with normal n (1 ~ a well lit desk top).
  double light(const Eigen::Vector3d& p, const Eigen::Vector3d& n) const;
  // A polygon (convex, planar) drawn on the side its normal faces; the normal is
  // oriented towards `toward` (a point in front of it).
  void poly(const std::vector<Eigen::Vector3d>& v, const Eigen::Vector3d& toward, const Material& m);
  // Same, texture mapped explicitly: texel = (tu.p + tu0, tv.p + tv0).
  void poly_mapped(const std::vector<Eigen::Vector3d>& v, const Eigen::Vector3d& toward, const Material& m,
                   const Eigen::Vector3d& tu, double tu0, const Eigen::Vector3d& tv, double tv0);
  // Box given by an affine map of the cube [-1,1]^3 (scale in the map).
  void box(const Eigen::Affine3d& T, const Material& m);
  // Truncated elliptic cone along local +Y from 0 to 1, radius r0 at y = 0 and
  // r1 at y = 1 (before T), n sides; planar sides because T is affine.
  void frustum(const Eigen::Affine3d& T, double r0, double r1, int n, const Material& m);
  // Ellipsoid: unit sphere under T, lat-long mesh. `color_of` picks a material
  // per face from its direction on the unit sphere.
  template <class F>
  void ellipsoid(const Eigen::Affine3d& T, int lon, int lat, F material_of);

 private:
  const std::vector<Light>* lights_;
  double ambient_;
  const Eigen::Vector3d* sun_dir_;
  double sun_;
  std::vector<Face>* out_;
};

template <class F>
void FaceBuilder::ellipsoid(const Eigen::Affine3d& T, int lon, int lat, F material_of) {
  const Eigen::Vector3d c = T * Eigen::Vector3d::Zero();
  auto sph = [&](int i, int j) {
    const double th = M_PI * i / lat;  // 0 at the top
    const double ph = 2 * M_PI * j / lon;
    return Eigen::Vector3d(std::sin(th) * std::sin(ph), std::cos(th), std::sin(th) * std::cos(ph));
  };
  for (int i = 0; i < lat; ++i) {
    for (int j = 0; j < lon; ++j) {
      std::vector<Eigen::Vector3d> q;
      const Eigen::Vector3d a = sph(i, j), b = sph(i, j + 1), cc = sph(i + 1, j + 1), d = sph(i + 1, j);
      if (i > 0) {
        q.push_back(a);
        q.push_back(b);
      } else {
        q.push_back(a);
      }
      q.push_back(cc);
      if (i + 1 < lat) q.push_back(d);
      Eigen::Vector3d mid = Eigen::Vector3d::Zero();
      for (auto& p : q) mid += p;
      mid.normalize();
      const Material& m = material_of(mid);
      std::vector<Eigen::Vector3d> w;
      for (auto& p : q) w.push_back(T * p);
      // The normal points away from the centre: aim it at a point beyond the face.
      Eigen::Vector3d fc = Eigen::Vector3d::Zero();
      for (auto& p : w) fc += p;
      fc /= double(w.size());
      poly(w, fc + (fc - c), m);
    }
  }
}

struct Seat {
  Eigen::Vector3d pos;   // floor point under the seat centre
  double aisle_x = 0;    // X of the aisle beside it
};

struct LearnerLook {
  Eigen::Vector3d shirt, trousers, skin, hair, shoes;
  bool long_sleeves = true;
  double height = 1.0;  // scale
  double phase = 0;     // desynchronises idle motion
  double slot_offset = 0;
  int seat = 0;
};

}  // namespace classroom_detail

struct Classroom::Impl {
  ClassroomConfig config;
  double floor_y = 0, ceiling_y = 0, front_z = 0, back_z = 0, left_x = 0, right_x = 0;
  std::vector<classroom_detail::Texture> textures;
  std::vector<classroom_detail::Face> faces;  // static scene
  std::vector<classroom_detail::Light> lights;
  Eigen::Vector3d sun_dir;
  double ambient = 0.3, sun = 0.2;
  std::vector<classroom_detail::Seat> seats;
  std::vector<classroom_detail::LearnerLook> looks;  // one per learner
  // Materials of the learners' bodies: texture ids.
  int tex_fabric = 0, tex_skin = 0, tex_hair = 0;

  // Appends the learners' faces at time t.
  void learner_faces(double t, std::vector<classroom_detail::Face>* out) const;
  LearnerState learner_state(int k, double t) const;
};

}  // namespace vclassroom
