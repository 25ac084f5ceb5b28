// Learners: articulated bodies whose behaviour is a pure function of
// (seed, learner, t), so every instance and every camera sees the same instant.
#include <algorithm>
#include <cmath>

#include <gst/vclassroom/synthetic/classroom_internal.h>

namespace vclassroom {

using namespace classroom_detail;
using Eigen::Affine3d;
using Eigen::AngleAxisd;
using Eigen::Vector3d;

namespace {

uint64_t mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}
uint64_t hash3(uint64_t a, uint64_t b, uint64_t c) { return mix(mix(mix(a) ^ b) ^ c); }
double unit(uint64_t h) { return (h >> 11) * (1.0 / 9007199254740992.0); }

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
// 0 before a, rising over `ramp` to 1, falling to 0 at b.
double envelope(double t, double a, double b, double ramp) {
  return smoothstep((t - a) / ramp) * (1 - smoothstep((t - (b - ramp)) / ramp));
}
double lerp(double a, double b, double s) { return a + (b - a) * s; }
double deg(double d) { return d * M_PI / 180.0; }

constexpr double kSlot = 12.0;  // seconds per behaviour slot

struct Pose {
  std::string action = "sit";
  double x = 0, z = 0, heading = 0;
  double stand = 0;                      // 0 seated .. 1 standing
  double walk = 0, walk_phase = 0;       // stride amplitude 0..1 and phase
  double torso_yaw = 0, lean = 0.08, head_yaw = 0, head_pitch = 0;
  double raise_r = 0, raise_l = 0;       // 0 resting .. 1 hand up
  double write = 0;
};

struct Seg {
  double dur;
  Eigen::Vector2d from, to;
  double heading;   // NaN: face along the motion
  double stand0, stand1;
  bool walking;
};

}  // namespace

namespace classroom_detail {

void init_learners(Classroom::Impl* im) {
  // A stream of its own, so the static scene never depends on the learners and
  // learner k looks and behaves the same whatever the learner count.
  cv::RNG rng(im->config.seed * 0xD1B54A32D192ED03ull + 777);
  std::vector<int> order(im->seats.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.uniform(0, int(i))]);
  const Vector3d shirts[] = {
      {0.86, 0.83, 0.75},  // like the wall
      {0.55, 0.64, 0.62},  // like the dado
      {0.78, 0.58, 0.4},   // like the desks
      {0.7, 0.14, 0.13},  {0.12, 0.15, 0.32}, {0.07, 0.07, 0.08}, {0.92, 0.92, 0.9},
      {0.2, 0.48, 0.3},   {0.9, 0.74, 0.2},   {0.5, 0.5, 0.52},   {0.35, 0.5, 0.8}, {0.55, 0.25, 0.5}};
  const Vector3d trousers[] = {{0.16, 0.22, 0.38}, {0.08, 0.08, 0.09}, {0.65, 0.57, 0.42}, {0.4, 0.4, 0.42}};
  const Vector3d skins[] = {{0.93, 0.76, 0.64}, {0.82, 0.62, 0.48}, {0.6, 0.42, 0.3}, {0.4, 0.27, 0.2}};
  const Vector3d hairs[] = {{0.06, 0.05, 0.05}, {0.25, 0.16, 0.1}, {0.6, 0.45, 0.25}, {0.12, 0.1, 0.08}};
  for (int k = 0; k < kClassroomMaxLearners; ++k) {
    LearnerLook l;
    l.seat = order[k % order.size()];
    l.shirt = shirts[rng.uniform(0, 12)];
    l.trousers = trousers[rng.uniform(0, 4)];
    l.skin = skins[rng.uniform(0, 4)];
    l.hair = hairs[rng.uniform(0, 4)];
    l.shoes = Vector3d(0.1, 0.09, 0.09);
    l.long_sleeves = rng.uniform(0, 2) == 0;
    l.height = rng.uniform(0.93, 1.05);
    l.phase = rng.uniform(0.0, 2 * M_PI);
    l.slot_offset = rng.uniform(0.0, kSlot);
    im->looks.push_back(l);
  }
  im->tex_fabric = 2;
  im->tex_skin = 3;
  im->tex_hair = 4;
}

}  // namespace classroom_detail

