/**
 * SECTION:element-rgbddemux
 * @title: rgbddemux
 *
 * Splits video/x-rgbd into plain video/x-raw: color (RGB), depth (GRAY16_LE, mm), and, when the stream has
 * them, label (GRAY8 learner ids), weight (GRAY8) and depth-gt (GRAY16_LE ground truth). Zero copy.
 * Upstream events (pose, QoS, navigation) from any output go back to the single input.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! rgbddemux name=d d.color ! queue ! videoconvert ! fakesink d.depth ! queue ! depthcolorize ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbddemux.h"

#include <gst/base/gstflowcombiner.h>
#include <gst/video/video.h>

#include <array>
#include <string>
#include <vector>

#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_demux_debug);
#define GST_CAT_DEFAULT rgbd_demux_debug

using namespace vclassroom;

namespace {
constexpr Plane kAllPlanes[] = {Plane::Color, Plane::Depth, Plane::Label, Plane::Weight, Plane::DepthGT};
constexpr size_t kPlaneCount = G_N_ELEMENTS(kAllPlanes);

size_t slot_of(Plane p) {
  for (size_t i = 0; i < kPlaneCount; ++i)
    if (kAllPlanes[i] == p) return i;
  return 0;
}
}  // namespace

struct _GstRgbdDemux {
  GstElement parent;
  GstPad* sinkpad;
  std::array<GstPad*, kPlaneCount> srcpads;  // by slot; null until the plane appears
  GstFlowCombiner* flow;
  RgbdInfo* info;
  gboolean have_info;
};

G_DEFINE_TYPE(GstRgbdDemux, gst_rgbd_demux, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(rgbddemux, "rgbddemux", GST_RANK_NONE, GST_TYPE_RGBD_DEMUX)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate color_template = GST_STATIC_PAD_TEMPLATE(
    "color", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGB")));
static GstStaticPadTemplate depth_template = GST_STATIC_PAD_TEMPLATE(
    "depth", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY16_LE")));
static GstStaticPadTemplate label_template = GST_STATIC_PAD_TEMPLATE(
    "label", GST_PAD_SRC, GST_PAD_SOMETIMES, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY8")));
static GstStaticPadTemplate weight_template = GST_STATIC_PAD_TEMPLATE(
    "weight", GST_PAD_SRC, GST_PAD_SOMETIMES, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY8")));
static GstStaticPadTemplate depth_gt_template = GST_STATIC_PAD_TEMPLATE(
    "depth-gt", GST_PAD_SRC, GST_PAD_SOMETIMES, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("GRAY16_LE")));

static GstPad* make_src_pad(GstRgbdDemux* self, Plane p) {
  GstPadTemplate* templ = gst_element_class_get_pad_template(GST_ELEMENT_GET_CLASS(self), plane_name(p));
  GstPad* pad = gst_pad_new_from_template(templ, plane_name(p));
  gst_pad_use_fixed_caps(pad);
  return pad;
}

static gboolean copy_sticky(GstPad*, GstEvent** event, gpointer user_data) {
  GstPad* to = static_cast<GstPad*>(user_data);
  // Caps differ per output and are set separately.
  if (GST_EVENT_TYPE(*event) != GST_EVENT_CAPS && GST_EVENT_TYPE(*event) != GST_EVENT_EOS)
    gst_pad_push_event(to, gst_event_ref(*event));
  return TRUE;
}

static gboolean set_output_caps(GstRgbdDemux* self, const RgbdInfo& info) {
  for (Plane p : info.planes) {
    const size_t slot = slot_of(p);
    GstPad* pad = self->srcpads[slot];
    if (!pad) {
      pad = make_src_pad(self, p);
      self->srcpads[slot] = pad;
      gst_pad_set_active(pad, TRUE);
      gst_element_add_pad(GST_ELEMENT(self), pad);
      gst_flow_combiner_add_pad(self->flow, pad);
      gst_pad_sticky_events_foreach(self->sinkpad, copy_sticky, pad);
    }
    GstVideoInfo vi;
    gst_video_info_set_format(&vi, plane_format(p), info.width(), info.height());
    GST_VIDEO_INFO_FPS_N(&vi) = info.fps_n;
    GST_VIDEO_INFO_FPS_D(&vi) = info.fps_d;
    GstCaps* caps = gst_video_info_to_caps(&vi);
    // Let a plain-video consumer still see which camera this is.
    gst_caps_set_simple(caps, "camera-id", G_TYPE_INT, info.camera.id, nullptr);
    const gboolean ok = gst_pad_push_event(pad, gst_event_new_caps(caps)) || !gst_pad_is_linked(pad);
    gst_caps_unref(caps);
    if (!ok) return FALSE;
  }
  gst_element_no_more_pads(GST_ELEMENT(self));
  return TRUE;
}

static GstFlowReturn gst_rgbd_demux_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  GstRgbdDemux* self = GST_RGBD_DEMUX(parent);
  if (!self->have_info) {
    gst_buffer_unref(buf);
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("buffer before caps"), (nullptr));
    return GST_FLOW_NOT_NEGOTIATED;
  }
  const RgbdInfo& info = *self->info;
  // Check every plane first: a frame goes out whole on every pad or not at all.
  std::vector<PlaneLayout> layouts(info.planes.size());
  for (size_t i = 0; i < info.planes.size(); ++i) {
    std::string err;
    if (!rgbd_plane_layout(buf, info, i, &layouts[i], &err)) {
      GST_ELEMENT_WARNING(self, STREAM, DECODE, ("dropping corrupt frame: %s", err.c_str()), (nullptr));
      gst_buffer_unref(buf);
      return GST_FLOW_OK;
    }
  }
  GstFlowReturn combined = GST_FLOW_OK;
  for (size_t i = 0; i < info.planes.size(); ++i) {
    const Plane p = info.planes[i];
    const PlaneLayout& l = layouts[i];
    GstVideoInfo vi;
    gst_video_info_set_format(&vi, plane_format(p), info.width(), info.height());
    const gint stride = GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0);
    GstBuffer* out;
    if (l.stride == stride) {
      const gsize size = std::min<gsize>(GST_VIDEO_INFO_SIZE(&vi), gst_buffer_get_size(buf) - l.offset);
      out = gst_buffer_copy_region(buf, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS |
                                                           GST_BUFFER_COPY_MEMORY),
                                   l.offset, size);
      if (size < GST_VIDEO_INFO_SIZE(&vi)) {
        // The last row needs no stride padding; give consumers a full-size buffer.
        gst_buffer_append_memory(out, gst_allocator_alloc(nullptr, GST_VIDEO_INFO_SIZE(&vi) - size, nullptr));
      }
    } else {
      // Padded rows upstream: repack to the default stride plain video expects.
      out = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&vi), nullptr);
      gst_buffer_copy_into(out, buf, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
      GstMapInfo src, dst;
      gst_buffer_map(buf, &src, GST_MAP_READ);
      gst_buffer_map(out, &dst, GST_MAP_WRITE);
      const gsize row = static_cast<gsize>(GST_VIDEO_INFO_COMP_PSTRIDE(&vi, 0)) * info.width();
      for (int y = 0; y < info.height(); ++y)
        memcpy(dst.data + static_cast<gsize>(y) * stride, src.data + l.offset + static_cast<gsize>(y) * l.stride, row);
      gst_buffer_unmap(out, &dst);
      gst_buffer_unmap(buf, &src);
    }
    // copy_region keeps timestamps only at offset 0.
    GST_BUFFER_PTS(out) = GST_BUFFER_PTS(buf);
    GST_BUFFER_DTS(out) = GST_BUFFER_DTS(buf);
    GST_BUFFER_DURATION(out) = GST_BUFFER_DURATION(buf);
    GST_BUFFER_OFFSET(out) = GST_BUFFER_OFFSET(buf);
    GST_BUFFER_OFFSET_END(out) = GST_BUFFER_OFFSET_END(buf);
    GstPad* pad = self->srcpads[slot_of(p)];
    const GstFlowReturn r = gst_pad_push(pad, out);
    combined = gst_flow_combiner_update_pad_flow(self->flow, pad, r);
  }
  gst_buffer_unref(buf);
  return combined;
}

static gboolean gst_rgbd_demux_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  GstRgbdDemux* self = GST_RGBD_DEMUX(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_CAPS: {
      GstCaps* caps;
      gst_event_parse_caps(event, &caps);
      std::string err;
      RgbdInfo info;
      if (!rgbd_info_from_caps(caps, &info, &err)) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), ("caps: %" GST_PTR_FORMAT, caps));
        gst_event_unref(event);
        return FALSE;
      }
      *self->info = info;
      self->have_info = TRUE;
      gst_event_unref(event);
      return set_output_caps(self, info);
    }
    case GST_EVENT_FLUSH_STOP:
      gst_flow_combiner_reset(self->flow);
      break;
    default:
      break;
  }
  return gst_pad_event_default(pad, parent, event);
}

static GstStateChangeReturn gst_rgbd_demux_change_state(GstElement* element, GstStateChange transition) {
  GstRgbdDemux* self = GST_RGBD_DEMUX(element);
  GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_rgbd_demux_parent_class)->change_state(element, transition);
  if (transition == GST_STATE_CHANGE_PAUSED_TO_READY) {
    self->have_info = FALSE;
    gst_flow_combiner_reset(self->flow);
  }
  return ret;
}

static void gst_rgbd_demux_finalize(GObject* object) {
  GstRgbdDemux* self = GST_RGBD_DEMUX(object);
  gst_flow_combiner_free(self->flow);
  delete self->info;
  G_OBJECT_CLASS(gst_rgbd_demux_parent_class)->finalize(object);
}

static void gst_rgbd_demux_class_init(GstRgbdDemuxClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gobject_class->finalize = gst_rgbd_demux_finalize;
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_rgbd_demux_change_state);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &color_template);
  gst_element_class_add_static_pad_template(element_class, &depth_template);
  gst_element_class_add_static_pad_template(element_class, &label_template);
  gst_element_class_add_static_pad_template(element_class, &weight_template);
  gst_element_class_add_static_pad_template(element_class, &depth_gt_template);
  gst_element_class_set_static_metadata(element_class, "RGB-D demuxer", "Demuxer/Video",
      "Splits an RGB-D stream into one raw video stream per plane", "gst-vclassroom developers");
  GST_DEBUG_CATEGORY_INIT(rgbd_demux_debug, "rgbddemux", 0, "RGB-D demuxer");
}

static void gst_rgbd_demux_init(GstRgbdDemux* self) {
  self->info = new RgbdInfo();
  self->have_info = FALSE;
  self->flow = gst_flow_combiner_new();
  self->srcpads.fill(nullptr);
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_rgbd_demux_chain));
  gst_pad_set_event_function(self->sinkpad, GST_DEBUG_FUNCPTR(gst_rgbd_demux_sink_event));
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  for (Plane p : {Plane::Color, Plane::Depth}) {
    GstPad* pad = make_src_pad(self, p);
    self->srcpads[slot_of(p)] = pad;
    gst_element_add_pad(GST_ELEMENT(self), pad);
    gst_flow_combiner_add_pad(self->flow, pad);
  }
}
