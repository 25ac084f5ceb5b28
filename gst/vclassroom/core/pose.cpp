#include <gst/vclassroom/core/pose.h>

#include <gst/vclassroom/core/checksum.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

namespace vclassroom {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

bool get_double(const GstStructure* s, const char* field, double* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_DOUBLE(v)) *out = g_value_get_double(v);
  else if (G_VALUE_HOLDS_FLOAT(v)) *out = g_value_get_float(v);
  else if (G_VALUE_HOLDS_INT(v)) *out = g_value_get_int(v);
  else return false;
  return true;
}

bool get_u64(const GstStructure* s, const char* field, uint64_t* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_UINT64(v)) *out = g_value_get_uint64(v);
  else if (G_VALUE_HOLDS_INT64(v) && g_value_get_int64(v) >= 0) *out = static_cast<uint64_t>(g_value_get_int64(v));
  else if (G_VALUE_HOLDS_UINT(v)) *out = g_value_get_uint(v);
  else if (G_VALUE_HOLDS_INT(v) && g_value_get_int(v) >= 0) *out = static_cast<uint64_t>(g_value_get_int(v));
  else return false;
  return true;
}

bool get_i64(const GstStructure* s, const char* field, int64_t* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_INT64(v)) *out = g_value_get_int64(v);
  else if (G_VALUE_HOLDS_UINT64(v)) *out = static_cast<int64_t>(g_value_get_uint64(v));
  else if (G_VALUE_HOLDS_INT(v)) *out = g_value_get_int(v);
  else return false;
  return true;
}

// YXZ intrinsic angles of R = Ry(yaw) Rx(pitch) Rz(roll).
Eigen::Matrix3d yaw_pitch_roll(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

}  // namespace

Eigen::Isometry3d Pose::cam_to_rig() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = orientation.normalized().toRotationMatrix();
  T.translation() = position;
  return T;
}

Pose Pose::from_cam_to_rig(const Eigen::Isometry3d& T) {
  Pose p;
  p.position = T.translation();
  p.orientation = Eigen::Quaterniond(T.linear()).normalized();
  return p;
}

uint64_t pose_session_id(const std::string& name) {
  // FNV-1a: stable across runs and machines, so a log's session numbers can be compared.
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ull;
  return h != 0 ? h : 1;
}

uint64_t new_pose_session_id() {
  uint64_t id = 0;
  while (id == 0) id = (static_cast<uint64_t>(g_random_int()) << 32) | g_random_int();
  return id;
}

void validate_pose(const Pose& p) {
  if (!p.position.allFinite()) throw Error("pose: position is not finite (NaN or infinity)");
  if (p.position.norm() > kMaxPoseDistance) {
    std::ostringstream os;
    os << "pose: position (" << p.position.x() << ", " << p.position.y() << ", " << p.position.z() << ") is "
       << p.position.norm() << " m from the rig origin (expected at most " << kMaxPoseDistance << " m)";
    throw Error(os.str());
  }
  const Eigen::Vector4d q = p.orientation.coeffs();
  if (!q.allFinite()) throw Error("pose: orientation quaternion is not finite (NaN or infinity)");
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) {
    std::ostringstream os;
    os << "pose: orientation quaternion has norm " << q.norm() << " (expected a unit quaternion, ±"
       << kUnitQuaternionTolerance << ")";
    throw Error(os.str());
  }
  if (p.has_fov() && !(p.fov_deg > 1.0 && p.fov_deg < 179.0)) {
    std::ostringstream os;
    os << "pose: fov " << p.fov_deg << " deg out of range (expected 1 to 179)";
    throw Error(os.str());
  }
  if (!std::isnan(p.fov_deg) && !std::isfinite(p.fov_deg)) throw Error("pose: fov is infinite");
}

RenderedPose rendered_pose_of(const Pose& pose) {
  RenderedPose r;
  r.known = true;
  r.clamped = pose.clamped;
  for (int i = 0; i < 3; ++i) r.position[i] = static_cast<float>(pose.position[i]);
  const Eigen::Quaterniond q = pose.orientation.normalized();
  r.orientation[0] = static_cast<float>(q.w());
  r.orientation[1] = static_cast<float>(q.x());
  r.orientation[2] = static_cast<float>(q.y());
  r.orientation[3] = static_cast<float>(q.z());
  return r;
}