namespace {

Pose pose_at(const Classroom::Impl& im, int k, double t) {
  const LearnerLook& look = im.looks[k - 1];
  const Seat& seat = im.seats[look.seat];
  Pose p;
  p.x = seat.pos.x();
  p.z = seat.pos.z();
  // Idle life: breathing and small head motion.
  p.lean += 0.02 * std::sin(t * 1.6 + look.phase);
  p.head_yaw = 0.12 * std::sin(t * 0.37 + look.phase);
  p.head_pitch = 0.06 * std::sin(t * 0.53 + 2 * look.phase);

  const double tt = t + look.slot_offset;
  const int64_t slot = int64_t(std::floor(tt / kSlot));
  const double tau = tt - double(slot) * kSlot;
  const uint64_t h = hash3(im.config.seed, uint64_t(k), uint64_t(slot));
  const int pick = int(h % 100);
  const double u = unit(mix(h));
  if (pick < 22) {
    p.action = "write";
    const double e = envelope(tau, 0.5, 11.0, 1.0);
    p.head_pitch += 0.45 * e;
    p.lean += 0.15 * e;
    p.write = e;
  } else if (pick < 42) {
    p.action = "look-around";
    const double side = u < 0.5 ? -1 : 1;
    const double e = envelope(tau, 1.0, 6.0 + 4 * u, 1.0);
    p.torso_yaw = side * 0.45 * e;
    p.head_yaw += side * 0.7 * e;
  } else if (pick < 60) {
    p.action = "raise-hand";
    const double e = envelope(tau, 1.0, 6.0 + 4 * u, 0.8);
    (u < 0.7 ? p.raise_r : p.raise_l) = e;
    p.head_pitch -= 0.1 * e;
  } else if (pick < 76) {
    p.action = "stand-up";
    p.stand = envelope(tau, 1.0, 8.0 + 3 * u, 1.3);
  } else if (pick < 90) {
    p.action = "walk-to-board";
    // Stand, step into the aisle, walk to the front, write on the board, come back.
    const Eigen::Vector2d S(seat.pos.x(), seat.pos.z() + 0.12), A(seat.aisle_x, S.y());
    const double front = im.front_z - 0.75;
    const Eigen::Vector2d B(seat.aisle_x, front), C(std::clamp(seat.aisle_x, -1.3, 1.3), front);
    const double nan = std::nan("");
    std::vector<Seg> segs = {
        {1.0, S, S, 0.0, 0, 1, false},   {0.8, S, A, 0.0, 1, 1, true},  {0, A, B, nan, 1, 1, true},
        {0, B, C, nan, 1, 1, true},      {1.6, C, C, 0.0, 1, 1, false}, {0, C, B, nan, 1, 1, true},
        {0, B, A, nan, 1, 1, true},      {0.8, A, S, 0.0, 1, 1, true},  {1.0, S, S, 0.0, 1, 0, false}};
    double fixed = 0, dist = 0;
    for (auto& s : segs) (s.dur > 0 ? fixed : dist) += s.dur > 0 ? s.dur : (s.to - s.from).norm();
    const double speed = std::max(1.0, dist / std::max(0.5, kSlot - 0.5 - fixed));
    for (auto& s : segs)
      if (s.dur == 0) s.dur = std::max(1e-3, (s.to - s.from).norm() / speed);
    double t0 = 0, walked = 0;
    p.lean = 0.02;
    bool placed = false;
    for (size_t i = 0; i < segs.size() && !placed; ++i) {
      const Seg& s = segs[i];
      if (tau < t0 + s.dur || i + 1 == segs.size()) {
        const double a = std::clamp((tau - t0) / s.dur, 0.0, 1.0);
        const Eigen::Vector2d q = s.from + (s.to - s.from) * a;
        p.x = q.x();
        p.z = q.y();
        p.stand = lerp(s.stand0, s.stand1, smoothstep(a));
        const Eigen::Vector2d d = s.to - s.from;
        p.heading = std::isnan(s.heading) ? std::atan2(d.x(), d.y()) : s.heading;
        if (s.walking) {
          walked += (s.to - s.from).norm() * a;
          p.walk = std::min(1.0, std::min(a, 1 - a) * 8);
        }
        if (i == 4) p.raise_r = 0.65 * envelope(tau - t0, 0.1, s.dur, 0.3), p.head_pitch = -0.15;
        placed = true;
      } else {
        if (s.walking) walked += (s.to - s.from).norm();
        t0 += s.dur;
      }
    }
    p.walk_phase = walked / 0.65 * M_PI;
  } else {
    p.action = "sit";
  }
  if (p.action != "walk-to-board" && p.stand > 0) p.z += 0.12 * p.stand;
  return p;
}

struct Mats {
  Material shirt, sleeve, trousers, skin, hair, shoes;
};

// Builds the body: root frame on the floor, facing +Z local.
void build_body(const Classroom::Impl& im, int k, double t, FaceBuilder& fb) {
  const Pose p = pose_at(im, k, t);
  const LearnerLook& look = im.looks[k - 1];
  const double s = look.height;
  auto lum = [](const Vector3d& c) { return 0.3 * c[0] + 0.59 * c[1] + 0.11 * c[2]; };
  Mats m;
  m.shirt = Material{im.tex_fabric, look.shirt, 300, float(0.12 + 0.7 * lum(look.shirt)), 0.02f, false};
  m.trousers = Material{im.tex_fabric, look.trousers, 300, float(0.12 + 0.7 * lum(look.trousers)), 0.02f, false};
  m.skin = Material{im.tex_skin, look.skin, 300, 0.45f, 0.05f, false};
  // Dark hair absorbs the near infrared: real ToF cameras lose it.
  m.hair = Material{im.tex_hair, look.hair, 500, float(0.04 + 0.5 * lum(look.hair)), 0.1f, false};
  m.shoes = Material{im.tex_fabric, look.shoes, 300, 0.1f, 0.3f, false};
  // Short sleeves show the forearms.
  m.sleeve = look.long_sleeves ? m.shirt : m.skin;

  const Affine3d root(Eigen::Translation3d(p.x, im.floor_y, p.z) * AngleAxisd(p.heading, Vector3d::UnitY()));
  // Rotation taking local +Y to direction d.
  auto along = [](const Vector3d& a, const Vector3d& b) {
    const Vector3d d = b - a;
    const double len = d.norm();
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitY(), d / len);
    return Affine3d(Eigen::Translation3d(a) * q * Eigen::Scaling(1.0, len, 1.0));
  };
  auto limb = [&](const Vector3d& a, const Vector3d& b, double r0, double r1, const Material& mat) {
    fb.frustum(root * along(a, b), r0, r1, 8, mat);
  };
  // Pitch angle phi from straight down towards +Z (forward).
  auto dir = [](double phi, double out) { return Vector3d(out, -std::cos(phi), std::sin(phi)); };

