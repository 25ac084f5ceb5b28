// GstRgbdFilter: the base class of the elements that take one camera's stream and give it back changed
// (depthcomplete, planerefine, learnerseg, viewprep, rgbddec, viewwarp), as GstVideoFilter is for video/x-raw.
// It owns what each of them wrote by hand: the caps parsed into RgbdInfo and the planes the subclass needs
// checked at negotiation, the buffers mapped as RgbdFrame, the library's errors (vclassroom::Error,
// cv::Exception) turned into bus errors in one place, frames that cannot be used dropped with a rate-limited
// warning, and a lock for the subclass's properties.
//
// A subclass picks its kind of work by the virtual method it sets:
// - transform_plane: the output is the input with one plane new (`new_plane`), written by the subclass;
//   every other plane shares the input's memory (no copy).
// - transform_frame_ip: the frame passes in place, its planes only read (the subclass may add metas).
// - neither: the subclass does its own buffer work (rgbddec decodes video/x-rgbd-coded, viewwarp makes
//   another camera's frame) and still gets the parsed caps, the error guard and the drop warnings.
#pragma once

#include <functional>
#include <mutex>
#include <string>

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rgbd.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_FILTER (gst_rgbd_filter_get_type())
G_DECLARE_DERIVABLE_TYPE(GstRgbdFilter, gst_rgbd_filter, GST, RGBD_FILTER, GstBaseTransform)

struct _GstRgbdFilterClass {
  GstBaseTransformClass parent_class;

  // Planes the input must carry (rgbd_plane_bit(Plane::Depth) | ...): caps without them are refused at
  // negotiation with a message naming what the stream has.
  guint required_planes;
  // For transform_plane: the plane the subclass writes (added when the input lacks it).
  vclassroom::Plane new_plane;

  // Caps accepted: `in` (for a video/x-rgbd-coded input, its fields as video/x-rgbd) and `out`. May throw
  // vclassroom::Error (a setting's file that cannot be read: a bus error) or call
  // gst_rgbd_filter_refuse_stream. FALSE (after posting an error) fails the negotiation.
  gboolean (*set_info)(GstRgbdFilter* self, const vclassroom::RgbdInfo& in, const vclassroom::RgbdInfo& out);
  // Writes the new plane (`plane`: the out caps' size and type) from the input frame.
  void (*transform_plane)(GstRgbdFilter* self, const vclassroom::RgbdFrame& in, cv::Mat& plane);
  // Reads the frame; `buffer` is writable for metas.
  void (*transform_frame_ip)(GstRgbdFilter* self, GstBuffer* buffer, const vclassroom::RgbdFrame& frame);

  gpointer padding[GST_PADDING];
};

G_END_DECLS

namespace vclassroom {

constexpr guint rgbd_plane_bit(Plane p) { return 1u << static_cast<unsigned>(p); }

// The negotiated caps (valid once set_info has been called; streaming thread).
const RgbdInfo& rgbd_filter_in_info(GstRgbdFilter* self);
const RgbdInfo& rgbd_filter_out_info(GstRgbdFilter* self);
bool rgbd_filter_negotiated(GstRgbdFilter* self);

// The lock of the subclass's properties: set_property and get_property take it; the streaming thread reads
// a consistent copy of the settings once per frame with rgbd_filter_settings.
std::unique_lock<std::mutex> rgbd_filter_lock(GstRgbdFilter* self);
template <class Settings>
Settings rgbd_filter_settings(GstRgbdFilter* self, const Settings& settings) {
  const auto lock = rgbd_filter_lock(self);
  return settings;
}

// Runs `work` and turns what the library throws into a bus error naming the element
// (GST_FLOW_ERROR, or FALSE for a setup step): the one place where that happens.
GstFlowReturn rgbd_filter_guard(GstRgbdFilter* self, const std::function<GstFlowReturn()>& work);
bool rgbd_filter_guard_setup(GstRgbdFilter* self, const char* what, const std::function<bool()>& work);

// From set_info: the stream cannot be served (another camera or size than the settings'; caps come from the
// network, so this is the sender's fault). Its frames are dropped with a rate-limited warning saying `why`,
// the other cameras go on. "" serves it again.
void rgbd_filter_refuse_stream(GstRgbdFilter* self, const std::string& why);

// Drops a frame that cannot be used (`why`), posting a warning when the rate limit lets one through
// ("name: dropped 3 frames from camera 2 in the last 5 s; why"). GST_BASE_TRANSFORM_FLOW_DROPPED.
GstFlowReturn rgbd_filter_drop_frame(GstRgbdFilter* self, const std::string& why);

}  // namespace vclassroom