Pose pose_of(const RenderedPose& r) {
  Pose p;
  p.position = Eigen::Vector3d(r.position[0], r.position[1], r.position[2]);
  p.orientation = Eigen::Quaterniond(r.orientation[0], r.orientation[1], r.orientation[2], r.orientation[3]).normalized();
  p.clamped = r.clamped;
  return p;
}

bool rendered_pose_is_valid(const RenderedPose& r) {
  double distance2 = 0, norm2 = 0;
  for (float v : r.position) {
    if (!std::isfinite(v)) return false;
    distance2 += double(v) * v;
  }
  for (float v : r.orientation) {
    if (!std::isfinite(v)) return false;
    norm2 += double(v) * v;
  }
  // Rounded to float, a unit quaternion's norm is within about 1e-7 of 1.
  return distance2 <= kMaxPoseDistance * kMaxPoseDistance && std::abs(std::sqrt(norm2) - 1.0) <= kUnitQuaternionTolerance;
}

GstEvent* pose_event_new(const Pose& p) {
  validate_pose(p);
  const Eigen::Quaterniond q = p.orientation.normalized();
  GstStructure* s = gst_structure_new(kPoseEventName, "x", G_TYPE_DOUBLE, p.position.x(), "y", G_TYPE_DOUBLE,
                                      p.position.y(), "z", G_TYPE_DOUBLE, p.position.z(), "qw", G_TYPE_DOUBLE, q.w(),
                                      "qx", G_TYPE_DOUBLE, q.x(), "qy", G_TYPE_DOUBLE, q.y(), "qz", G_TYPE_DOUBLE,
                                      q.z(), "seq", G_TYPE_UINT64, static_cast<guint64>(p.seq), nullptr);
  if (p.session != 0) gst_structure_set(s, "session", G_TYPE_UINT64, static_cast<guint64>(p.session), nullptr);
  if (p.has_fov()) gst_structure_set(s, "fov", G_TYPE_DOUBLE, p.fov_deg, nullptr);
  if (p.viewer_time_ns >= 0) gst_structure_set(s, "viewer-time", G_TYPE_INT64, static_cast<gint64>(p.viewer_time_ns), nullptr);
  if (p.clamped) gst_structure_set(s, "clamped", G_TYPE_BOOLEAN, TRUE, nullptr);
  return gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s);
}

bool is_pose_event(GstEvent* event) {
  return event && GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
         gst_event_has_name(event, kPoseEventName);
}

bool pose_event_parse(GstEvent* event, Pose* out, std::string* error) {
  std::string dummy;
  if (!error) error = &dummy;
  if (!is_pose_event(event)) {
    *error = "not a vclassroom/pose upstream event";
    return false;
  }
  const GstStructure* s = gst_event_get_structure(event);
  Pose p;
  double v[7];
  const char* fields[7] = {"x", "y", "z", "qw", "qx", "qy", "qz"};
  for (int i = 0; i < 7; ++i) {
    if (!get_double(s, fields[i], &v[i])) {
      *error = std::string("pose event: field '") + fields[i] + "' missing or not a number";
      return false;
    }
  }
  p.position = Eigen::Vector3d(v[0], v[1], v[2]);
  p.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
  if (gst_structure_has_field(s, "fov") && !get_double(s, "fov", &p.fov_deg)) {
    *error = "pose event: field 'fov' is not a number";
    return false;
  }
  if (!get_u64(s, "seq", &p.seq)) {
    *error = "pose event: field 'seq' missing or not an unsigned integer";
    return false;
  }
  if (gst_structure_has_field(s, "session") && !get_u64(s, "session", &p.session)) {
    *error = "pose event: field 'session' is not an unsigned integer";
    return false;
  }
  if (gst_structure_has_field(s, "viewer-time") && !get_i64(s, "viewer-time", &p.viewer_time_ns)) {
    *error = "pose event: field 'viewer-time' is not an integer (ns)";
    return false;
  }
  gboolean clamped = FALSE;
  if (gst_structure_has_field(s, "clamped") && !gst_structure_get_boolean(s, "clamped", &clamped)) {
    *error = "pose event: field 'clamped' is not a boolean";
    return false;
  }
  p.clamped = clamped;
  try {
    validate_pose(p);
  } catch (const Error& e) {
    *error = e.what();
    return false;
  }
  p.orientation.normalize();
  *out = p;
  return true;
}

