// rgbdsrc's streaming thread: the camera's paired frames as buffers, what was lost on the way, and waiting
// for a camera that went away.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdsrc_state.h"

namespace vclassroom {

void rgbd_src_post_capture_error(GstElement* self, const CaptureError& e) {
  switch (e.kind()) {
    case CaptureError::Kind::kNoDevice:
      GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("%s", e.what()), (nullptr));
      break;
    case CaptureError::Kind::kBusy:
      GST_ELEMENT_ERROR(self, RESOURCE, BUSY, ("%s", e.what()), (nullptr));
      break;
    case CaptureError::Kind::kNotCapture:
    case CaptureError::Kind::kUnsupported:
      GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("%s", e.what()), (nullptr));
      break;
    case CaptureError::Kind::kVanished:
    case CaptureError::Kind::kIo:
      GST_ELEMENT_ERROR(self, RESOURCE, READ, ("%s", e.what()), (nullptr));
      break;
  }
}

// CLOCK_MONOTONIC, the kernel's capture clock (GLib reads the same one).
static int64_t monotonic_ns() { return g_get_monotonic_time() * 1000; }

// Counts what a round lost; damaged frames get a rate-limited warning.
static void note_losses(GstElement* self, RgbdSrcState* st, const RgbdCamera::Losses& losses) {
  if (losses.unpaired == 0 && losses.damaged.empty()) return;
  {
    std::lock_guard<std::mutex> g(st->lock);
    st->unpaired += losses.unpaired;
    st->damaged += losses.damaged.size();
  }
  for (const std::string& why : losses.damaged) {
    uint64_t count = 0;
    int64_t span = 0;
    if (st->damaged_warnings.note(monotonic_ns(), &count, &span))
      GST_ELEMENT_WARNING(self, STREAM, DECODE,
                          ("%s", describe_occurrences(count, "a damaged frame dropped", "damaged frames dropped",
                                                      st->camera->color_path() + " / " + st->camera->depth_path(), span)
                                     .c_str()),
                          ("the last: %s", why.c_str()));
  }
}

// The kernel's capture time (CLOCK_MONOTONIC) as this pipeline's running time.
static GstClockTime running_time_of(GstElement* self, int64_t capture_ns) {
  GstClock* clock = gst_element_get_clock(self);
  if (!clock) return GST_CLOCK_TIME_NONE;
  const int64_t offset = int64_t(gst_clock_get_time(clock)) - monotonic_ns();
  gst_object_unref(clock);
  const int64_t t = capture_ns + offset - int64_t(gst_element_get_base_time(self));
  return t < 0 ? 0 : GstClockTime(t);
}

// reconnect=true: the camera went away (unplugged); says so, then tries to
// open it again twice a second until it is back or the pipeline stops. Only
// this camera's branch waits: every camera has its own rgbdsrc and thread.
static bool wait_for_return(GstElement* self, RgbdSrcState* st, const CaptureError& why) {
  GST_ELEMENT_WARNING(self, RESOURCE, READ, ("%s; waiting for it to return", why.what()), ("reconnect=true"));
  while (!st->flushing) {
    try {
      st->camera->reopen();
      GST_ELEMENT_WARNING(self, RESOURCE, READ,
                          ("camera %s / %s returned", st->camera->color_path().c_str(), st->camera->depth_path().c_str()),
                          (nullptr));
      return true;
    } catch (const CaptureError&) {
      g_usleep(G_USEC_PER_SEC / 2);  // a device coming back is not announced here: look again
    }
  }
  return false;
}

GstFlowReturn rgbd_src_next_buffer(GstElement* self, RgbdSrcState* st, GstBuffer** outbuf) {
  for (;;) {
    if (st->flushing) return GST_FLOW_FLUSHING;
    RgbdCamera::Frame frame;
    RgbdCamera::Losses losses;
    bool got = false;
    try {
      // Wakes now and then to notice a flush (unlock) even when no frame comes.
      got = st->camera->next(100, &frame, &losses);
    } catch (const CaptureError& e) {
      note_losses(self, st, losses);
      if (e.kind() == CaptureError::Kind::kIo) {
        // One frame the driver could not deliver: the stream goes on.
        GST_ELEMENT_WARNING(self, RESOURCE, READ, ("%s", e.what()), ("the frame is dropped"));
        continue;
      }
      bool reconnect;
      {
        std::lock_guard<std::mutex> g(st->lock);
        reconnect = st->reconnect;
      }
      if (e.kind() != CaptureError::Kind::kVanished || !reconnect) {
        rgbd_src_post_capture_error(self, e);
        return GST_FLOW_ERROR;
      }
      if (!wait_for_return(self, st, e)) return GST_FLOW_FLUSHING;
      continue;
    }
    note_losses(self, st, losses);
    if (!got) continue;
    std::string err;
    GstBuffer* buf =
        rgbd_buffer_with_planes(st->info, {{Plane::Color, frame.color}, {Plane::Depth, frame.depth}}, &err);
    if (!buf) {
      GST_ELEMENT_ERROR(self, CORE, FAILED, ("%s", err.c_str()), (nullptr));
      return GST_FLOW_ERROR;
    }
    GST_BUFFER_PTS(buf) = running_time_of(self, frame.capture_ns);
    GST_BUFFER_DURATION(buf) = st->info.frame_duration();
    *outbuf = buf;
    return GST_FLOW_OK;
  }
}

}  // namespace vclassroom
