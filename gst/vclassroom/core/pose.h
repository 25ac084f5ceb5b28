// The lecturer's 6DoF pose: the `vclassroom/pose` upstream event, the paper's
// six-slider notation, and pose traces (DESIGN.md §2.3, docs/pose.md).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gst/gst.h>

#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

inline constexpr const char* kPoseEventName = "vclassroom/pose";
// Positions farther than this from the rig origin are rejected as absurd.
inline constexpr double kMaxPoseDistance = 1000.0;  // metres
// Quaternions whose norm is farther than this from 1 are rejected.
inline constexpr double kUnitQuaternionTolerance = 1e-3;

// The virtual camera's pose in the rig frame: `position` is its optical
// centre, `orientation` rotates virtual-camera coordinates (OpenCV axes) into
// rig coordinates, exactly like a rig camera's cam_to_rig.
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  double fov_deg = std::numeric_limits<double>::quiet_NaN();  // optional horizontal field of view
  uint64_t seq = 0;
  // Whose stream the pose belongs to: seqs are ordered only within one
  // session (docs/network.md, "Sessions"). Named by the receiver that obeyed
  // the pose (pose_session_id()); 0: unnamed, one local source.
  uint64_t session = 0;
  int64_t viewer_time_ns = -1;  // -1: not given
  // The server moved this pose into the rig's navigation bounds (docs/navigation.md); carried by the pose
  // event to the renderers and echoed with the frame, never sent by a client.
  bool clamped = false;

  bool has_fov() const { return std::isfinite(fov_deg); }
  Eigen::Isometry3d cam_to_rig() const;
  static Pose from_cam_to_rig(const Eigen::Isometry3d& T);
};

// The pose a frame shows, as the server rendered it: after the navigation bounds moved it in, so the lecturer's
// side learns where it really is. Plain floats, as it rides in a GstMeta and on the wire (pose_stamp.h).
struct RenderedPose {
  bool known = false;    // false: the frame names only the pose's seq and viewer time
  bool clamped = false;  // the lecturer's pose was outside the navigation bounds and was moved in
  float position[3] = {0, 0, 0};         // rig metres
  float orientation[4] = {1, 0, 0, 0};  // unit quaternion w, x, y, z (virtual camera -> rig)
};
RenderedPose rendered_pose_of(const Pose& pose);
// The pose it names (seq and viewer time unset), for a known one.
Pose pose_of(const RenderedPose& rendered);
// False when the values are not a usable pose (not finite, absurd position, not a unit quaternion at float
// precision): it came from the network.
bool rendered_pose_is_valid(const RenderedPose& rendered);

// A session's number in pose events from the receiver's name for it (an RTP
// stream's SSRC and session number, a WHEP session id): a stable 64-bit hash,
// never 0.
uint64_t pose_session_id(const std::string& name);
// A fresh random session number for a local pose source that starts (never 0).
uint64_t new_pose_session_id();

// Throws Error when the pose is not usable: NaN, non-unit quaternion, absurd
// position or field of view.
void validate_pose(const Pose& pose);

// A GST_EVENT_CUSTOM_UPSTREAM event carrying the pose. Validates first; throws Error.
GstEvent* pose_event_new(const Pose& pose);
// True when `event` is a pose event (whether or not it is valid).
bool is_pose_event(GstEvent* event);
// Parses and validates; false with a message on a malformed or invalid pose.
bool pose_event_parse(GstEvent* event, Pose* pose, std::string* error);

// The paper's mouse interface writes a view as six sliders 0..100, where
// [50,50,50,50,50,50] is the reference camera. Mapping (docs/pose.md):
//   s[0..2]: move right / up / forward in the reference camera's own axes,
//            (s - 50) * kSliderMetres each (±1 m);
//   s[3..5]: yaw (turn right) / pitch (look up) / roll (clockwise),
//            (s - 50) * kSliderDegrees each (±90°), applied yaw, then pitch, then roll.
using Sliders = std::array<double, 6>;
inline constexpr double kSliderMetres = 0.02;
inline constexpr double kSliderDegrees = 1.8;

// A view relative to a reference camera, in that camera's own axes: the
// unbounded form of the sliders (which are this, scaled and offset by 50).
struct ViewOffset {
  double right = 0, up = 0, forward = 0;  // metres
  double yaw = 0, pitch = 0, roll = 0;    // degrees: turn right, look up, roll clockwise
};
Pose offset_to_pose(const ViewOffset& o, const CameraCalib& reference);
// The reference when no rig is known: a camera at the rig origin looking
// level along -Z (rotation diag(1, -1, -1), rig Y up).
CameraCalib rig_origin_reference();
ViewOffset pose_to_offset(const Pose& pose, const CameraCalib& reference);
ViewOffset sliders_to_offset(const Sliders& s);
Sliders offset_to_sliders(const ViewOffset& o);

// The pose nearest to `pose` inside the navigation bounds (each of the six
// offsets from the reference camera clamped to its range). Returns false and
// leaves `pose` untouched, bit for bit, when it is inside already. seq,
// session, viewer time and field of view are kept; `clamped` is set.
bool clamp_to_navigation(const NavigationBounds& bounds, const CameraCalib& reference, Pose* pose);