Pose offset_to_pose(const ViewOffset& o, const CameraCalib& ref) {
  const Eigen::Matrix3d R = ref.cam_to_rig.linear();
  Pose p;
  p.position = ref.cam_to_rig.translation() + R * Eigen::Vector3d(o.right, -o.up, o.forward);
  p.orientation = Eigen::Quaterniond(R * yaw_pitch_roll(o.yaw * kDeg, o.pitch * kDeg, o.roll * kDeg)).normalized();
  return p;
}

CameraCalib rig_origin_reference() {
  CameraCalib c;
  c.width = c.height = 1;
  c.fx = c.fy = 1;
  c.cam_to_rig.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  return c;
}

ViewOffset pose_to_offset(const Pose& p, const CameraCalib& ref) {
  const Eigen::Matrix3d R = ref.cam_to_rig.linear();
  const Eigen::Vector3d move = R.transpose() * (p.position - ref.cam_to_rig.translation());
  const Eigen::Matrix3d off = R.transpose() * p.orientation.normalized().toRotationMatrix();
  ViewOffset o;
  o.right = move.x();
  o.up = -move.y();
  o.forward = move.z();
  o.pitch = std::asin(std::clamp(-off(1, 2), -1.0, 1.0)) / kDeg;
  o.yaw = std::atan2(off(0, 2), off(2, 2)) / kDeg;
  o.roll = std::atan2(off(1, 0), off(1, 1)) / kDeg;
  return o;
}

ViewOffset sliders_to_offset(const Sliders& s) {
  return {(s[0] - 50) * kSliderMetres, (s[1] - 50) * kSliderMetres, (s[2] - 50) * kSliderMetres,
          (s[3] - 50) * kSliderDegrees, (s[4] - 50) * kSliderDegrees, (s[5] - 50) * kSliderDegrees};
}

Sliders offset_to_sliders(const ViewOffset& o) {
  return {50 + o.right / kSliderMetres, 50 + o.up / kSliderMetres, 50 + o.forward / kSliderMetres,
          50 + o.yaw / kSliderDegrees,  50 + o.pitch / kSliderDegrees, 50 + o.roll / kSliderDegrees};
}

Pose sliders_to_pose(const Sliders& s, const CameraCalib& ref) {
  for (double v : s)
    if (!std::isfinite(v) || v < 0 || v > 100) throw Error("sliders: each value must be between 0 and 100");
  return offset_to_pose(sliders_to_offset(s), ref);
}

Sliders pose_to_sliders(const Pose& p, const CameraCalib& ref) { return offset_to_sliders(pose_to_offset(p, ref)); }

Sliders parse_sliders(const std::string& text) {
  std::string t = text;
  for (char& c : t)
    if (c == '[' || c == ']' || c == ',' || c == ';') c = ' ';
  std::istringstream is(t);
  Sliders s;
  std::string tok;
  size_t n = 0;
  while (is >> tok) {
    if (n == 6) throw Error("sliders '" + text + "': expected 6 values, got more");
    char* end = nullptr;
    double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0' || !std::isfinite(v))
      throw Error("sliders '" + text + "': '" + tok + "' is not a number");
    if (v < 0 || v > 100) throw Error("sliders '" + text + "': '" + tok + "' is outside 0..100");
    s[n++] = v;
  }
  if (n != 6) throw Error("sliders '" + text + "': expected 6 values like [50,50,50,50,50,50], got " + std::to_string(n));
  return s;
}

std::string format_sliders(const Sliders& s) {
  std::ostringstream os;
  os.precision(10);
  os << '[';
  for (size_t i = 0; i < s.size(); ++i) os << (i ? "," : "") << s[i];
  os << ']';
  return os.str();
}

namespace {
template <typename T>
void put_le(uint8_t*& p, T v) {
  uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof v);
  for (size_t i = 0; i < sizeof v; ++i) *p++ = static_cast<uint8_t>(bits >> (8 * i));
}
template <typename T>
T get_le(const uint8_t*& p) {
  uint64_t bits = 0;
  for (size_t i = 0; i < sizeof(T); ++i) bits |= static_cast<uint64_t>(*p++) << (8 * i);
  T v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}
}  // namespace

