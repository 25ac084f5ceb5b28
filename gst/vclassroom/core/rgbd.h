// The per-camera RGB-D stream `video/x-rgbd` (DESIGN.md §2.1, docs/rgbd-stream.md):
// caps <-> calibration, and the planes of a buffer as cv::Mat.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gst/base/gstaggregator.h>
#include <gst/gst.h>
#include <gst/video/video.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/core/rig.h>

namespace vclassroom {

inline constexpr const char* kRgbdMediaType = "video/x-rgbd";
// Pad-template caps: any size and rate, planes and calibration negotiated.
inline constexpr const char* kRgbdTemplateCaps =
    "video/x-rgbd, width = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], height = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], "
    "framerate = (fraction) [ 0/1, 2147483647/1 ]";

// The planes a `video/x-rgbd` buffer can hold, in the order they are stored.
enum class Plane {
  Color,    // RGB, 8 bit per channel
  Depth,    // GRAY16_LE, millimetres, 0 = no measurement
  Label,    // GRAY8, 0 = static scene, k = learner k
  Weight,   // GRAY8, per-pixel confidence 0..255
  DepthGT,  // GRAY16_LE, ground-truth (clean) depth in mm, from synthetic sources
};

const char* plane_name(Plane p);
std::optional<Plane> plane_from_name(const std::string& name);
GstVideoFormat plane_format(Plane p);
int plane_cv_type(Plane p);

// Layout of one image inside a GstBuffer: where it starts, bytes per row.
struct PlaneLayout {
  gsize offset = 0;
  gint stride = 0;
};

// Everything the caps of one camera's stream say.
struct RgbdInfo {
  CameraCalib camera;  // width/height are the stream's size
  int fps_n = 30;
  int fps_d = 1;
  std::vector<Plane> planes{Plane::Color, Plane::Depth};

  int width() const { return camera.width; }
  int height() const { return camera.height; }
  bool has(Plane p) const { return index_of(p) >= 0; }
  int index_of(Plane p) const;
  // Bytes per row of plane `i` in the packed layout used when a buffer carries
  // no GstVideoMeta (e.g. after the network): GstVideoInfo's default stride.
  gint default_stride(size_t i) const;
  gsize plane_size(size_t i) const { return static_cast<gsize>(default_stride(i)) * height(); }
  gsize default_offset(size_t i) const;
  gsize default_total_size() const { return default_offset(planes.size()); }
  // "color,depth,label" as written in the caps.
  std::string planes_string() const;
  // Stream duration of one frame; GST_CLOCK_TIME_NONE for variable rate.
  GstClockTime frame_duration() const;
};

// The compressed stream (rgbdenc → rgbddec, recordings): the video/x-rgbd
// fields (size, rate, planes, calibration) under another name.
inline constexpr const char* kRgbdCodedMediaType = "video/x-rgbd-coded";
inline constexpr const char* kRgbdCodedTemplateCaps =
    "video/x-rgbd-coded, codec = (string) vcrd1, width = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], "
    "height = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], "
    "framerate = (fraction) [ 0/1, 2147483647/1 ]";

// Renames every structure of `caps` to `name`, adding or removing the codec field.
GstCaps* rgbd_caps_renamed(GstCaps* caps, const char* name, bool coded);

// A video/x-rgbd source's caps query (get_caps of rgbdtestsrc, rgbdfilesrc,
// rgbdsrc): the stream's fixed caps once it knows them (`info` set), else the
// pad template's; narrowed to `filter` when given. Caller owns the result.
GstCaps* rgbd_source_caps(GstPad* pad, const RgbdInfo* info, GstCaps* filter);

// A transform_caps or caps query's answer: `caps` narrowed to `filter` (when given), filter's order first.
// Takes ownership of `caps`; caller owns the result.
GstCaps* caps_narrowed(GstCaps* caps, GstCaps* filter);

// Caps for a stream (fixed). Caller owns the result.
GstCaps* rgbd_caps_new(const RgbdInfo& info);
// Parses fixed `video/x-rgbd` caps. On failure returns false and says which field is wrong.
bool rgbd_info_from_caps(const GstCaps* caps, RgbdInfo* info, std::string* error);
// Puts camera calibration fields into a caps structure (also used for video/x-raw hints).
void rgbd_structure_set_camera(GstStructure* s, const CameraCalib& cam);

// Layout of plane `i` of `buf`: from its GstVideoMeta (id = i) when present,
// else the default packed layout. Fails when the buffer is too small.
bool rgbd_plane_layout(GstBuffer* buf, const RgbdInfo& info, size_t i, PlaneLayout* out, std::string* error);
// Layout of a plain single-plane video/x-raw buffer.
PlaneLayout raw_plane_layout(GstBuffer* buf, int width, int height, GstVideoFormat fmt);

// A new buffer with one GstMemory and one GstVideoMeta per plane (contents uninitialised).
GstBuffer* rgbd_buffer_new(const RgbdInfo& info);
// A new rgbd buffer whose plane i shares the memory of parts[i] at layouts[i] (no copy).
// parts.size() must equal info.planes.size(). Timestamps are not copied.
GstBuffer* rgbd_buffer_assemble(const RgbdInfo& info, const std::vector<GstBuffer*>& parts,
                                const std::vector<PlaneLayout>& layouts);
// An output buffer that is the input with one plane new (replaced or added)
// and every other plane sharing the input's memory: for elements that compute
// one plane (depthcomplete, planerefine: depth; learnerseg: labels). The new
// plane is allocated at construction and mapped writable as `mat`.
class RgbdPlaneOutput {
 public:
  RgbdPlaneOutput(const RgbdInfo& out_info, Plane plane);
  ~RgbdPlaneOutput();
  RgbdPlaneOutput(const RgbdPlaneOutput&) = delete;
  RgbdPlaneOutput& operator=(const RgbdPlaneOutput&) = delete;
  cv::Mat mat;  // the new plane; empty when it could not be allocated
  // The output buffer (planes of out_info): the new plane, the others from `in`
  // (described by in_info); flags and timestamps copied. nullptr and `error` on failure.
  GstBuffer* finish(GstBuffer* in, const RgbdInfo& in_info, std::string* error);