Pose sliders_to_pose(const Sliders& s, const CameraCalib& reference);
// Inverse of sliders_to_pose for poses within the sliders' range (|pitch| < 90°).
Sliders pose_to_sliders(const Pose& pose, const CameraCalib& reference);
// Parses "[50,50,50,50,50,50]" (brackets optional, comma or space separated); throws Error.
Sliders parse_sliders(const std::string& text);
std::string format_sliders(const Sliders& s);

// The pose on the wire: the RTP payload of the back channel, version 3
// (docs/network.md), little-endian:
//   "VCP3", flags u32 (bit 0: a tag follows), session u64 (the sender's
//   random number for this run: a restarted lecturer is a new session),
//   packet u64 (numbers every packet of the session, repeats included),
//   sent-time i64 (the sender's monotonic clock when it sent the packet, ns;
//   -1 none), seq u64, viewer-time i64, x y z qw qx qy qz fov as IEEE doubles
//   (fov NaN = none), CRC-32 of all before it; then, with flag bit 0, a
//   16-byte tag: HMAC-SHA256 (key from a file) of all before it, truncated.
//   The tag covers session, packet number and times, so a receiver's replay
//   window (net/pose_session.h) can trust them.
inline constexpr size_t kPoseWireSize = 4 + 4 + 8 + 8 + 8 + 8 + 8 + 8 * 8 + 4;  // untagged
inline constexpr size_t kPoseTagSize = 16;
inline constexpr size_t kPoseWireMaxSize = kPoseWireSize + kPoseTagSize;  // tagged
inline constexpr uint32_t kPoseWireFlagTagged = 1u;

// What a packet says of its sending apart from the pose. Built from a bare
// session number where the rest does not matter (tests, untagged senders).
struct PoseWireStamp {
  uint64_t session = 0;
  uint64_t packet = 0;
  int64_t sent_ns = -1;
  PoseWireStamp(uint64_t session_ = 0, uint64_t packet_ = 0, int64_t sent_ns_ = -1)  // NOLINT: implicit on purpose
      : session(session_), packet(packet_), sent_ns(sent_ns_) {}
};

// The shared secret that authenticates poses: a file's whole content, raw
// bytes (e.g. `head -c 32 /dev/urandom > pose.key`).
inline constexpr size_t kPoseKeyMinSize = 16;
inline constexpr size_t kPoseKeyMaxSize = 1024;
struct PoseKey {
  std::vector<uint8_t> bytes;
  bool empty() const { return bytes.empty(); }
};
// Throws Error naming the file when it is missing, unreadable, shorter than
// kPoseKeyMinSize or longer than kPoseKeyMaxSize bytes.
PoseKey load_pose_key(const std::string& path);

// Why pose_from_wire() refused a packet.
enum class PoseWireError {
  kNone,
  kDamaged,          // wrong size, version, flags or checksum
  kUnauthenticated,  // a key is set and the tag is missing or wrong
  kInvalid,          // well-formed but a pose validate_pose() rejects (NaN, not a unit quaternion, ...)
};
struct PoseWireInfo {
  PoseWireStamp stamp;   // the sender's session number, packet number and sending time
  bool tagged = false;   // whether the packet carried a tag (checked only when a key is given)
  PoseWireError error = PoseWireError::kNone;
};

// Writes the packet into `out` (room for kPoseWireMaxSize bytes); returns its
// size: kPoseWireSize, or kPoseWireMaxSize when a non-empty key tags it.
size_t pose_to_wire(const Pose& pose, uint8_t* out, const PoseWireStamp& stamp = {}, const PoseKey* key = nullptr);
// False with a message on a wrong size, version, flags or checksum, a pose
// validate_pose() rejects, or, when `key` is non-empty, a missing or wrong
// tag (without a key a tag is not checked: anyone can steer, docs/network.md).
// `info` (optional) receives the stamp and why the packet was refused.
bool pose_from_wire(const uint8_t* data, size_t size, Pose* pose, std::string* error, const PoseKey* key = nullptr,
                    PoseWireInfo* info = nullptr);

// A pose trace: CSV with a header naming the columns, one pose per frame.
// Required columns x,y,z,qw,qx,qy,qz; optional t (seconds), fov (deg), seq.
// '#' starts a comment line. Throws Error naming file, line and column.
struct PoseSample {
  double t = std::numeric_limits<double>::quiet_NaN();  // seconds, NaN when the trace has no t column
  Pose pose;
};
std::vector<PoseSample> load_pose_trace(const std::string& path);
void save_pose_trace(const std::vector<PoseSample>& trace, const std::string& path);
// Writes a trace as it happens (the lecturer's poses during a session), one
// line per pose handed to the kernel at once, so a killed process leaves every
// pose before. The columns are those of the first pose (fov or not). Throws
// Error naming the file.
class PoseTraceWriter {
 public:
  explicit PoseTraceWriter(const std::string& path);
  ~PoseTraceWriter();
  PoseTraceWriter(const PoseTraceWriter&) = delete;
  PoseTraceWriter& operator=(const PoseTraceWriter&) = delete;
  void append(const PoseSample& sample);

 private:
  std::string path_;
  FILE* file_ = nullptr;
  bool fov_ = false;
  bool header_written_ = false;
};
// Which sample of a non-empty trace shows the frame at running time `t`
// seconds, the `frame`-th of its stream: with a t column the last sample at or
// before t (the first before it starts), else sample `frame`; the last one is
// held.
size_t pose_trace_index(const std::vector<PoseSample>& trace, double t, uint64_t frame);

}  // namespace vclassroom
