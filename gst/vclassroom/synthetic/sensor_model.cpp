// A consumer RGB-D camera (Azure Kinect-like) applied to a clean render.
//
// Depth:
//   - outside the depth field of view (an ellipse in normalised coordinates,
//     as the registered NFOV/WFOV depth of an Azure Kinect) nothing is measured;
//   - returned signal ~ ir_albedo * cos(incidence) / z^2: weak returns (dark
//     hair and clothes, far dark furniture) drop out;
//   - grazing incidence drops out;
//   - glossy surfaces (blackboard, windows, metal) drop out in blobs;
//   - pixels on depth discontinuities become flying pixels (a depth between the
//     two surfaces) or drop out;
//   - elsewhere Gaussian-like noise with sigma = a z^2, bounded at +-3.46 sigma
//     (sum of four uniforms), then rounding to 1 mm.
// Colour: Gaussian-like noise per channel.
// Everything is drawn from a counter-based generator keyed on (seed, camera
// id, frame, row), so a frame is reproducible and independent of the others.
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/synthetic/classroom.h>

namespace vclassroom {

namespace {

uint64_t mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// wyrand: one 64x64->128 multiply per draw, plenty for noise.
struct Rng {
  uint64_t s;
  uint64_t next() {
    s += 0xa0761d6478bd642full;
    const __uint128_t t = static_cast<__uint128_t>(s) * (s ^ 0xe7037ed1a0b428dbull);
    return uint64_t(t >> 64) ^ uint64_t(t);
  }
  // Uniform in [0, 1).
  float uniform() { return float(next() >> 40) * (1.0f / 16777216.0f); }
  // Unit variance, zero mean, bounded at +-3.46: the sum of four uniform bytes
  // (Irwin-Hall), close enough to Gaussian for sensor noise.
  static float gauss32(uint32_t r) {
    const int s = int(r & 255) + int((r >> 8) & 255) + int((r >> 16) & 255) + int(r >> 24);
    return float(s - 510) * (1.0f / 147.8f);
  }
  float gauss() { return gauss32(uint32_t(next())); }
};

float smooth01(float x) {
  x = std::clamp(x, 0.f, 1.f);
  return x * x * (3 - 2 * x);
}

}  // namespace

double sensor_depth_sigma_mm(const SensorParams& p, double z_m) { return p.sigma_mm_per_m2 * z_m * z_m; }

cv::Mat sensor_edge_mask(const cv::Mat& clean, const SensorParams& p) {
  CV_Assert(clean.type() == CV_16UC1);
  // The same integer test as apply_sensor_model.
  const int edge_min = int(std::floor(p.edge_min_mm));
  const int edge_q12 = int(std::lround(p.edge_ratio * 4096));
  cv::Mat mask = cv::Mat::zeros(clean.size(), CV_8UC1);
  const int W = clean.cols, H = clean.rows;
  for (int y = 0; y < H; ++y) {
    const uint16_t* r = clean.ptr<uint16_t>(y);
    for (int x = 0; x < W; ++x) {
      const int z = r[x];
      if (!z) continue;
      const int nb[4][2] = {{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}};
      for (auto& q : nb) {
        if (q[0] < 0 || q[0] >= W || q[1] < 0 || q[1] >= H) continue;
        const int nz = clean.at<uint16_t>(q[1], q[0]);
        const int dz = std::abs(nz - z);
        if (nz && dz > edge_min && dz * 4096 > edge_q12 * std::min(z, nz)) {
          mask.at<uint8_t>(y, x) = 255;
          break;
        }
      }
    }
  }
  return mask;
}

void apply_sensor_model(const RenderOutput& clean, const CameraCalib& cam, const SensorParams& p, uint64_t seed,
                        uint64_t frame, cv::Mat* depth_out, cv::Mat* color_out) {
  const int W = clean.depth.cols, H = clean.depth.rows;
  CV_Assert(clean.depth.type() == CV_16UC1 && clean.surface.type() == CV_16UC1 && clean.color.type() == CV_8UC3);
  depth_out->create(H, W, CV_16UC1);
  color_out->create(H, W, CV_8UC3);
  const uint64_t key = mix(mix(mix(seed) ^ uint64_t(cam.id)) ^ frame);

  // Coarse random field for the glossy dropout blobs (cells of 24 px).
  const int cell = 24;
  const int gw = W / cell + 2, gh = H / cell + 2;
  cv::Mat grid(gh, gw, CV_32F);
  {
    Rng g{mix(key ^ 0xB10B)};
    for (int i = 0; i < gh; ++i)
      for (int j = 0; j < gw; ++j) grid.at<float>(i, j) = g.uniform();
  }
  const float sig_a = float(p.sigma_mm_per_m2) * 1e-6f;  // mm per mm^2
  const float s_lo = float(p.signal_min), s_hi = float(p.signal_ok);
  const float g0 = float(std::cos(p.grazing_start_deg * M_PI / 180)), g1 = float(std::cos(p.grazing_full_deg * M_PI / 180));
  const float ax2 = float(1.0 / (p.fov_ax * p.fov_ax)), ay2 = float(1.0 / (p.fov_ay * p.fov_ay));
  const float ifx = float(1.0 / cam.fx), ify = float(1.0 / cam.fy), fcx = float(cam.cx), fcy = float(cam.cy);
  const float csig = float(p.color_sigma);
  const int edge_min = int(std::floor(p.edge_min_mm));
  const int edge_q12 = int(std::lround(p.edge_ratio * 4096));
  const SurfaceInfo* surf = clean.surfaces.data();
  const size_t nsurf = clean.surfaces.size();

  for (int y = 0; y < H; ++y) {
    Rng rng{mix(key ^ (uint64_t(y) << 20))};
    const uint16_t* zr = clean.depth.ptr<uint16_t>(y);
    const uint16_t* sr = clean.surface.ptr<uint16_t>(y);
    const uint16_t* zu = y > 0 ? clean.depth.ptr<uint16_t>(y - 1) : nullptr;
    const uint16_t* zd = y + 1 < H ? clean.depth.ptr<uint16_t>(y + 1) : nullptr;
    uint16_t* out = depth_out->ptr<uint16_t>(y);
    const float yn = (float(y) - fcy) * ify;
    const float gy = float(y) / cell;
    const int gi = int(gy);
    const float fyw = gy - gi;
    for (int x = 0; x < W; ++x) {
      const int z = zr[x];
      out[x] = 0;
      if (!z) continue;
      const float xn = (float(x) - fcx) * ifx;
      // Outside the depth camera's field of view.
      if (xn * xn * ax2 + yn * yn * ay2 > 1.0f) continue;
      // Depth discontinuity: the largest jump to a 4-neighbour (integer
      // thresholds: this runs for every pixel).
      int jump_z = 0, jump = 0;
      const int nb[4] = {x > 0 ? zr[x - 1] : 0, x + 1 < W ? zr[x + 1] : 0, zu ? zu[x] : 0, zd ? zd[x] : 0};
      for (int nz : nb) {
        const int dz = std::abs(nz - z);
        if (!nz || dz <= jump || dz <= edge_min) continue;
        if (dz * 4096 > edge_q12 * std::min(z, nz)) {
          jump = dz;
          jump_z = nz;
        }
      }
      if (jump) {
        const float r = rng.uniform();
        if (r < p.edge_drop_prob) continue;
        if (r < p.edge_drop_prob + p.flying_prob) {
          // Mixed return of the two surfaces.
          const float a = 0.15f + 0.7f * rng.uniform();
          out[x] = uint16_t(std::lround(z + a * float(jump_z - z)));
          continue;
        }
      }
      const uint16_t id = sr[x];
      const SurfaceInfo& s = id < nsurf ? surf[id] : surf[0];
      // Weak return or grazing incidence. The common case (neither) is decided
      // without divisions or roots: compare squares.
      const float rn2 = xn * xn + yn * yn + 1.f;
      const float dn = std::abs(s.normal_cam.x() * xn + s.normal_cam.y() * yn + s.normal_cam.z());
      const float zm = float(z) * 0.001f, zm2 = zm * zm;
      const float ird = s.ir_albedo * dn;
      const bool fine = dn * dn >= g0 * g0 * rn2 && ird * ird >= s_hi * s_hi * zm2 * zm2 * rn2;
      if (!fine) {
        const float cosi = dn / std::sqrt(rn2);
        const float signal = s.ir_albedo * cosi / zm2;
        const float p_dark = 1.f - smooth01((signal - s_lo) / (s_hi - s_lo));
        const float p_graze = smooth01((g0 - cosi) / (g0 - g1));
        const float p_miss = 1.f - (1.f - p_dark) * (1.f - p_graze);
        if (p_miss > 0 && rng.uniform() < p_miss) continue;
      }
      if (s.gloss > 0) {
        const float gx = float(x) / cell;
        const int gj = int(gx);
        const float fxw = gx - gj;
        const float b = (grid.at<float>(gi, gj) * (1 - fxw) + grid.at<float>(gi, gj + 1) * fxw) * (1 - fyw) +
                        (grid.at<float>(gi + 1, gj) * (1 - fxw) + grid.at<float>(gi + 1, gj + 1) * fxw) * fyw;
        // Bilinear blending squeezes the field towards 0.5; stretch it back.
        const float bb = std::clamp((b - 0.5f) * 1.8f + 0.5f, 0.f, 1.f);
        if (bb < s.gloss * float(p.gloss_dropout)) continue;
      }
      const float sigma = sig_a * float(z) * float(z);
      const int v = int(float(z) + sigma * rng.gauss() + 0.5f);  // z >= 1: positive, so + 0.5 rounds
      out[x] = uint16_t(std::clamp(v, 1, 65535));
    }
    const uint8_t* ci = clean.color.ptr<uint8_t>(y);
    uint8_t* co = color_out->ptr<uint8_t>(y);
    // Triangular noise (two uniform bytes) per channel: sigma 104.5 units.
    const int cs = int(csig * 65536.f / 104.5f);
    for (int x = 0; x < W; ++x) {
      const uint64_t r = rng.next();
      for (int k = 0; k < 3; ++k) {
        const int tri = int((r >> (16 * k)) & 255) + int((r >> (16 * k + 8)) & 255) - 255;
        const int v = int(ci[3 * x + k]) + ((tri * cs + 32768 + (1 << 24)) >> 16) - 256;
        co[3 * x + k] = uint8_t(std::clamp(v, 0, 255));
      }
    }
  }
}

}  // namespace vclassroom
