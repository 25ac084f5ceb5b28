// One V4L2 capture node (a colour or a depth stream of an RGB-D camera):
// opening, what it offers, setting a format, memory-mapped streaming and
// capture timestamps. Everything the driver says is checked before use (a
// buffer index, a byte count). Errors are CaptureError, the project's Error
// with a kind, so rgbdsrc can say "no such device" apart from "device busy".
// GStreamer-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

class CaptureError : public Error {
 public:
  enum class Kind { kNoDevice, kBusy, kNotCapture, kUnsupported, kVanished, kIo };
  CaptureError(Kind kind, const std::string& what) : Error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// One format, size and rate the device offers.
struct CaptureMode {
  CapturePixelFormat format;
  int width = 0, height = 0;
  int fps_n = 0, fps_d = 1;  // 0/1: the driver did not say
};
std::string describe_modes(const std::vector<CaptureMode>& modes);

// A frame the driver filled; valid until released.
struct CapturedFrame {
  uint32_t index = 0;
  const uint8_t* data = nullptr;
  size_t bytesused = 0;
  size_t stride = 0;         // bytes per line, 0 for compressed formats
  int64_t timestamp_ns = 0;  // the kernel's capture time, CLOCK_MONOTONIC
  uint32_t sequence = 0;     // the driver's frame counter (gaps: frames it dropped)
};

class V4l2Device {
 public:
  // `path`: a device node or a /dev/v4l/by-id name. Throws CaptureError
  // (kNoDevice, kBusy, kNotCapture).
  explicit V4l2Device(const std::string& path);
  ~V4l2Device();
  V4l2Device(const V4l2Device&) = delete;
  V4l2Device& operator=(const V4l2Device&) = delete;

  const std::string& path() const { return path_; }
  // What the driver calls the device ("Intel RealSense D435") and where it
  // sits ("usb-0000:00:14.0-2"): the colour and depth nodes of one camera
  // share the bus.
  const std::string& card() const { return card_; }
  const std::string& bus() const { return bus_; }
  const CaptureMode& mode() const { return mode_; }
  int fd() const { return fd_; }
  // The formats rgbdsrc understands, with their discrete sizes and rates.
  std::vector<CaptureMode> modes();
  // Sets the format, size and rate; kUnsupported (naming what the device
  // offers) when the driver does not take them as asked.
  void set_mode(const CaptureMode& mode);
  // Maps `buffers` buffers, queues them and starts streaming.
  void start(unsigned buffers = 4);
  // Takes the next filled frame; false when none came within timeout_ms.
  // kVanished when the device went away (unplugged), kIo on a driver error.
  bool next_frame(int timeout_ms, CapturedFrame* frame);
  // Hands the frame's buffer back to the driver.
  void release(const CapturedFrame& frame);
  void stop();

 private:
  struct Mapping {
    void* start = nullptr;
    size_t length = 0;
  };
  [[noreturn]] void fail(const std::string& what, int err);
  std::string path_, card_, bus_;
  int fd_ = -1;
  CaptureMode mode_{};
  size_t stride_ = 0;
  std::vector<Mapping> buffers_;
  bool streaming_ = false;
};

// One RGB-D camera found on the machine: a node offering depth and a node
// offering colour on the same bus, with the sizes both offer.
struct RgbdCameraNodes {
  std::string name, bus, color_path, depth_path;
  std::vector<std::pair<int, int>> sizes;  // offered by both nodes
};
// Opens each of `paths` (e.g. /dev/video0 … /dev/video63; missing ones are
// skipped) and groups colour and depth nodes by bus. Never throws: a node
// that cannot be opened is left out.
std::vector<RgbdCameraNodes> find_rgbd_cameras(const std::vector<std::string>& paths);

}  // namespace vclassroom