namespace {
constexpr char kPoseWireMagic[4] = {'V', 'C', 'P', '3'};

// HMAC-SHA256 of data through GLib, truncated to kPoseTagSize bytes.
void pose_tag(const PoseKey& key, const uint8_t* data, size_t size, uint8_t tag[kPoseTagSize]) {
  GHmac* hmac = g_hmac_new(G_CHECKSUM_SHA256, key.bytes.data(), key.bytes.size());
  g_hmac_update(hmac, data, static_cast<gssize>(size));
  guint8 digest[32];
  gsize len = sizeof digest;
  g_hmac_get_digest(hmac, digest, &len);
  g_hmac_unref(hmac);
  std::memcpy(tag, digest, kPoseTagSize);
}

// Compares all bytes whatever the first difference, so the time taken tells
// a forger nothing about how much of a tag was right.
bool same_tag(const uint8_t* a, const uint8_t* b) {
  uint8_t diff = 0;
  for (size_t i = 0; i < kPoseTagSize; ++i) diff |= static_cast<uint8_t>(a[i] ^ b[i]);
  return diff == 0;
}
}  // namespace

PoseKey load_pose_key(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the pose key file (missing or unreadable)");
  PoseKey key;
  key.bytes.resize(kPoseKeyMaxSize + 1);
  in.read(reinterpret_cast<char*>(key.bytes.data()), static_cast<std::streamsize>(key.bytes.size()));
  if (in.bad()) throw Error(path + ": cannot read the pose key file");
  const size_t n = static_cast<size_t>(in.gcount());
  if (n < kPoseKeyMinSize || n > kPoseKeyMaxSize)
    throw Error(path + ": pose key file holds " + (n > kPoseKeyMaxSize ? "more than " + std::to_string(kPoseKeyMaxSize)
                                                                        : std::to_string(n)) +
                " bytes (expected " + std::to_string(kPoseKeyMinSize) + " to " + std::to_string(kPoseKeyMaxSize) +
                " random bytes, e.g. head -c 32 /dev/urandom > pose.key)");
  key.bytes.resize(n);
  return key;
}

size_t pose_to_wire(const Pose& pose, uint8_t* out, const PoseWireStamp& stamp, const PoseKey* key) {
  const bool tagged = key && !key->empty();
  uint8_t* p = out;
  for (char c : kPoseWireMagic) *p++ = static_cast<uint8_t>(c);
  put_le<uint32_t>(p, tagged ? kPoseWireFlagTagged : 0u);
  put_le<uint64_t>(p, stamp.session);
  put_le<uint64_t>(p, stamp.packet);
  put_le<int64_t>(p, stamp.sent_ns);
  put_le<uint64_t>(p, pose.seq);
  put_le<int64_t>(p, pose.viewer_time_ns);
  const Eigen::Quaterniond q = pose.orientation.normalized();
  for (double v : {pose.position.x(), pose.position.y(), pose.position.z(), q.w(), q.x(), q.y(), q.z(), pose.fov_deg})
    put_le<double>(p, v);
  put_le<uint32_t>(p, crc32(out, kPoseWireSize - 4));
  if (!tagged) return kPoseWireSize;
  pose_tag(*key, out, kPoseWireSize, out + kPoseWireSize);
  return kPoseWireMaxSize;
}

