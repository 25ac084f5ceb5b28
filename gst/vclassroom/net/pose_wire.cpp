#include <gst/vclassroom/net/pose_wire.h>

#include <cstring>
#include <fstream>

#include <glib.h>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

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

}  // namespace vclassroom
