/**
 * SECTION:element-rgbdlinkjoin
 * @title: rgbdlinkjoin
 *
 * The server side of the H.264 camera link (docs/network.md): after the H.264 decoder, joins each decoded
 * picture (I420, converted to RGB here, BT.601 as rgbdlinksplit made it: a videoconvert before it passes it
 * through; or RGB) with the depth and labels that came in its own access unit (the meta
 * rgbdlinkdemux attached) into one video/x-rgbd frame, with the camera's calibration in the caps. The depth
 * is decoded here, with the depth frames before it that no picture took: a leaky queue before this element
 * (as pipelines/server.sh has, in a low-priority thread) spares the conversion and most of the depth decoding
 * of the pictures it drops (docs/network.md, "Decoding the depth where the picture is used"). It counts as
 * the codecs do (`frames`: joined, `frames-dropped`, a vclassroom-codec-stats message every `stats-interval`;
 * its `bytes` stay 0: rgbdlinkdemux counts the coded bytes). Colour is
 * never joined with another instant's depth: a picture without its depth (lost, damaged, or awaiting a depth
 * key frame), or whose meta was made for another timestamp, is dropped with a rate-limited warning.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=30 ! rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! x264enc tune=zerolatency speed-preset=ultrafast ! video/x-h264,profile=constrained-baseline ! rgbdlinkmux ! rgbdlinkdemux ! avdec_h264 max-threads=1 ! videoconvert ! rgbdlinkjoin ! rgbddemux name=d d.depth ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbdlinkjoin.h"

#include <string>
#include <utility>
#include <vector>

#include <gst/video/video.h>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/net/colour_i420.h>
#include <gst/vclassroom/net/depth_link_backlog.h>
#include <gst/vclassroom/core/warning_limiter.h>

#include "rgbdcoded.h"
#include "rgbdlinkmeta.h"

GST_DEBUG_CATEGORY_STATIC(rgbd_link_join_debug);
#define GST_CAT_DEFAULT rgbd_link_join_debug

using namespace vclassroom;

struct _GstRgbdLinkJoin {
  GstElement parent;
  GstPad* sinkpad;
  GstPad* srcpad;
  CodecStats stats;  // object lock
  // Streaming thread only:
  GstVideoInfo vinfo;
  gboolean have_vinfo;
  GstCaps* out_caps;
  GstEvent* pending_segment;  // held until the first joined caps are out (sticky event order)
  RgbdInfo* info;
  WarningLimiter* warnings;
};

G_DEFINE_TYPE(GstRgbdLinkJoin, gst_rgbd_link_join, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(rgbdlinkjoin, "rgbdlinkjoin", GST_RANK_NONE, GST_TYPE_RGBD_LINK_JOIN)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("video/x-raw, format=(string){ I420, RGB }"));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static void drop_picture(GstRgbdLinkJoin* self, const std::string& why) {
  const guint64 dropped = codec_stats_drop(GST_ELEMENT(self), &self->stats, DropKind::Damaged).dropped;
  uint64_t count = 0;
  int64_t span = 0;
  if (!self->warnings->note(g_get_monotonic_time() * 1000, &count, &span)) return;
  warn_dropped(GST_ELEMENT(self), count, span, "a picture", "pictures", "", why, dropped, "pictures");
}

// The joined frame of picture `in` and its meta; nullptr with `why` when they do not belong together.
static GstBuffer* join(GstRgbdLinkJoin* self, GstBuffer* in, GstRgbdLinkMeta* meta, std::string* why) {
  if (GST_CLOCK_TIME_IS_VALID(meta->pts) && GST_BUFFER_PTS(in) != meta->pts) {
    *why = "a picture whose depth was made for another timestamp";
    return nullptr;
  }
  // The depth's caps parsed when they change, and kept only once a picture fits them.
  const bool new_caps = !self->out_caps || !gst_caps_is_equal(self->out_caps, meta->caps);
  RgbdInfo parsed;
  if (new_caps && !rgbd_info_from_caps(meta->caps, &parsed, why)) return nullptr;
  const RgbdInfo& info = new_caps ? parsed : *self->info;
  // Every picture, not only when the depth's caps change: a new picture size (a new SPS) under the same depth
  // caps would otherwise be read at the depth's size, past the picture's planes.
  if (info.width() != GST_VIDEO_INFO_WIDTH(&self->vinfo) || info.height() != GST_VIDEO_INFO_HEIGHT(&self->vinfo)) {
    *why = "the colour picture and the depth differ in size";
    return nullptr;
  }
  if (new_caps) {
    *self->info = parsed;
    gst_caps_replace(&self->out_caps, meta->caps);
    gst_pad_push_event(self->srcpad, gst_event_new_caps(meta->caps));
    if (self->pending_segment) {
      gst_pad_push_event(self->srcpad, self->pending_segment);
      self->pending_segment = nullptr;
    }
  }
  const int w = self->info->width(), h = self->info->height();
  DepthLinkFrame depth;
  if (!(*meta->backlog)->take(meta->id, &depth, why)) return nullptr;
  const bool labels = self->info->has(Plane::Label);
  if (depth.depth.cols != w || depth.depth.rows != h || labels == depth.label.empty()) {
    *why = "the depth frame does not fit the caps";
    return nullptr;
  }
  GstVideoFrame vf;
  if (!gst_video_frame_map(&vf, &self->vinfo, in, GST_MAP_READ)) {
    *why = "cannot map the picture";
    return nullptr;
  }
  const bool i420 = GST_VIDEO_FRAME_FORMAT(&vf) == GST_VIDEO_FORMAT_I420;
  std::vector<std::pair<Plane, cv::Mat>> planes = {{Plane::Depth, depth.depth}};
  if (!i420)
    planes.emplace_back(Plane::Color, cv::Mat(h, w, CV_8UC3, GST_VIDEO_FRAME_PLANE_DATA(&vf, 0),
                                              GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0)));
  if (labels) planes.emplace_back(Plane::Label, depth.label);
  GstBuffer* out = rgbd_buffer_with_planes(*self->info, planes, why);
  if (out && i420) {  // the colour converted right into the frame's plane
    RgbdFrame frame;
    if (frame.map(out, *self->info, GST_MAP_WRITE, why)) {
      cv::Mat rgb = frame.color();
      auto plane = [&](int p) { return static_cast<const uint8_t*>(GST_VIDEO_FRAME_PLANE_DATA(&vf, p)); };
      i420_to_rgb(plane(0), GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0), plane(1), GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 1),
                  plane(2), GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 2), w, h, rgb.data, int(rgb.step));
    } else {
      gst_buffer_unref(out);
      out = nullptr;
    }
  }
  gst_video_frame_unmap(&vf);
  if (out) gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  return out;
}

static GstFlowReturn gst_rgbd_link_join_chain(GstPad*, GstObject* parent, GstBuffer* in) {
  GstRgbdLinkJoin* self = GST_RGBD_LINK_JOIN(parent);
  if (!self->have_vinfo) {
    gst_buffer_unref(in);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  GstRgbdLinkMeta* meta = gst_buffer_get_rgbd_link_meta(in);
  std::string why = "a picture without its depth (lost, damaged or awaiting a depth key frame)";
  GstBuffer* out = meta && meta->backlog ? join(self, in, meta, &why) : nullptr;
  gst_buffer_unref(in);
  if (!out) {
    drop_picture(self, why);
    return GST_FLOW_OK;
  }
  codec_stats_count(GST_ELEMENT(self), &self->stats, 0, false);
  return gst_pad_push(self->srcpad, out);
}

static gboolean gst_rgbd_link_join_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  GstRgbdLinkJoin* self = GST_RGBD_LINK_JOIN(parent);
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    self->have_vinfo = gst_video_info_from_caps(&self->vinfo, caps);
    // The conversion back is BT.601's, as rgbdlinksplit made it; another matrix would come out in the wrong
    // colours (a stream converted by something else, a decoder that reads BT.709 from the stream).
    if (self->have_vinfo && GST_VIDEO_INFO_FORMAT(&self->vinfo) == GST_VIDEO_FORMAT_I420 &&
        GST_VIDEO_INFO_COLORIMETRY(&self->vinfo).matrix != GST_VIDEO_COLOR_MATRIX_BT601 &&
        GST_VIDEO_INFO_COLORIMETRY(&self->vinfo).matrix != GST_VIDEO_COLOR_MATRIX_UNKNOWN)
      GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("I420 pictures that are not BT.601"),
                          ("the colours are converted as BT.601 (rgbdlinksplit's); these caps say otherwise"));
    gst_event_unref(event);  // the joined caps come with the first joined frame
    return self->have_vinfo;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_SEGMENT && !self->out_caps) {
    gst_event_replace(&self->pending_segment, event);
    gst_event_unref(event);
    return TRUE;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_FLUSH_STOP || GST_EVENT_TYPE(event) == GST_EVENT_EOS)
    gst_event_replace(&self->pending_segment, nullptr);
  if (GST_EVENT_TYPE(event) == GST_EVENT_EOS) codec_stats_post(GST_ELEMENT(self), &self->stats);
  return gst_pad_event_default(pad, parent, event);
}

static GstStateChangeReturn gst_rgbd_link_join_change_state(GstElement* element, GstStateChange transition) {
  GstRgbdLinkJoin* self = GST_RGBD_LINK_JOIN(element);
  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {
    gst_caps_replace(&self->out_caps, nullptr);
    gst_event_replace(&self->pending_segment, nullptr);
    self->have_vinfo = FALSE;
    self->warnings->reset();
    GST_OBJECT_LOCK(self);
    self->stats = CodecStats{0, 0, 0, self->stats.interval};
    GST_OBJECT_UNLOCK(self);
  }
  return GST_ELEMENT_CLASS(gst_rgbd_link_join_parent_class)->change_state(element, transition);
}

static void gst_rgbd_link_join_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  if (!codec_stats_set_property(GST_OBJECT(object), &GST_RGBD_LINK_JOIN(object)->stats, prop_id, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
}

static void gst_rgbd_link_join_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  if (!codec_stats_get_property(GST_OBJECT(object), GST_RGBD_LINK_JOIN(object)->stats, prop_id, value))
    G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
}

static void gst_rgbd_link_join_finalize(GObject* object) {
  GstRgbdLinkJoin* self = GST_RGBD_LINK_JOIN(object);
  gst_caps_replace(&self->out_caps, nullptr);
  gst_event_replace(&self->pending_segment, nullptr);
  delete self->info;
  delete self->warnings;
  G_OBJECT_CLASS(gst_rgbd_link_join_parent_class)->finalize(object);
}

static void gst_rgbd_link_join_class_init(GstRgbdLinkJoinClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->set_property = gst_rgbd_link_join_set_property;
  gobject_class->get_property = gst_rgbd_link_join_get_property;
  gobject_class->finalize = gst_rgbd_link_join_finalize;
  codec_stats_install_properties(gobject_class, "RGB-D frames joined (their depth decoded) since the element started");
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D camera link joiner", "Filter/Converter/Video",
      "Joins each decoded picture with the depth its own access unit carried into a video/x-rgbd frame",
      "gst-vclassroom developers");
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_rgbd_link_join_change_state);
  GST_DEBUG_CATEGORY_INIT(rgbd_link_join_debug, "rgbdlinkjoin", 0, "RGB-D camera link joiner");
}

static void gst_rgbd_link_join_init(GstRgbdLinkJoin* self) {
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_rgbd_link_join_chain));
  gst_pad_set_event_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_rgbd_link_join_sink_event));
  GST_PAD_SET_PROXY_ALLOCATION(self->sinkpad);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
  gst_pad_use_fixed_caps(self->srcpad);
  gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
  self->stats = CodecStats();
  self->have_vinfo = FALSE;
  self->out_caps = nullptr;
  self->pending_segment = nullptr;
  self->info = new RgbdInfo();
  self->warnings = new WarningLimiter();
}