bool pose_from_wire(const uint8_t* data, size_t size, Pose* out, std::string* error, const PoseKey* key,
                    PoseWireInfo* info) {
  PoseWireInfo dummy_info;
  if (!info) info = &dummy_info;
  *info = PoseWireInfo();
  auto fail = [&](PoseWireError why, const std::string& what) {
    info->error = why;
    if (error) *error = what;
    return false;
  };
  if (size < 8 || std::memcmp(data, kPoseWireMagic, 4) != 0) {
    if (size >= 4 && (std::memcmp(data, "VCP1", 4) == 0 || std::memcmp(data, "VCP2", 4) == 0))
      return fail(PoseWireError::kDamaged, std::string("pose packet of version ") + char(data[3]) + " (VCP" +
                                               char(data[3]) + "): this receiver reads version 3 (VCP3); "
                                               "update the lecturer's side");
    return fail(PoseWireError::kDamaged, "not a pose packet (size " + std::to_string(size) + ")");
  }
  const uint8_t* p = data + 4;
  const uint32_t flags = get_le<uint32_t>(p);
  if (flags & ~kPoseWireFlagTagged)
    return fail(PoseWireError::kDamaged, "pose packet with unknown flags " + std::to_string(flags));
  info->tagged = (flags & kPoseWireFlagTagged) != 0;
  const size_t expected = info->tagged ? kPoseWireMaxSize : kPoseWireSize;
  if (size != expected)
    return fail(PoseWireError::kDamaged, "pose packet of " + std::to_string(size) + " bytes (expected " +
                                             std::to_string(expected) + ")");
  const uint8_t* check = data + kPoseWireSize - 4;
  if (get_le<uint32_t>(check) != crc32(data, kPoseWireSize - 4))
    return fail(PoseWireError::kDamaged, "damaged pose packet (checksum)");
  if (key && !key->empty()) {
    if (!info->tagged) return fail(PoseWireError::kUnauthenticated, "pose packet without an authentication tag");
    uint8_t tag[kPoseTagSize];
    pose_tag(*key, data, kPoseWireSize, tag);
    if (!same_tag(tag, data + kPoseWireSize))
      return fail(PoseWireError::kUnauthenticated, "pose packet with a wrong authentication tag (another key?)");
  }
  info->stamp.session = get_le<uint64_t>(p);
  info->stamp.packet = get_le<uint64_t>(p);
  info->stamp.sent_ns = get_le<int64_t>(p);
  Pose pose;
  pose.seq = get_le<uint64_t>(p);
  pose.viewer_time_ns = get_le<int64_t>(p);
  double v[8];
  for (double& x : v) x = get_le<double>(p);
  pose.position = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
  pose.fov_deg = v[7];
  try {
    validate_pose(pose);
  } catch (const Error& e) {
    return fail(PoseWireError::kInvalid, e.what());
  }
  pose.orientation.normalize();
  *out = pose;
  return true;
}

std::vector<PoseSample> load_pose_trace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open pose trace (missing or unreadable)");
  std::string line;
  size_t lineno = 0;
  std::map<std::string, size_t> col;
  std::vector<PoseSample> out;
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::string cur;
    std::istringstream is(l);
    while (std::getline(is, cur, ',')) {
      size_t a = cur.find_first_not_of(" \t\r"), b = cur.find_last_not_of(" \t\r");
      f.push_back(a == std::string::npos ? "" : cur.substr(a, b - a + 1));
    }
    return f;
  };
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    std::vector<std::string> f = split(line);
    if (col.empty()) {
      for (size_t i = 0; i < f.size(); ++i) col[f[i]] = i;
      for (const char* req : {"x", "y", "z", "qw", "qx", "qy", "qz"})
        if (!col.count(req))
          throw Error(path + ":" + std::to_string(lineno) + ": header lacks column '" + req +
                      "' (expected t,x,y,z,qw,qx,qy,qz[,fov][,seq])");
      continue;
    }
    if (f.size() != col.size())
      throw Error(path + ":" + std::to_string(lineno) + ": expected " + std::to_string(col.size()) + " columns, got " +
                  std::to_string(f.size()));
    auto num = [&](const std::string& name) {
      const std::string& s = f[col.at(name)];
      char* end = nullptr;
      double v = std::strtod(s.c_str(), &end);
      if (s.empty() || *end != '\0' || !std::isfinite(v))
        throw Error(path + ":" + std::to_string(lineno) + ": column '" + name + "': '" + s + "' is not a number");
      return v;
    };
    PoseSample ps;
    ps.pose.position = {num("x"), num("y"), num("z")};
    ps.pose.orientation = Eigen::Quaterniond(num("qw"), num("qx"), num("qy"), num("qz"));
    if (col.count("t")) {
      ps.t = num("t");
      if (!out.empty() && ps.t < out.back().t)
        throw Error(path + ":" + std::to_string(lineno) + ": column 't': " + std::to_string(ps.t) +
                    " is earlier than the line before (" + std::to_string(out.back().t) + "); times must not decrease");
    }
    if (col.count("fov")) ps.pose.fov_deg = num("fov");
    ps.pose.seq = col.count("seq") ? static_cast<uint64_t>(num("seq")) : out.size();
    try {
      validate_pose(ps.pose);
    } catch (const Error& e) {
      throw Error(path + ":" + std::to_string(lineno) + ": " + e.what());
    }
    ps.pose.orientation.normalize();
    out.push_back(ps);
  }
  if (col.empty()) throw Error(path + ": empty pose trace (expected a header line t,x,y,z,qw,qx,qy,qz)");
  return out;
}