 private:
  RgbdInfo out_info_;
  Plane plane_;
  GstBuffer* buf_ = nullptr;
  GstMapInfo map_{};
  gint stride_ = 0;
  bool mapped_ = false;
};

// Adds GstVideoMeta for every plane of a packed buffer that has none.
void rgbd_buffer_add_default_metas(GstBuffer* buf, const RgbdInfo& info);

// Running time of a buffer queued on an aggregator pad (PTS, else DTS, in
// the pad's segment); GST_CLOCK_TIME_NONE when it has no timestamp.
GstClockTime aggregator_pad_running_time(GstAggregatorPad* pad, GstBuffer* buf);

// Maps the planes of an rgbd buffer as cv::Mat headers over the buffer's memory.
class RgbdFrame {
 public:
  RgbdFrame() = default;
  RgbdFrame(const RgbdFrame&) = delete;
  RgbdFrame& operator=(const RgbdFrame&) = delete;
  ~RgbdFrame() { unmap(); }

  // GST_MAP_WRITE needs a writable buffer. On failure nothing stays mapped.
  bool map(GstBuffer* buf, const RgbdInfo& info, GstMapFlags flags, std::string* error);
  void unmap();

  // Empty Mat when the plane is absent.
  cv::Mat plane(Plane p) const;
  cv::Mat color() const { return plane(Plane::Color); }
  cv::Mat depth() const { return plane(Plane::Depth); }
  cv::Mat label() const { return plane(Plane::Label); }

 private:
  struct Mapped {
    Plane plane;
    GstMemory* memory = nullptr;  // single-memory plane
    GstBuffer* buffer = nullptr;  // plane spanning several memories
    GstMapInfo info{};
    cv::Mat mat;
  };
  std::vector<Mapped> maps_;
};

// A new buffer of `info` (rgbd_buffer_new) with each given plane copied in; planes `info` does not carry are
// skipped, planes not given are left uninitialised. What the RGB-D sources make a frame with. nullptr and
// *error when the buffer cannot be mapped.
GstBuffer* rgbd_buffer_with_planes(const RgbdInfo& info, const std::vector<std::pair<Plane, cv::Mat>>& planes,
                                   std::string* error);

}  // namespace vclassroom
