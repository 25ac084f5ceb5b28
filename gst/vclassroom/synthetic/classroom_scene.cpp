// The static classroom: procedural textures, baked lighting, furniture, and
// the default rig looking at it.
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom_internal.h>

namespace vclassroom {

using namespace classroom_detail;
using Eigen::Affine3d;
using Eigen::Vector3d;

// ---------------------------------------------------------------- FaceBuilder

double FaceBuilder::light(const Vector3d& p, const Vector3d& n) const {
  double e = ambient_;
  for (const Light& L : *lights_) {
    const Vector3d d = L.pos - p;
    const double r2 = d.squaredNorm() + 0.05;
    const double r = std::sqrt(r2);
    const double cs = n.dot(d) / r, ce = d.y() / r;
    // A soft term keeps faces that turn away from every lamp from going black.
    if (ce > 0) e += L.power * ce * (std::max(0.0, cs) * 0.85 + 0.15) / r2;
  }
  e += sun_ * std::max(0.0, -n.dot(*sun_dir_));
  // Light bounced off the floor reaches faces that look down.
  e += 0.12 * std::max(0.0, -n.y());
  return e;
}

void FaceBuilder::poly(const std::vector<Vector3d>& v, const Vector3d& toward, const Material& m) {
  // Texture axes in the face's plane, anchored at a position-dependent offset
  // so equal parts do not show identical texture.
  Vector3d n = Vector3d::Zero();
  for (size_t i = 0; i < v.size(); ++i) n += v[i].cross(v[(i + 1) % v.size()]);
  n.normalize();
  Vector3d u = (v[1] - v[0]).normalized();
  if (std::abs(n.y()) < 0.9 && std::abs(u.y()) > 0.7) u = n.cross(Vector3d::UnitY()).normalized();
  const Vector3d w = n.cross(u);
  const double k = m.texels_per_m;
  const double off = std::fmod(std::abs(v[0].x() * 131.7 + v[0].y() * 71.3 + v[0].z() * 53.9), 1.0) * 997;
  poly_mapped(v, toward, m, u * k, -u.dot(v[0]) * k + off, w * k, -w.dot(v[0]) * k + off * 0.61);
}

void FaceBuilder::poly_mapped(const std::vector<Vector3d>& v, const Vector3d& toward, const Material& m,
                              const Vector3d& tu, double tu0, const Vector3d& tv, double tv0) {
  Face f;
  f.n = static_cast<int>(std::min<size_t>(v.size(), kMaxPolyVerts));
  Vector3d n = Vector3d::Zero(), c = Vector3d::Zero();
  for (int i = 0; i < f.n; ++i) {
    f.v[i] = v[i];
    n += v[i].cross(v[(i + 1) % f.n]);
    c += v[i];
  }
  c /= f.n;
  if (n.norm() < 1e-12) return;  // degenerate
  n.normalize();
  if (n.dot(toward - c) < 0) n = -n;
  f.normal = n;
  f.tu = tu;
  f.tv = tv;
  f.tu0 = tu0;
  f.tv0 = tv0;
  f.texture = m.texture;
  const double e = m.emissive ? 1.0 : light(c, n);
  for (int i = 0; i < 3; ++i) f.tint[i] = static_cast<uint16_t>(std::clamp(m.color[i] * e * 256.0, 0.0, 1023.0));
  f.ir_albedo = m.ir_albedo;
  f.gloss = m.gloss;
  f.label = label;
  out_->push_back(f);
}

void FaceBuilder::box(const Affine3d& T, const Material& m) {
  const Vector3d c = T * Vector3d::Zero();
  auto P = [&](double x, double y, double z) { return T * Vector3d(x, y, z); };
  for (int axis = 0; axis < 3; ++axis) {
    for (int s = -1; s <= 1; s += 2) {
      std::vector<Vector3d> q;
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      for (auto& cr : corners) {
        double p[3];
        p[axis] = s;
        p[a1] = cr[0];
        p[a2] = cr[1];
        q.push_back(P(p[0], p[1], p[2]));
      }
      Vector3d fc = Vector3d::Zero();
      for (auto& p : q) fc += p;
      fc /= 4;
      poly(q, fc + (fc - c), m);
    }
  }
}

void FaceBuilder::frustum(const Affine3d& T, double r0, double r1, int n, const Material& m) {
  const Vector3d axis_mid = T * Vector3d(0, 0.5, 0);
  std::vector<Vector3d> bottom, top;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * (i + 0.5) / n;
    bottom.push_back(T * Vector3d(r0 * std::cos(a), 0, r0 * std::sin(a)));
    top.push_back(T * Vector3d(r1 * std::cos(a), 1, r1 * std::sin(a)));
  }
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    std::vector<Vector3d> q{bottom[i], bottom[j], top[j], top[i]};
    const Vector3d fc = (q[0] + q[1] + q[2] + q[3]) / 4;
    poly(q, fc + (fc - axis_mid), m);
  }
  const Vector3d b0 = T * Vector3d::Zero(), t0 = T * Vector3d(0, 1, 0);
  if (r0 > 1e-6) poly(bottom, b0 + (b0 - t0), m);
  if (r1 > 1e-6) poly(top, t0 + (t0 - b0), m);
}

// ------------------------------------------------------------------ textures