bool clamp_to_navigation(const NavigationBounds& bounds, const CameraCalib& reference, Pose* pose) {
  const ViewOffset o = pose_to_offset(*pose, reference);
  std::array<double, 6> v{{o.right, o.up, o.forward, o.yaw, o.pitch, o.roll}};
  bool outside = false;
  for (size_t i = 0; i < v.size(); ++i) {
    // A hair of tolerance: a pose made at the boundary (e.g. by posenav's own
    // clamping) comes back from the decomposition a rounding error outside it.
    const double eps = i < 3 ? 1e-9 : 1e-7;
    if (v[i] < bounds.min[i] - eps || v[i] > bounds.max[i] + eps) outside = true;
    v[i] = std::clamp(v[i], bounds.min[i], bounds.max[i]);
  }
  if (!outside) return false;
  // Only where it looks moves: seq, session, times and field of view stay the lecturer's.
  const Pose clamped = offset_to_pose(ViewOffset{v[0], v[1], v[2], v[3], v[4], v[5]}, reference);
  pose->position = clamped.position;
  pose->orientation = clamped.orientation;
  pose->clamped = true;
  return true;
}

namespace {

std::string trace_header(bool fov) { return std::string("t,x,y,z,qw,qx,qy,qz") + (fov ? ",fov" : "") + ",seq\n"; }

std::string trace_line(const PoseSample& s, bool fov) {
  const Pose& p = s.pose;
  char buf[512];
  int n = std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g",
                        std::isnan(s.t) ? 0.0 : s.t, p.position.x(), p.position.y(), p.position.z(),
                        p.orientation.w(), p.orientation.x(), p.orientation.y(), p.orientation.z());
  if (fov) n += std::snprintf(buf + n, sizeof buf - size_t(n), ",%.17g", p.fov_deg);
  std::snprintf(buf + n, sizeof buf - size_t(n), ",%llu\n", static_cast<unsigned long long>(p.seq));
  return buf;
}

}  // namespace

void save_pose_trace(const std::vector<PoseSample>& trace, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot write pose trace");
  const bool fov = !trace.empty() && trace.front().pose.has_fov();
  out << trace_header(fov);
  for (const auto& s : trace) out << trace_line(s, fov);
}

PoseTraceWriter::PoseTraceWriter(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) throw Error(path + ": cannot write pose trace (" + std::strerror(errno) + ")");
}

PoseTraceWriter::~PoseTraceWriter() {
  if (file_) std::fclose(file_);
}

void PoseTraceWriter::append(const PoseSample& sample) {
  std::string text;
  if (!header_written_) {
    fov_ = sample.pose.has_fov();
    text = trace_header(fov_);
    header_written_ = true;
  }
  text += trace_line(sample, fov_);
  if (std::fwrite(text.data(), 1, text.size(), file_) != text.size() || std::fflush(file_) != 0)
    throw Error(path_ + ": cannot write pose trace (" + std::strerror(errno) + ")");
}

size_t pose_trace_index(const std::vector<PoseSample>& trace, double t, uint64_t frame) {
  if (trace.empty()) return 0;
  if (std::isnan(trace.front().t)) return static_cast<size_t>(std::min<uint64_t>(frame, trace.size() - 1));
  // A frame time a hair under a sample's (rounding of 1/30 s) still shows that sample.
  const double at = t + 1e-6;
  const auto it = std::upper_bound(trace.begin(), trace.end(), at,
                                   [](double v, const PoseSample& s) { return v < s.t; });
  return it == trace.begin() ? 0 : static_cast<size_t>(it - trace.begin()) - 1;
}

}  // namespace vclassroom
