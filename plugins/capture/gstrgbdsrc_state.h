// rgbdsrc's private state, shared by the element (gstrgbdsrc.cpp: properties, start and stop, caps) and its
// streaming thread (gstrgbdsrc_capture.cpp: frames, losses, reconnecting), so that neither file mixes the
// two. Not installed.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>

#include <gst/gst.h>

#include <gst/vclassroom/capture/rgbd_camera.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/warning_limiter.h>

namespace vclassroom {

inline constexpr guint64 kRgbdSrcDefaultMaxSkew = 10 * GST_MSECOND;

struct RgbdSrcState {
  std::mutex lock;  // the properties and the counters
  std::string color_device, depth_device, rig_path;
  int camera_id = 0;
  guint64 max_skew = kRgbdSrcDefaultMaxSkew;
  int fps_n = 30, fps_d = 1;
  bool reconnect = false;
  guint64 unpaired = 0, damaged = 0;

  // Streaming thread (and start/stop).
  RgbdInfo info;
  std::unique_ptr<RgbdCamera> camera;
  WarningLimiter damaged_warnings;
  std::atomic<bool> flushing{false};
};

// Posts a CaptureError on `element`'s bus as the error a person can act on.
void rgbd_src_post_capture_error(GstElement* element, const CaptureError& e);
// The next paired frame as a buffer stamped with its capture time in running time (create's work): losses
// counted and warned about, a lost frame skipped, a vanished camera waited for with reconnect.
GstFlowReturn rgbd_src_next_buffer(GstElement* element, RgbdSrcState* st, GstBuffer** outbuf);

}  // namespace vclassroom