namespace {

int pow2_mask(int n) { return n - 1; }

Texture make_texture(const cv::Mat& rgb_float) {
  Texture t;
  rgb_float.convertTo(t.img, CV_8UC3, 255.0);
  t.wmask = pow2_mask(t.img.cols);
  t.hmask = pow2_mask(t.img.rows);
  return t;
}

// Tileable smooth noise in [0, 1): a random gx x gy grid, wrapped and
// resized, so it repeats seamlessly every w x h pixels.
cv::Mat tile_noise(int w, int h, int gx, int gy, cv::RNG& rng) {
  cv::Mat g(gy, gx, CV_32F);
  rng.fill(g, cv::RNG::UNIFORM, 0.f, 1.f);
  cv::Mat ext;
  cv::copyMakeBorder(g, ext, 2, 2, 2, 2, cv::BORDER_WRAP);
  const double sx = double(w) / gx, sy = double(h) / gy;
  cv::Mat big;
  cv::resize(ext, big, cv::Size(int(std::lround((gx + 4) * sx)), int(std::lround((gy + 4) * sy))), 0, 0,
             cv::INTER_CUBIC);
  return big(cv::Rect(int(std::lround(2 * sx)), int(std::lround(2 * sy)), w, h)).clone();
}

// Fractal noise, roughly zero-mean, amplitude ~1.
cv::Mat fbm(int w, int h, int g0, int octaves, cv::RNG& rng) {
  cv::Mat acc = cv::Mat::zeros(h, w, CV_32F);
  double amp = 1, total = 0;
  int g = g0;
  for (int o = 0; o < octaves && g <= std::min(w, h); ++o) {
    const int gx = std::max(1, g * w / std::min(w, h)), gy = std::max(1, g * h / std::min(w, h));
    cv::Mat n = tile_noise(w, h, gx, gy, rng);
    acc += (n - 0.5f) * float(amp);
    total += amp * 0.5;
    amp *= 0.5;
    g *= 2;
  }
  return acc / float(total);
}

cv::Mat solid(int w, int h, const Vector3d& c) {
  return cv::Mat(h, w, CV_32FC3, cv::Scalar(c[0], c[1], c[2]));
}

// Multiplies each channel of rgb by (1 + amount * n).
void modulate(cv::Mat& rgb, const cv::Mat& n, double amount) {
  cv::Mat f = 1.0f + n * float(amount);
  cv::Mat f3;
  cv::merge(std::vector<cv::Mat>{f, f, f}, f3);
  rgb = rgb.mul(f3);
}

cv::Scalar rgbs(double r, double g, double b) { return cv::Scalar(r, g, b); }

// Chalk: strokes drawn into a mask, roughened by noise and blurred a little.
void chalk_writing(cv::Mat& board, cv::RNG& rng) {
  const int w = board.cols, h = board.rows;
  cv::Mat mask = cv::Mat::zeros(h, w, CV_32F);
  const char* titles[] = {"Projective geometry", "Lecture 7: Depth from stereo", "Linear algebra review",
                          "Optics: refraction", "Chapter 3 - Functions"};
  const char* lines[] = {"x' = K [R | t] X", "Z = f b / d", "a^2 + b^2 = c^2", "E = m c^2",
                         "F = m a", "y = a x + b", "det(A) = ad - bc", "n1 sin(t1) = n2 sin(t2)",
                         "lim 1/n = 0", "f(x) = x^2 - 3x + 2"};
  const int font = cv::FONT_HERSHEY_SCRIPT_SIMPLEX;
  cv::putText(mask, titles[rng.uniform(0, 5)], cv::Point(int(0.06 * w), int(0.17 * h)), font, 0.0021 * w,
              cv::Scalar(1), std::max(2, w / 400), cv::LINE_AA);
  cv::line(mask, cv::Point(int(0.06 * w), int(0.2 * h)), cv::Point(int(0.55 * w), int(0.205 * h)), cv::Scalar(0.8),
           std::max(1, w / 600), cv::LINE_AA);
  int y = int(0.33 * h);
  for (int i = 0; i < 4; ++i) {
    cv::putText(mask, lines[rng.uniform(0, 10)], cv::Point(int((0.07 + 0.02 * (i % 2)) * w), y),
                cv::FONT_HERSHEY_SIMPLEX, 0.0012 * w, cv::Scalar(1), std::max(1, w / 500), cv::LINE_AA);
    y += int(0.14 * h);
  }
  // A diagram on the right: a triangle with a circle, axes and a curve.
  const cv::Point o(int(0.66 * w), int(0.85 * h));
  const int s = int(0.25 * h);
  cv::line(mask, o, o + cv::Point(int(2.4 * s), 0), cv::Scalar(1), std::max(1, w / 550), cv::LINE_AA);
  cv::line(mask, o, o - cv::Point(0, int(2.6 * s)), cv::Scalar(1), std::max(1, w / 550), cv::LINE_AA);
  std::vector<cv::Point> curve;
  const double a = rng.uniform(0.6, 1.4);
  for (int i = 0; i <= 40; ++i) {
    const double xx = i / 40.0;
    curve.emplace_back(o.x + int(2.3 * s * xx), o.y - int(2.4 * s * (0.5 + 0.45 * std::sin(a * 6 * xx))));
  }
  cv::polylines(mask, curve, false, cv::Scalar(0.9), std::max(1, w / 600), cv::LINE_AA);
  cv::circle(mask, cv::Point(int(0.57 * w), int(0.62 * h)), int(0.12 * h), cv::Scalar(0.8), std::max(1, w / 600),
             cv::LINE_AA);
  // Rough chalk: strokes break up, and erased chalk leaves a haze.
  cv::Mat grain(h, w, CV_32F);
  rng.fill(grain, cv::RNG::UNIFORM, 0.45f, 1.0f);
  mask = mask.mul(grain);
  cv::GaussianBlur(mask, mask, cv::Size(3, 3), 0.6);
  cv::Mat haze = (fbm(w, h, 3, 4, rng) + 0.5f) * 0.12f;
  cv::Mat m = cv::min(mask + cv::max(haze, 0.f), 1.f);
  const cv::Vec3f chalk(0.93f, 0.94f, 0.9f);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) {
      const float k = m.at<float>(r, c);
      cv::Vec3f& p = board.at<cv::Vec3f>(r, c);
      p = p * (1 - k) + chalk * k;
    }
}