  const double hip_h = lerp(0.47, 0.91 * s, p.stand) - 0.02 * p.walk * std::abs(std::sin(p.walk_phase));
  const double thigh = 0.44 * s, shin = 0.43 * s;
  const double sw = std::sin(p.walk_phase);
  for (int side = -1; side <= 1; side += 2) {
    // side -1 = right (-X local), +1 = left.
    const Vector3d hip(side * 0.095 * s, hip_h, p.stand < 1 ? -0.04 * (1 - p.stand) : 0.0);
    double th = lerp(deg(88), 0, p.stand) + p.walk * deg(24) * sw * side;
    double knee_bend = lerp(deg(88), 0, p.stand) + p.walk * deg(30) * std::max(0.0, -sw * side);
    const Vector3d knee = hip + thigh * dir(th, 0);
    const Vector3d ankle = knee + shin * dir(th - knee_bend, 0);
    limb(hip, knee, 0.075 * s, 0.055 * s, m.trousers);
    limb(knee, ankle, 0.05 * s, 0.04 * s, m.trousers);
    const Vector3d foot(ankle.x(), std::max(0.035, ankle.y() - 0.02), ankle.z() + 0.05);
    fb.box(root * Affine3d(Eigen::Translation3d(foot) * Eigen::Scaling(0.045, 0.035, 0.12)), m.shoes);
  }
  // Torso, leaning forward and twisting about the pelvis.
  const Affine3d torso = Affine3d(Eigen::Translation3d(0, hip_h, 0)) *
                         AngleAxisd(p.torso_yaw, Vector3d::UnitY()) * AngleAxisd(p.lean, Vector3d::UnitX());
  const double tl = 0.54 * s;
  fb.frustum(root * torso * Affine3d(Eigen::Scaling(1.0, tl, 0.62)), 0.155 * s, 0.19 * s, 8, m.shirt);
  // Neck and head.
  const Vector3d neck0 = torso * Vector3d(0, tl - 0.02, 0), neck1 = torso * Vector3d(0, tl + 0.08 * s, 0.01);
  limb(neck0, neck1, 0.05 * s, 0.045 * s, m.skin);
  const Affine3d head = Affine3d(Eigen::Translation3d(neck1 + Vector3d(0, 0.1 * s, 0))) *
                        AngleAxisd(p.torso_yaw + p.head_yaw, Vector3d::UnitY()) *
                        AngleAxisd(p.head_pitch + p.lean, Vector3d::UnitX()) *
                        Eigen::Scaling(0.085 * s, 0.115 * s, 0.1 * s);
  fb.ellipsoid(root * head, 10, 7, [&](const Vector3d& d) -> const Material& {
    // Face and neck in skin, the rest hair.
    const bool face = d.z() > 0.2 && d.y() < 0.45;
    const bool low = d.y() < -0.3;
    return (face || low) ? m.skin : m.hair;
  });
  // Arms.
  const double swing = p.walk * deg(22) * sw;
  for (int side = -1; side <= 1; side += 2) {
    const double raise = side < 0 ? p.raise_r : p.raise_l;
    const Vector3d shoulder = torso * Vector3d(side * 0.205 * s, tl - 0.05 * s, 0);
    // Resting: on the desk when seated, hanging when standing.
    double a_up = lerp(deg(40), deg(6), p.stand), a_fore = lerp(deg(95), deg(14), p.stand);
    a_up += -side * swing;
    a_fore += -side * swing;
    if (side < 0 && p.write > 0) a_fore += p.write * deg(8) * std::sin(t * 9.0);
    a_up = lerp(a_up, deg(168), raise);
    a_fore = lerp(a_fore, deg(176), raise);
    const double out = side * lerp(0.12, 0.2, raise * 0.3);
    const Vector3d ud = (AngleAxisd(p.torso_yaw, Vector3d::UnitY()) * dir(a_up, out)).normalized();
    const Vector3d fd = (AngleAxisd(p.torso_yaw, Vector3d::UnitY()) * dir(a_fore, out * 0.3)).normalized();
    const Vector3d elbow = shoulder + 0.29 * s * ud;
    const Vector3d wrist = elbow + 0.25 * s * fd;
    limb(shoulder, elbow, 0.052 * s, 0.042 * s, m.shirt);
    limb(elbow, wrist, 0.04 * s, 0.032 * s, m.sleeve);
    const Vector3d hand = wrist + 0.06 * s * fd;
    fb.box(root * along(wrist, hand + 0.03 * s * fd) * Affine3d(Eigen::Translation3d(0, 0.5, 0)) *
               Affine3d(Eigen::Scaling(0.04 * s, 0.5, 0.018 * s)),
           m.skin);
  }
}

}  // namespace

void Classroom::Impl::learner_faces(double t, std::vector<Face>* out) const {
  FaceBuilder fb(&lights, ambient, &sun_dir, sun, out);
  for (int k = 1; k <= config.learners; ++k) {
    fb.label = uint8_t(k);
    build_body(*this, k, t, fb);
  }
}

LearnerState Classroom::Impl::learner_state(int k, double t) const {
  if (k < 1 || k > config.learners)
    throw Error("classroom: no learner " + std::to_string(k) + " (learners: " + std::to_string(config.learners) +
                ")");
  const Pose p = pose_at(*this, k, t);
  LearnerState s;
  s.id = k;
  s.action = p.action;
  s.position = Vector3d(p.x, floor_y, p.z);
  s.heading = p.heading;
  return s;
}

}  // namespace vclassroom
