// Ground-truth renderer of the synthetic classroom: a z-buffered scanline
// rasterizer of planar convex polygons with deferred, perspective-correct
// texturing.
//
// Why it is exact: for a planar face, inverse depth 1/z and texel/z are affine
// functions of the pixel position, derived here from the face's plane and the
// pinhole model directly (not interpolated from rounded vertices), and pixel
// (u, v) is covered when its centre lies inside the projected polygon (top-left
// style half-open rule, so shared edges are neither missed nor drawn twice).
#include <algorithm>
#include <cmath>

#include <gst/vclassroom/synthetic/classroom_internal.h>

namespace vclassroom {

using namespace classroom_detail;
using Eigen::Vector3d;

namespace {

// A face as seen by this camera: screen-space affine coefficients.
struct Draw {
  float ua = 0, ub = 0, uc = 0;  // texel_u / z = ua x + ub y + uc
  float va = 0, vb = 0, vc = 0;
  const uint8_t* tex = nullptr;
  size_t step = 0;
  int wmask = 0, hmask = 0;
  uint16_t tint[3] = {0, 0, 0};
  uint8_t label = 0;
};

constexpr double kNear = 0.02;  // metres
constexpr int kMaxDraws = 65535;
constexpr int64_t kMaxRenderPixels = int64_t(4096) * 4096;

}  // namespace

struct ClassroomRenderer::Scratch {
  std::vector<float> invz;  // 1/z per pixel (0 = nothing yet)
  std::vector<Face> dynamic;
  std::vector<Draw> draws;
};

ClassroomRenderer::ClassroomRenderer() : s_(new Scratch) {}
ClassroomRenderer::~ClassroomRenderer() = default;

namespace {

struct Camera {
  int W, H;
  double fx, fy, cx, cy;
  Eigen::Matrix3d R;  // rig -> camera
  Vector3d t;         // rig -> camera
  Vector3d centre;    // in the rig
};

void raster_face(const Face& f, const Classroom::Impl& scene, const Camera& c, float* invz, uint16_t* sid,
                 std::vector<Draw>* draws, std::vector<SurfaceInfo>* surfaces) {
  // Back faces and faces seen exactly edge-on show nothing.
  if (f.normal.dot(c.centre - f.v[0]) <= 1e-9) return;
  if (draws->size() >= size_t(kMaxDraws)) return;
  Vector3d in[kMaxPolyVerts];
  for (int i = 0; i < f.n; ++i) in[i] = c.R * f.v[i] + c.t;
  // Clip against the near plane.
  Vector3d poly[kMaxPolyVerts + 4];
  int n = 0;
  for (int i = 0; i < f.n; ++i) {
    const Vector3d& a = in[i];
    const Vector3d& b = in[(i + 1) % f.n];
    const bool ia = a.z() >= kNear, ib = b.z() >= kNear;
    if (ia) poly[n++] = a;
    if (ia != ib) poly[n++] = a + (b - a) * ((kNear - a.z()) / (b.z() - a.z()));
  }
  if (n < 3) return;
  double sx[kMaxPolyVerts + 4], sy[kMaxPolyVerts + 4];
  double ymin = 1e30, ymax = -1e30, xmin = 1e30, xmax = -1e30;
  for (int i = 0; i < n; ++i) {
    sx[i] = c.fx * poly[i].x() / poly[i].z() + c.cx;
    sy[i] = c.fy * poly[i].y() / poly[i].z() + c.cy;
    // Extreme intrinsics from a rig file can overflow to inf or NaN: such a face is not drawn.
    if (!std::isfinite(sx[i]) || !std::isfinite(sy[i])) return;
    ymin = std::min(ymin, sy[i]);
    ymax = std::max(ymax, sy[i]);
    xmin = std::min(xmin, sx[i]);
    xmax = std::max(xmax, sx[i]);
  }
  if (xmax < 0 || xmin > c.W - 1) return;
  // Clamped as doubles before converting: a coordinate beyond int's range
  // would make the conversion undefined.
  const int row0 = int(std::ceil(std::clamp(ymin, 0.0, double(c.H))));
  const int row1 = int(std::ceil(std::clamp(ymax, 0.0, double(c.H))));  // exclusive
  if (row0 >= row1) return;

  // Plane n.P = d in camera coordinates; on the ray P = z (xn, yn, 1):
  // 1/z = n.(xn, yn, 1) / d, affine in the pixel position.
  const Vector3d nc = c.R * f.normal;
  const double d = nc.dot(in[0]);
  if (std::abs(d) < 1e-12) return;
  const double A = nc.x() / (c.fx * d), B = nc.y() / (c.fy * d),
               C = (nc.z() - nc.x() * c.cx / c.fx - nc.y() * c.cy / c.fy) / d;
  // Texel coordinate u = tu.P_rig + tu0 = (R tu).P_cam + (tu.centre + tu0);
  // u/z is then affine too.
  auto coeffs = [&](const Vector3d& tw, double t0, float* a, float* b, float* cc) {
    const Vector3d U = c.R * tw;
    const double u0 = tw.dot(c.centre) + t0;
    *a = float(U.x() / c.fx + u0 * A);
    *b = float(U.y() / c.fy + u0 * B);
    *cc = float(U.z() - U.x() * c.cx / c.fx - U.y() * c.cy / c.fy + u0 * C);
  };
  Draw dr;
  coeffs(f.tu, f.tu0, &dr.ua, &dr.ub, &dr.uc);
  coeffs(f.tv, f.tv0, &dr.va, &dr.vb, &dr.vc);
  const Texture& tex = scene.textures[f.texture];
  dr.tex = tex.img.data;
  dr.step = tex.img.step;
  dr.wmask = tex.wmask;
  dr.hmask = tex.hmask;
  for (int i = 0; i < 3; ++i) dr.tint[i] = f.tint[i];
  dr.label = f.label;

  const uint16_t id = uint16_t(draws->size());
  const float fA = float(A), fB = float(B), fC = float(C);
  bool any = false;
  for (int y = row0; y < row1; ++y) {
    double xl = 1e30, xr = -1e30;
    for (int i = 0; i < n; ++i) {
      const int j = (i + 1) % n;
      const double ya = sy[i], yb = sy[j];
      // Half-open in y: an edge owns rows with min <= y < max.
      if ((ya <= y && y < yb) || (yb <= y && y < ya)) {
        const double x = sx[i] + (y - ya) * (sx[j] - sx[i]) / (yb - ya);
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
    }
    if (xl > xr) continue;
    const int x0 = int(std::ceil(std::clamp(xl, 0.0, double(c.W))));
    const int x1 = int(std::ceil(std::clamp(xr, 0.0, double(c.W))));
    if (x0 >= x1) continue;
    float* zr = invz + size_t(y) * c.W;
    uint16_t* sr = sid + size_t(y) * c.W;
    const float rowc = fB * float(y) + fC;
    for (int x = x0; x < x1; ++x) {
      const float iz = fA * float(x) + rowc;
      if (iz > zr[x]) {
        zr[x] = iz;
        sr[x] = id;
        any = true;
      }
    }
  }
  if (!any) return;
  draws->push_back(dr);
  SurfaceInfo si;
  si.normal_cam = nc.cast<float>();
  si.ir_albedo = f.ir_albedo;
  si.gloss = f.gloss;
  si.label = f.label;
  surfaces->push_back(si);
}

}  // namespace

void ClassroomRenderer::render(const Classroom& scene, double t, const CameraCalib& cam, RenderOutput* out) {
  if (cam.width <= 0 || cam.height <= 0 || !(cam.fx > 0) || !(cam.fy > 0) || !std::isfinite(cam.fx) ||
      !std::isfinite(cam.fy) || !std::isfinite(cam.cx) || !std::isfinite(cam.cy))
    throw Error("classroom render: camera " + std::to_string(cam.id) + " has no valid size/focal length");
  // A rig may hold cameras up to 16384x16384 (docs/rig-format.md), but one
  // such synthetic frame takes about 4 GB and tens of seconds of CPU: rgbdtestsrc
  // would spin for minutes. Refused before anything is allocated.
  if (int64_t(cam.width) * cam.height > kMaxRenderPixels)
    throw Error("classroom render: camera " + std::to_string(cam.id) + " is " + std::to_string(cam.width) + "x" +
                std::to_string(cam.height) + "; the synthetic classroom renders at most " +
                std::to_string(kMaxRenderPixels) + " pixels (4096x4096) per frame");
  const Classroom::Impl& im = scene.impl();
  Camera c;
  c.W = cam.width;
  c.H = cam.height;
  c.fx = cam.fx;
  c.fy = cam.fy;
  c.cx = cam.cx;
  c.cy = cam.cy;
  c.R = cam.cam_to_rig.linear().transpose();
  c.centre = cam.cam_to_rig.translation();
  c.t = -c.R * c.centre;

  const size_t N = size_t(c.W) * c.H;
  out->color.create(c.H, c.W, CV_8UC3);
  out->depth.create(c.H, c.W, CV_16UC1);
  out->label.create(c.H, c.W, CV_8UC1);
  out->surface.create(c.H, c.W, CV_16UC1);
  s_->invz.assign(N, 0.f);
  out->surface.setTo(0);
  s_->draws.assign(1, Draw{});
  out->surfaces.assign(1, SurfaceInfo{});
  s_->dynamic.clear();
  im.learner_faces(t, &s_->dynamic);

  float* invz = s_->invz.data();
  uint16_t* sid = out->surface.ptr<uint16_t>();  // continuous: just created
  // Hidden surface removal only: texturing happens once per pixel below.
  for (const Face& f : im.faces) raster_face(f, im, c, invz, sid, &s_->draws, &out->surfaces);
  for (const Face& f : s_->dynamic) raster_face(f, im, c, invz, sid, &s_->draws, &out->surfaces);

  const Draw* draws = s_->draws.data();
  for (int y = 0; y < c.H; ++y) {
    const float* zr = invz + size_t(y) * c.W;
    const uint16_t* sr = sid + size_t(y) * c.W;
    uint8_t* col = out->color.ptr<uint8_t>(y);
    uint16_t* dep = out->depth.ptr<uint16_t>(y);
    uint8_t* lab = out->label.ptr<uint8_t>(y);
    const float fy = float(y);
    for (int x = 0; x < c.W; ++x) {
      const uint16_t id = sr[x];
      if (!id) {
        col[3 * x] = col[3 * x + 1] = col[3 * x + 2] = 0;
        dep[x] = 0;
        lab[x] = 0;
        continue;
      }
      const Draw& d = draws[id];
      const float z = 1.f / zr[x];
      const float fx = float(x);
      const float u = (d.ua * fx + d.ub * fy + d.uc) * z;
      const float v = (d.va * fx + d.vb * fy + d.vc) * z;
      // The bias makes truncation a floor for any texel the faces use.
      const int iu = int(u + 65536.f) & d.wmask;
      const int iv = int(v + 65536.f) & d.hmask;
      const uint8_t* tx = d.tex + size_t(iv) * d.step + 3 * size_t(iu);
      for (int k = 0; k < 3; ++k) {
        const unsigned val = (unsigned(tx[k]) * d.tint[k]) >> 8;
        col[3 * x + k] = uint8_t(val > 255 ? 255 : val);
      }
      const float mm = z * 1000.f;
      dep[x] = mm < 65535.f ? uint16_t(mm + 0.5f) : 0;
      lab[x] = d.label;
    }
  }
}

RenderOutput render(const Classroom& scene, double t, const CameraCalib& cam) {
  ClassroomRenderer r;
  RenderOutput out;
  r.render(scene, t, cam, &out);
  return out;
}

}  // namespace vclassroom