// A poster: a coloured header, text lines and a picture block.
cv::Mat poster(int w, int h, cv::RNG& rng) {
  const cv::Scalar papers[] = {rgbs(0.95, 0.93, 0.88), rgbs(0.9, 0.95, 0.97), rgbs(0.98, 0.95, 0.8)};
  const cv::Scalar inks[] = {rgbs(0.75, 0.15, 0.12), rgbs(0.1, 0.3, 0.6), rgbs(0.15, 0.5, 0.25),
                             rgbs(0.85, 0.55, 0.1)};
  cv::Mat p(h, w, CV_32FC3, papers[rng.uniform(0, 3)]);
  const cv::Scalar ink = inks[rng.uniform(0, 4)];
  cv::rectangle(p, cv::Rect(0, 0, w, h / 6), ink, cv::FILLED);
  const char* words[] = {"PERIODIC TABLE", "WORLD MAP", "SAFETY FIRST", "SOLAR SYSTEM", "READ MORE"};
  cv::putText(p, words[rng.uniform(0, 5)], cv::Point(w / 20, h / 9), cv::FONT_HERSHEY_DUPLEX, w / 400.0,
              cv::Scalar(1, 1, 1), std::max(1, w / 128), cv::LINE_AA);
  // Picture: a grid of coloured cells or circles.
  const cv::Rect pic(w / 10, h / 4, w * 8 / 10, h * 2 / 5);
  if (rng.uniform(0, 2) == 0) {
    const int n = 6;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        cv::rectangle(p,
                      cv::Rect(pic.x + i * pic.width / n + 1, pic.y + j * pic.height / n + 1, pic.width / n - 2,
                               pic.height / n - 2),
                      cv::Scalar(rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0)), cv::FILLED);
  } else {
    cv::rectangle(p, pic, cv::Scalar(0.1, 0.1, 0.2), cv::FILLED);
    for (int i = 0; i < 5; ++i)
      cv::circle(p, cv::Point(pic.x + rng.uniform(0, pic.width), pic.y + rng.uniform(0, pic.height)),
                 rng.uniform(4, pic.height / 4), cv::Scalar(rng.uniform(0.5, 1.0), rng.uniform(0.4, 1.0), 0.3),
                 cv::FILLED, cv::LINE_AA);
  }
  for (int y = pic.y + pic.height + h / 12; y < h - h / 20; y += h / 18)
    cv::line(p, cv::Point(w / 10, y), cv::Point(w / 10 + rng.uniform(w / 3, w * 8 / 10), y), cv::Scalar(0.3, 0.3, 0.3),
             std::max(1, h / 160));
  return p;
}

// Index of each texture in Impl::textures.
enum Tex {
  kTexPlain,
  kTexWood,
  kTexFabric,
  kTexSkin,
  kTexHair,
  kTexMetal,
  kTexFloor,
  kTexCeiling,
  kTexWallFront,
  kTexWallBack,
  kTexWallLeft,
  kTexWallRight,
  kTexBoard,
  kTexWindow,
  kTexCork,
  kTexDoor,
  kTexClock,
  kTexPoster0,  // several posters follow
};
constexpr int kPosters = 5;

}  // namespace

// --------------------------------------------------------------- the classroom

namespace {

// Bakes albedo x irradiance over a rectangle of the room: texel (i, j) is the
// point origin + (i + 0.5)/w * ex + (j + 0.5)/h * ey, with normal n.
cv::Mat bake(const cv::Mat& albedo, const Vector3d& origin, const Vector3d& ex, const Vector3d& ey,
             const Vector3d& n, const FaceBuilder& fb, const cv::Mat* shadow = nullptr) {
  const int w = albedo.cols, h = albedo.rows;
  // Irradiance is smooth: evaluate it on a coarse grid and interpolate.
  const int lw = std::max(2, w / 8), lh = std::max(2, h / 8);
  cv::Mat lm(lh, lw, CV_32F);
  for (int j = 0; j < lh; ++j)
    for (int i = 0; i < lw; ++i) {
      const Vector3d p = origin + ex * ((i + 0.5) / lw) + ey * ((j + 0.5) / lh);
      lm.at<float>(j, i) = float(fb.light(p, n));
    }
  cv::Mat full;
  cv::resize(lm, full, albedo.size(), 0, 0, cv::INTER_CUBIC);
  if (shadow) full = full.mul(*shadow);
  cv::Mat f3;
  cv::merge(std::vector<cv::Mat>{full, full, full}, f3);
  cv::Mat out = albedo.mul(f3);
  return cv::min(out, 1.0);
}

}  // namespace

namespace classroom_detail {
std::shared_ptr<Classroom::Impl> build_classroom(const ClassroomConfig& cfg);
void init_learners(Classroom::Impl* im);
}  // namespace classroom_detail

std::shared_ptr<Classroom::Impl> classroom_detail::build_classroom(const ClassroomConfig& cfg) {
  auto im = std::make_shared<Classroom::Impl>();
  im->config = cfg;
  const double H = cfg.camera_height;
  im->floor_y = -H;
  im->ceiling_y = -H + kClassroomHeight;
  im->front_z = 0.25;
  im->back_z = im->front_z - kClassroomDepth;
  im->left_x = -kClassroomWidth / 2;
  im->right_x = kClassroomWidth / 2;
  const double fy = im->floor_y, cy = im->ceiling_y, fz = im->front_z, bz = im->back_z, lx = im->left_x,
               rx = im->right_x;
  // Floor-relative point.
  auto F = [&](double x, double h, double z) { return Vector3d(x, fy + h, z); };
  const Vector3d room_centre(0, fy + 1.2, (fz + bz) / 2);

  cv::RNG rng(cfg.seed * 0x9E3779B97F4A7C15ull + 12345);

  // Lamps: two rows of three ceiling panels; the sun comes in through the
  // windows on the left wall.
  for (double z : {fz - 1.4, fz - 3.6})
    for (double x : {-1.8, 0.0, 1.8}) im->lights.push_back({Vector3d(x, cy - 0.02, z), 1.1});
  im->sun_dir = Vector3d(1.0, -0.55, -0.25).normalized();
  im->ambient = 0.42;
  im->sun = 0.25;
  FaceBuilder fb(&im->lights, im->ambient, &im->sun_dir, im->sun, &im->faces);

  auto& T = im->textures;
  T.resize(kTexPoster0 + kPosters);
  {  // plain: faint mottling for painted and plastic parts
    cv::Mat n = fbm(128, 128, 4, 4, rng);
    cv::Mat p = solid(128, 128, {0.9, 0.9, 0.9});
    modulate(p, n, 0.12);
    T[kTexPlain] = make_texture(p);
  }
  {  // wood grain: rings around a distorted axis
    const int w = 512, h = 256;
    cv::Mat warp = fbm(w, h, 2, 4, rng), fine = fbm(w, h, 16, 3, rng);
    cv::Mat p(h, w, CV_32FC3);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double ring = std::sin((r / double(h) * 2 * M_PI) * 9 + warp.at<float>(r, c) * 9.0);
        const double g = 0.5 + 0.5 * ring;
        const double k = 0.82 + 0.1 * g * g * g + 0.06 * fine.at<float>(r, c);
        p.at<cv::Vec3f>(r, c) = cv::Vec3f(float(0.86 * k), float(0.64 * k), float(0.42 * k));
      }
    T[kTexWood] = make_texture(p);
  }
  {  // fabric: fine weave and soft folds, grey so the tint colours it
    const int w = 128, h = 128;
    cv::Mat folds = fbm(w, h, 2, 3, rng);
    cv::Mat p(h, w, CV_32FC3);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double weave = ((r / 2 + c / 2) % 2) ? 0.04 : -0.04;
        const float k = float(0.85 + weave + 0.18 * folds.at<float>(r, c));
        p.at<cv::Vec3f>(r, c) = cv::Vec3f(k, k, k);
      }
    T[kTexFabric] = make_texture(p);
  }
  {
    cv::Mat p = solid(64, 64, {0.92, 0.92, 0.92});
    modulate(p, fbm(64, 64, 4, 3, rng), 0.06);
    T[kTexSkin] = make_texture(p);
  }
  {  // hair: strands along v
    const int w = 128, h = 128;
    cv::Mat n = tile_noise(w, h, 64, 4, rng);
    cv::Mat p(h, w, CV_32FC3);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const float k = 0.7f + 0.5f * n.at<float>(r, c);
        p.at<cv::Vec3f>(r, c) = cv::Vec3f(k, k, k);
      }
    T[kTexHair] = make_texture(p);
  }
  {  // brushed metal
    const int w = 128, h = 128;
    cv::Mat n = tile_noise(w, h, 4, 64, rng);
    cv::Mat p = solid(w, h, {0.8, 0.8, 0.82});
    modulate(p, n - 0.5f, 0.25);
    T[kTexMetal] = make_texture(p);
  }

  // Lamps and desks first: the floor bakes the desks' soft shadows.
  struct DeskPos {
    double x, zf;
  };
  std::vector<DeskPos> desks;
  const double desk_w = 1.2, desk_d = 0.45, desk_h = 0.75;
  const double row_front[4] = {fz - 1.25, fz - 2.2, fz - 3.15, fz - 4.1};
  for (double zf : row_front)
    for (double x : {-1.9, 0.0, 1.9}) desks.push_back({x, zf});

  {  // floor: 60 cm terrazzo tiles with grout
    const int w = 1024, h = 1024;
    cv::Mat a(h, w, CV_32FC3);
    cv::Mat speck(h, w, CV_32F);
    rng.fill(speck, cv::RNG::UNIFORM, 0.f, 1.f);
    cv::Mat cloud = fbm(w, h, 6, 5, rng);
    const double tile = 0.6;
    std::vector<double> tile_tone(200);
    for (auto& t : tile_tone) t = rng.uniform(-0.05, 0.05);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double x = lx + (c + 0.5) / w * kClassroomWidth, z = bz + (r + 0.5) / h * kClassroomDepth;
        const double tx = (x - lx) / tile, tz = (z - bz) / tile;
        const double gx = std::abs(tx - std::round(tx)) * tile, gz = std::abs(tz - std::round(tz)) * tile;
        const int id = (int(tx) * 13 + int(tz) * 7) % 200;
        double k = 0.62 + tile_tone[id] + 0.06 * cloud.at<float>(r, c);
        const float s = speck.at<float>(r, c);
        if (s > 0.93) k += 0.12;
        else if (s < 0.05) k -= 0.15;
        cv::Vec3f col(float(k * 1.0), float(k * 0.96), float(k * 0.9));
        if (std::min(gx, gz) < 0.004) col = cv::Vec3f(0.33f, 0.32f, 0.3f);
        a.at<cv::Vec3f>(r, c) = col;
      }
    // Soft shadows under the desks and chairs.
    cv::Mat shadow(h, w, CV_32F, cv::Scalar(1));
    auto dark = [&](double x0, double x1, double z0, double z1, double k) {
      const cv::Point p0(int((x0 - lx) / kClassroomWidth * w), int((z0 - bz) / kClassroomDepth * h));
      const cv::Point p1(int((x1 - lx) / kClassroomWidth * w), int((z1 - bz) / kClassroomDepth * h));
      cv::rectangle(shadow, p0, p1, cv::Scalar(k), cv::FILLED);
    };
    for (const auto& d : desks) {
      dark(d.x - desk_w / 2, d.x + desk_w / 2, d.zf - desk_d, d.zf, 0.55);
      for (double s : {-0.3, 0.3}) dark(d.x + s - 0.21, d.x + s + 0.21, d.zf - 0.85, d.zf - 0.45, 0.7);
    }
    cv::GaussianBlur(shadow, shadow, cv::Size(0, 0), 14);
    // Corners get less light.
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double x = lx + (c + 0.5) / w * kClassroomWidth, z = bz + (r + 0.5) / h * kClassroomDepth;
        const double dw = std::min({x - lx, rx - x, z - bz, fz - z});
        shadow.at<float>(r, c) *= float(1.0 - 0.35 * std::exp(-dw / 0.25));
      }
    T[kTexFloor] = make_texture(bake(a, F(lx, 0, bz), Vector3d(kClassroomWidth, 0, 0), Vector3d(0, 0, kClassroomDepth),
                                     Vector3d::UnitY(), fb, &shadow));
    const double kx = w / kClassroomWidth, kz = h / kClassroomDepth;
    fb.poly_mapped({F(lx, 0, bz), F(rx, 0, bz), F(rx, 0, fz), F(lx, 0, fz)}, room_centre,
                   Material{kTexFloor, {1, 1, 1}, 0, 0.55f, 0.05f, true}, Vector3d(kx, 0, 0), -lx * kx,
                   Vector3d(0, 0, kz), -bz * kz);
  }
  {  // ceiling: acoustic tiles in a T-bar grid
    const int w = 512, h = 512;
    cv::Mat a(h, w, CV_32FC3);
    cv::Mat speck(h, w, CV_32F);
    rng.fill(speck, cv::RNG::UNIFORM, 0.f, 1.f);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double x = lx + (c + 0.5) / w * kClassroomWidth, z = bz + (r + 0.5) / h * kClassroomDepth;
        const double tx = (x - lx) / 0.6, tz = (z - bz) / 0.6;
        const double g = std::min(std::abs(tx - std::round(tx)), std::abs(tz - std::round(tz))) * 0.6;
        float k = 0.92f - (speck.at<float>(r, c) > 0.8f ? 0.08f : 0.f);
        if (g < 0.012) k = 0.75f;
        a.at<cv::Vec3f>(r, c) = cv::Vec3f(k, k, k * 0.98f);
      }
    const Vector3d n(0, -1, 0);
    // The ceiling gets mostly bounced light.
    FaceBuilder up(&im->lights, im->ambient + 0.35, &im->sun_dir, 0, &im->faces);
    T[kTexCeiling] = make_texture(bake(a, F(lx, kClassroomHeight, bz), Vector3d(kClassroomWidth, 0, 0),
                                       Vector3d(0, 0, kClassroomDepth), n, up));
    const double kx = w / kClassroomWidth, kz = h / kClassroomDepth;
    fb.poly_mapped({F(lx, kClassroomHeight, bz), F(rx, kClassroomHeight, bz), F(rx, kClassroomHeight, fz),
                    F(lx, kClassroomHeight, fz)},
                   room_centre, Material{kTexCeiling, {1, 1, 1}, 0, 0.7f, 0, true}, Vector3d(kx, 0, 0), -lx * kx,
                   Vector3d(0, 0, kz), -bz * kz);
    // Lamp panels, emissive, just below the ceiling.
    for (const Light& L : im->lights) {
      const double y = cy - 0.015;
      const Vector3d c = L.pos;
      fb.box(Affine3d(Eigen::Translation3d(c.x(), y, c.z()) * Eigen::Scaling(0.3, 0.012, 0.6)),
             Material{kTexPlain, {1.1, 1.1, 1.08}, 256, 0.8f, 0, true});
    }
  }
  // Walls: painted plaster above a darker dado band.
  auto wall_albedo = [&](int w, int h, double len) {
    cv::Mat a(h, w, CV_32FC3);
    cv::Mat n = fbm(w, h, 8, 5, rng);
    cv::Mat fine(h, w, CV_32F);
    rng.fill(fine, cv::RNG::NORMAL, 0.f, 0.012f);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double hgt = (1.0 - (r + 0.5) / h) * kClassroomHeight;  // row 0 is the top
        (void)len;
        cv::Vec3f col = hgt < 1.0 ? cv::Vec3f(0.55f, 0.64f, 0.62f) : cv::Vec3f(0.88f, 0.85f, 0.77f);
        if (std::abs(hgt - 1.0) < 0.02) col = cv::Vec3f(0.42f, 0.48f, 0.47f);
        if (hgt < 0.1) col = cv::Vec3f(0.3f, 0.3f, 0.3f);  // skirting
        col *= float(1.0 + 0.05 * n.at<float>(r, c) + fine.at<float>(r, c));
        a.at<cv::Vec3f>(r, c) = col;
      }
    return a;
  };
  // One wall: corners a (bottom-left seen from inside) to b (bottom-right).
  auto wall = [&](int tex, const Vector3d& a, const Vector3d& b) {
    const double len = (b - a).norm();
    const int w = 1024, h = 512;
    const Vector3d ex = b - a, ey(0, -kClassroomHeight, 0);
    const Vector3d top_left = a + Vector3d(0, kClassroomHeight, 0);
    const Vector3d n = Vector3d(0, 1, 0).cross(ex).normalized();
    T[tex] = make_texture(bake(wall_albedo(w, h, len), top_left, ex, ey, n, fb));
    const Vector3d tu = ex / ex.squaredNorm() * w, tv = ey / ey.squaredNorm() * h;
    fb.poly_mapped({a, b, b + Vector3d(0, kClassroomHeight, 0), top_left}, room_centre,
                   Material{tex, {1, 1, 1}, 0, 0.6f, 0, true}, tu, -tu.dot(top_left), tv, -tv.dot(top_left));
  };
  // Seen from inside, facing each wall, "a" is on the left.
  wall(kTexWallFront, F(lx, 0, fz), F(rx, 0, fz));
  wall(kTexWallBack, F(rx, 0, bz), F(lx, 0, bz));
  wall(kTexWallLeft, F(lx, 0, bz), F(lx, 0, fz));
  wall(kTexWallRight, F(rx, 0, fz), F(rx, 0, bz));

  // A flat rectangle on a wall, `gap` in front of it, mapped to a whole texture.
  auto panel = [&](const Vector3d& centre, const Vector3d& right, const Vector3d& up, double w, double h, int tex,
                   const Material& m0) {
    Material m = m0;
    m.texture = tex;
    const Vector3d a = centre - right * (w / 2) - up * (h / 2), b = centre + right * (w / 2) - up * (h / 2);
    const Vector3d c = centre + right * (w / 2) + up * (h / 2), d = centre - right * (w / 2) + up * (h / 2);
    const Texture& t = T[tex];
    const Vector3d tu = right / w * t.img.cols, tv = -up / h * t.img.rows;
    const Vector3d toward = centre + right.cross(up);
    fb.poly_mapped({a, b, c, d}, toward, m, tu, -tu.dot(d), tv, -tv.dot(d));
  };

  {  // the blackboard with chalk writing, in an aluminium frame with a tray
    const int w = 1024, hh = 342;
    cv::Mat board(hh, w, CV_32FC3, cv::Scalar(0.16, 0.27, 0.21));
    modulate(board, fbm(w, hh, 6, 4, rng), 0.15);
    chalk_writing(board, rng);
    cv::Mat b512;
    cv::resize(board, b512, cv::Size(1024, 512), 0, 0, cv::INTER_AREA);
    T[kTexBoard] = make_texture(b512);
    const double bw = 3.6, bh = 1.2, y0 = 0.9;
    const Vector3d c = F(0, y0 + bh / 2, fz - 0.012);
    // Board lit by the lamps; emissive=false gives one shade for the face.
    panel(c, Vector3d(-1, 0, 0), Vector3d::UnitY(), bw, bh, kTexBoard,
          Material{0, {1, 1, 1}, 0, 0.06f, 0.8f, false});
    const Material alu{kTexMetal, {0.85, 0.85, 0.87}, 400, 0.6f, 0.6f, false};
    const double t = 0.03;
    fb.box(Affine3d(Eigen::Translation3d(0, fy + y0 + bh + t / 2, fz - 0.02) * Eigen::Scaling(bw / 2 + t, t / 2, 0.02)), alu);
    fb.box(Affine3d(Eigen::Translation3d(0, fy + y0 - t / 2, fz - 0.04) * Eigen::Scaling(bw / 2 + t, t / 2, 0.04)), alu);
    for (double s : {-1.0, 1.0})
      fb.box(Affine3d(Eigen::Translation3d(s * (bw / 2 + t / 2), fy + y0 + bh / 2, fz - 0.02) *
                      Eigen::Scaling(t / 2, bh / 2, 0.02)),
             alu);
  }
  {  // windows on the left wall: sky and trees behind white frames
    const int w = 256, h = 256;
    cv::Mat p(h, w, CV_32FC3);
    cv::Mat trees = fbm(w, h, 6, 4, rng);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double v = r / double(h);
        cv::Vec3f sky(float(0.62 + 0.3 * v), float(0.78 + 0.17 * v), 1.0f);
        const double treeline = 0.55 + 0.18 * trees.at<float>(0, c) + 0.1 * std::sin(c * 0.05);
        if (v > treeline) {
          const float k = float(0.6 + 0.5 * trees.at<float>(r, c));
          sky = cv::Vec3f(0.25f * k, 0.45f * k, 0.2f * k);
        }
        p.at<cv::Vec3f>(r, c) = sky;
      }
    const cv::Scalar frame(0.95, 0.95, 0.93);
    cv::rectangle(p, cv::Rect(0, 0, w, h), frame, 10);
    cv::line(p, cv::Point(w / 2, 0), cv::Point(w / 2, h), frame, 8);
    cv::line(p, cv::Point(0, h * 2 / 5), cv::Point(w, h * 2 / 5), frame, 6);
    T[kTexWindow] = make_texture(p);
    // Glass returns almost no infrared to a ToF camera.
    const Material glass{0, {1.05, 1.05, 1.05}, 0, 0.03f, 1.0f, true};
    for (double z : {fz - 1.2, fz - 2.5, fz - 3.8})
      panel(F(lx + 0.01, 1.65, z), Vector3d(0, 0, -1), Vector3d::UnitY(), 1.1, 1.3, kTexWindow, glass);
    const Material sill{kTexPlain, {0.95, 0.95, 0.93}, 256, 0.7f, 0, false};
    for (double z : {fz - 1.2, fz - 2.5, fz - 3.8})
      fb.box(Affine3d(Eigen::Translation3d(lx + 0.06, fy + 0.98, z) * Eigen::Scaling(0.06, 0.02, 0.62)), sill);
  }
  {  // posters, a cork board, a clock and a door
    for (int i = 0; i < kPosters; ++i) T[kTexPoster0 + i] = make_texture(poster(256, 256, rng));
    const Material paper{0, {1, 1, 1}, 0, 0.75f, 0.1f, false};
    // Right wall (X = rx), seen from inside: "right" points to +Z.
    panel(F(rx - 0.006, 1.55, fz - 2.2), Vector3d(0, 0, 1), Vector3d::UnitY(), 0.6, 0.8, kTexPoster0, paper);
    panel(F(rx - 0.006, 1.55, fz - 3.2), Vector3d(0, 0, 1), Vector3d::UnitY(), 0.6, 0.8, kTexPoster0 + 1, paper);
    // Door near the front of the right wall.
    {
      cv::Mat d(512, 256, CV_32FC3);
      cv::Mat woodimg;
      T[kTexWood].img.convertTo(woodimg, CV_32FC3, 1 / 255.0);
      cv::resize(woodimg(cv::Rect(0, 0, 256, 128)), d, d.size());
      d = d.mul(cv::Scalar(0.75, 0.7, 0.7));
      cv::rectangle(d, cv::Rect(0, 0, 256, 512), cv::Scalar(0.35, 0.3, 0.25), 10);
      cv::rectangle(d, cv::Rect(40, 40, 176, 150), cv::Scalar(0.6, 0.72, 0.8), cv::FILLED);
      cv::rectangle(d, cv::Rect(40, 40, 176, 150), cv::Scalar(0.3, 0.25, 0.2), 5);
      cv::circle(d, cv::Point(215, 270), 9, cv::Scalar(0.8, 0.78, 0.7), cv::FILLED, cv::LINE_AA);
      T[kTexDoor] = make_texture(d);
      panel(F(rx - 0.008, 1.03, fz - 0.9), Vector3d(0, 0, 1), Vector3d::UnitY(), 0.95, 2.06, kTexDoor,
            Material{0, {1, 1, 1}, 0, 0.5f, 0.2f, false});
    }
    {  // cork board with pinned sheets on the back wall (right = +X seen from inside)
      const int w = 512, h = 256;
      cv::Mat c = solid(w, h, {0.72, 0.55, 0.36});
      cv::Mat sp(h, w, CV_32F);
      rng.fill(sp, cv::RNG::UNIFORM, 0.f, 1.f);
      modulate(c, sp - 0.5f, 0.35);
      for (int i = 0; i < 9; ++i) {
        const cv::Rect r(rng.uniform(10, w - 70), rng.uniform(10, h - 90), rng.uniform(40, 60), rng.uniform(55, 80));
        const cv::Scalar papercol(rng.uniform(0.85, 1.0), rng.uniform(0.85, 1.0), rng.uniform(0.6, 1.0));
        cv::rectangle(c, r, papercol, cv::FILLED);
        for (int y = r.y + 10; y < r.y + r.height - 5; y += 7)
          cv::line(c, cv::Point(r.x + 5, y), cv::Point(r.x + r.width - rng.uniform(5, 20), y),
                   cv::Scalar(0.35, 0.35, 0.4), 1);
        cv::circle(c, cv::Point(r.x + r.width / 2, r.y + 4), 3, cv::Scalar(0.8, 0.1, 0.1), cv::FILLED);
      }
      cv::rectangle(c, cv::Rect(0, 0, w, h), cv::Scalar(0.45, 0.32, 0.2), 8);
      T[kTexCork] = make_texture(c);
      panel(F(-0.6, 1.45, bz + 0.01), Vector3d(1, 0, 0), Vector3d::UnitY(), 2.4, 1.1, kTexCork,
            Material{0, {1, 1, 1}, 0, 0.45f, 0, false});
      panel(F(1.7, 1.5, bz + 0.006), Vector3d(1, 0, 0), Vector3d::UnitY(), 0.6, 0.8, kTexPoster0 + 2, paper);
      panel(F(-2.35, 1.5, bz + 0.006), Vector3d(1, 0, 0), Vector3d::UnitY(), 0.6, 0.8, kTexPoster0 + 3, paper);
      panel(F(2.45, 1.5, fz - 0.006), Vector3d(-1, 0, 0), Vector3d::UnitY(), 0.5, 0.6, kTexPoster0 + 4, paper);
    }
    {  // clock above the cork board
      const int s = 128;
      cv::Mat c(s, s, CV_32FC3, cv::Scalar(0.93, 0.92, 0.9));
      cv::circle(c, cv::Point(s / 2, s / 2), s / 2 - 2, cv::Scalar(0.15, 0.15, 0.15), 6, cv::LINE_AA);
      for (int i = 0; i < 12; ++i) {
        const double a = i * M_PI / 6;
        cv::line(c, cv::Point(int(s / 2 + 0.38 * s * std::sin(a)), int(s / 2 - 0.38 * s * std::cos(a))),
                 cv::Point(int(s / 2 + 0.44 * s * std::sin(a)), int(s / 2 - 0.44 * s * std::cos(a))),
                 cv::Scalar(0.1, 0.1, 0.1), 3);
      }
      cv::line(c, cv::Point(s / 2, s / 2), cv::Point(s / 2 + 20, s / 2 - 25), cv::Scalar(0.1, 0.1, 0.1), 4);
      cv::line(c, cv::Point(s / 2, s / 2), cv::Point(s / 2 - 8, s / 2 + 40), cv::Scalar(0.1, 0.1, 0.1), 2);
      T[kTexClock] = make_texture(c);
      panel(F(-0.6, 2.18, bz + 0.01), Vector3d(1, 0, 0), Vector3d::UnitY(), 0.32, 0.32, kTexClock,
            Material{0, {1, 1, 1}, 0, 0.6f, 0.3f, false});
    }
  }

  // Desks and chairs.
  const Material wood{kTexWood, {1, 1, 1}, 400, 0.6f, 0.15f, false};
  const Material frame{kTexMetal, {0.28, 0.28, 0.3}, 300, 0.25f, 0.4f, false};
  const Material panel_m{kTexPlain, {0.55, 0.6, 0.66}, 256, 0.5f, 0.05f, false};
  const Vector3d chair_cols[] = {{0.2, 0.33, 0.62}, {0.22, 0.5, 0.55}, {0.75, 0.3, 0.2}};
  const Material chair_m{kTexPlain, chair_cols[rng.uniform(0, 3)], 256, 0.45f, 0.2f, false};
  auto box = [&](double x, double y, double z, double hx, double hy, double hz, const Material& m) {
    fb.box(Affine3d(Eigen::Translation3d(x, fy + y, z) * Eigen::Scaling(hx, hy, hz)), m);
  };
  for (const auto& d : desks) {
    const double zc = d.zf - desk_d / 2;
    box(d.x, desk_h - 0.015, zc, desk_w / 2, 0.015, desk_d / 2, wood);
    for (double sx : {-1.0, 1.0})
      for (double sz : {-1.0, 1.0})
        box(d.x + sx * (desk_w / 2 - 0.04), (desk_h - 0.03) / 2, zc + sz * (desk_d / 2 - 0.04), 0.018,
            (desk_h - 0.03) / 2, 0.018, frame);
    // Modesty panel on the board side and a book shelf under the top.
    box(d.x, desk_h - 0.21, d.zf - 0.03, desk_w / 2 - 0.06, 0.17, 0.008, panel_m);
    box(d.x, desk_h - 0.16, zc + 0.02, desk_w / 2 - 0.06, 0.006, desk_d / 2 - 0.08, frame);
    for (double s : {-0.3, 0.3}) {
      const double x = d.x + s, zs = d.zf - 0.65;
      im->seats.push_back({F(x, 0, zs), 0});
      box(x, 0.44, zs, 0.21, 0.015, 0.2, chair_m);
      box(x, 0.68, zs - 0.19, 0.2, 0.14, 0.012, chair_m);
      for (double sx : {-1.0, 1.0})
        for (double sz : {-1.0, 1.0}) box(x + sx * 0.18, 0.215, zs + sz * 0.17, 0.012, 0.215, 0.012, frame);
      for (double sx : {-1.0, 1.0}) box(x + sx * 0.18, 0.6, zs - 0.19, 0.012, 0.16, 0.012, frame);
      // The aisle beside the seat: outer seats step out to the wall side.
      const double side = (s > 0) ? 1.0 : -1.0;
      im->seats.back().aisle_x = d.x + side * (desk_w / 2 + (std::abs(d.x) > 1 && side * d.x > 0 ? 0.25 : 0.35));
    }
  }
  {  // the lecturer's desk at the front left
    box(-2.1, 0.76, fz - 0.75, 0.7, 0.02, 0.35, wood);
    box(-2.1, 0.38, fz - 0.75 - 0.33, 0.68, 0.36, 0.012, panel_m);
    for (double sx : {-1.0, 1.0}) box(-2.1 + sx * 0.68, 0.37, fz - 0.75, 0.012, 0.37, 0.33, panel_m);
    // A closed laptop and a stack of books.
    box(-2.3, 0.79, fz - 0.8, 0.17, 0.012, 0.12, Material{kTexMetal, {0.35, 0.35, 0.38}, 300, 0.3f, 0.5f, false});
    box(-1.75, 0.81, fz - 0.7, 0.12, 0.03, 0.09, Material{kTexPlain, {0.7, 0.2, 0.15}, 256, 0.5f, 0.1f, false});
  }
  // Books and notebooks on some desks.
  {
    const Vector3d book_cols[] = {{0.9, 0.9, 0.85}, {0.2, 0.4, 0.7}, {0.8, 0.3, 0.2}, {0.3, 0.6, 0.3}};
    for (const auto& d : desks)
      for (double s : {-0.3, 0.3}) {
        if (rng.uniform(0.0, 1.0) < 0.35) continue;
        const double zc = d.zf - desk_d / 2 + rng.uniform(-0.05, 0.05);
        const Material bm{kTexPlain, book_cols[rng.uniform(0, 4)], 256, 0.7f, 0.05f, false};
        fb.box(Affine3d(Eigen::Translation3d(d.x + s + rng.uniform(-0.1, 0.1), fy + desk_h + 0.008, zc) *
                        Eigen::AngleAxisd(rng.uniform(-0.4, 0.4), Vector3d::UnitY()) *
                        Eigen::Scaling(0.15, 0.008, 0.105)),
               bm);
      }
  }
  return im;
}

Classroom::Classroom(const ClassroomConfig& config) {
  if (config.learners < 0 || config.learners > kClassroomMaxLearners)
    throw Error("classroom: learners must be 0.." + std::to_string(kClassroomMaxLearners) + ", got " +
                std::to_string(config.learners));
  if (!(config.camera_height > 0.3 && config.camera_height < kClassroomHeight - 0.05))
    throw Error("classroom: camera_height must be inside the room (0.3 .. 2.35 m)");
  auto im = classroom_detail::build_classroom(config);
  classroom_detail::init_learners(im.get());
  impl_ = im;
}

const ClassroomConfig& Classroom::config() const { return impl_->config; }
int Classroom::learner_count() const { return impl_->config.learners; }
double Classroom::floor_y() const { return impl_->floor_y; }
double Classroom::ceiling_y() const { return impl_->ceiling_y; }
double Classroom::front_z() const { return impl_->front_z; }
double Classroom::back_z() const { return impl_->back_z; }
double Classroom::left_x() const { return impl_->left_x; }
double Classroom::right_x() const { return impl_->right_x; }
LearnerState Classroom::learner(int k, double t) const { return impl_->learner_state(k, t); }

// ----------------------------------------------------------------- cameras

CameraCalib look_at_camera(const Vector3d& position, const Vector3d& target, int width, int height,
                           double hfov_deg) {
  CameraCalib c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = (width / 2.0) / std::tan(hfov_deg * M_PI / 360.0);
  c.cx = (width - 1) / 2.0;
  c.cy = (height - 1) / 2.0;
  const Vector3d z = (target - position).normalized();
  // OpenCV camera: y points down, so x = y x z = z x up.
  Vector3d x = z.cross(Vector3d::UnitY());
  x = x.norm() < 1e-9 ? Vector3d::UnitX() : Vector3d(x.normalized());
  const Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  c.cam_to_rig = Eigen::Isometry3d::Identity();
  c.cam_to_rig.linear() = R;
  c.cam_to_rig.translation() = position;
  return c;
}

Rig default_classroom_rig() {
  Rig rig;
  rig.name = "vclassroom-synthetic";
  const double tilt = 20.0 * M_PI / 180.0;
  // Looking along -Z of the rig (towards the class), tilted down.
  const Vector3d fwd(0, -std::sin(tilt), -std::cos(tilt));
  const char* names[] = {"centre", "left", "right"};
  const double xs[] = {0.0, -0.8, 0.8};
  for (int i = 0; i < 3; ++i) {
    const Vector3d pos(xs[i], 0, 0);
    CameraCalib c = look_at_camera(pos, pos + fwd, 960, 540, 90.0);
    c.id = i;
    c.name = names[i];
    c.fx = c.fy = 480.0;
    c.cx = 479.5;
    c.cy = 269.5;
    rig.cameras.push_back(c);
  }
  return rig;
}

}  // namespace vclassroom
