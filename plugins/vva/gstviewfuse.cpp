// viewfuse: fuses the cameras warped to the virtual view (one viewwarp per
// camera on request pads cam_%u) into the lecturer's video/x-raw RGB picture
// (V-VA step 3, docs/vva.md). Forwards pose events to every input and can play
// a pose trace itself.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewfuse.h"

#include <gst/video/video.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/pose.h>
#include <gst/vclassroom/pose_meta.h>
#include <gst/vclassroom/rgbd.h>
#include <gst/vclassroom/view_fuse.h>

GST_DEBUG_CATEGORY_STATIC(view_fuse_debug);
#define GST_CAT_DEFAULT view_fuse_debug

using namespace vclassroom;

enum { PROP_0, PROP_POSE_TRACE, PROP_DEPTH_TOLERANCE, PROP_FILL_HOLES, PROP_FRAMES_FUSED, PROP_POSE_WINDOW };
constexpr guint64 kDefaultPoseWindow = 50 * GST_MSECOND;

namespace {

struct FuseState {
  std::mutex lock;  // guards the properties and pad_info
  std::string trace_path;
  FuseParams params;
  std::map<GstPad*, RgbdInfo> pad_info;
  guint64 frames = 0;
  guint64 pose_window = kDefaultPoseWindow;  // ns

  // Streaming thread only.
  std::vector<PoseSample> trace;
  size_t trace_next = 0;
  GstVideoInfo out_info{};
  bool have_out = false;
  FusedView fused;
  GstClockTime last_out = GST_CLOCK_TIME_NONE;  // running time of the last output frame
};

}  // namespace

struct _GstViewFuse {
  GstAggregator parent;
  FuseState* st;
};

G_DEFINE_TYPE(GstViewFuse, gst_view_fuse, GST_TYPE_AGGREGATOR)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "cam_%u", GST_PAD_SINK, GST_PAD_REQUEST,
    GST_STATIC_CAPS("video/x-rgbd, width = (int) [ 1, 16384 ], height = (int) [ 1, 16384 ], "
                    "framerate = (fraction) [ 0/1, 2147483647/1 ], planes = (string) \"color,depth,label,weight\""));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGB")));

// Sends a pose upstream to every camera branch.
static void forward_pose(GstViewFuse* self, GstEvent* event) {
  GstIterator* it = gst_element_iterate_sink_pads(GST_ELEMENT(self));
  GValue item = G_VALUE_INIT;
  bool done = false;
  while (!done) {
    switch (gst_iterator_next(it, &item)) {
      case GST_ITERATOR_OK: {
        GstPad* pad = GST_PAD(g_value_get_object(&item));
        gst_pad_push_event(pad, gst_event_ref(event));
        g_value_reset(&item);
        break;
      }
      case GST_ITERATOR_RESYNC:
        gst_iterator_resync(it);
        break;
      default:
        done = true;
    }
  }
  g_value_unset(&item);
  gst_iterator_free(it);
  gst_event_unref(event);
}

static gboolean gst_view_fuse_src_event(GstAggregator* agg, GstEvent* event) {
  if (is_pose_event(event)) {
    forward_pose(GST_VIEW_FUSE(agg), event);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->src_event(agg, event);
}

static gboolean gst_view_fuse_sink_event(GstAggregator* agg, GstAggregatorPad* pad, GstEvent* event) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    RgbdInfo info;
    std::string err;
    if (!rgbd_info_from_caps(caps, &info, &err)) {
      GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("pad %s: %s", GST_PAD_NAME(pad), err.c_str()), (nullptr));
      gst_event_unref(event);
      return FALSE;
    }
    {
      std::lock_guard<std::mutex> g(self->st->lock);
      for (const auto& [p, other] : self->st->pad_info)
        if (p != GST_PAD(pad) && (other.width() != info.width() || other.height() != info.height())) {
          GST_ELEMENT_ERROR(self, CORE, NEGOTIATION,
                            ("pad %s brings a %dx%d virtual view, another pad %dx%d: every viewwarp must render the "
                             "same virtual size",
                             GST_PAD_NAME(pad), info.width(), info.height(), other.width(), other.height()),
                            (nullptr));
          gst_event_unref(event);
          return FALSE;
        }
      self->st->pad_info[GST_PAD(pad)] = info;
    }
    gst_pad_mark_reconfigure(agg->srcpad);
    gst_event_unref(event);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->sink_event(agg, pad, event);
}

static GstFlowReturn gst_view_fuse_update_src_caps(GstAggregator* agg, GstCaps* downstream, GstCaps** ret) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  RgbdInfo info;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    if (self->st->pad_info.empty()) return GST_AGGREGATOR_FLOW_NEED_DATA;
    info = self->st->pad_info.begin()->second;
  }
  GstVideoInfo vi;
  gst_video_info_set_format(&vi, GST_VIDEO_FORMAT_RGB, info.width(), info.height());
  GST_VIDEO_INFO_FPS_N(&vi) = info.fps_n;
  GST_VIDEO_INFO_FPS_D(&vi) = info.fps_d;
  GstCaps* caps = gst_video_info_to_caps(&vi);
  if (!gst_caps_can_intersect(caps, downstream)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("downstream does not accept the fused view"),
                      ("ours: %" GST_PTR_FORMAT ", downstream: %" GST_PTR_FORMAT, caps, downstream));
    gst_caps_unref(caps);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  self->st->out_info = vi;
  self->st->have_out = true;
  *ret = caps;
  return GST_FLOW_OK;
}


static void send_trace_pose(GstViewFuse* self) {
  FuseState* st = self->st;
  if (st->trace.empty()) return;
  const size_t i = std::min(st->trace_next, st->trace.size() - 1);
  Pose pose = st->trace[i].pose;
  pose.seq = i + 1;
  pose.viewer_time_ns = g_get_monotonic_time() * 1000;
  ++st->trace_next;
  try {
    forward_pose(self, pose_event_new(pose));
  } catch (const Error& e) {
    GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("pose trace line %zu: %s", i + 1, e.what()), (nullptr));
  }
}

static GstFlowReturn gst_view_fuse_aggregate(GstAggregator* agg, gboolean timeout) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  FuseState* st = self->st;
  if (st->trace_next == 0) send_trace_pose(self);

  struct Input {
    GstAggregatorPad* pad = nullptr;
    GstBuffer* buf = nullptr;
    RgbdInfo info;
  };
  std::vector<Input> inputs;
  bool all_eos = true;
  GST_OBJECT_LOCK(agg);
  for (GList* l = GST_ELEMENT(agg)->sinkpads; l; l = l->next) {
    GstAggregatorPad* pad = GST_AGGREGATOR_PAD(l->data);
    GstBuffer* buf = gst_aggregator_pad_peek_buffer(pad);
    if (!gst_aggregator_pad_is_eos(pad) || buf) all_eos = false;
    if (buf) {
      Input in;
      in.pad = GST_AGGREGATOR_PAD(gst_object_ref(pad));
      in.buf = buf;
      inputs.push_back(std::move(in));
    }
  }
  GST_OBJECT_UNLOCK(agg);
  if (inputs.empty()) return all_eos ? GST_FLOW_EOS : GST_AGGREGATOR_FLOW_NEED_DATA;
  {
    std::lock_guard<std::mutex> g(st->lock);
    for (auto& in : inputs) in.info = st->pad_info[GST_PAD(in.pad)];
  }
  // One output frame shows one pose. Live, a camera's frame warped for an
  // older pose than the others (or older than the last output) is stale:
  // drop it and wait for its fresh one, fusing only the consistent ones when
  // the latency runs out. Not live, everything is fused and the frame is
  // stamped with the oldest pose in it, the one it fully shows.
  {
    std::vector<WarpedPose> poses;
    for (auto& in : inputs) {
      WarpedPose p;
      if (const PoseMeta* m = buffer_get_pose_meta(in.buf)) p = WarpedPose{true, m->seq, m->viewer_time_ns};
      poses.push_back(p);
    }
    int64_t window;
    {
      std::lock_guard<std::mutex> g(st->lock);
      window = int64_t(st->pose_window);
    }
    const std::vector<bool> stale = stale_poses(poses, window);
    const bool live = GST_CLOCK_TIME_IS_VALID(gst_aggregator_get_latency(agg));
    bool dropped = false;
    size_t index = 0;
    for (auto it = inputs.begin(); live && it != inputs.end(); ++index) {
      const GstClockTime t = aggregator_pad_running_time(it->pad, it->buf);
      const bool old_pose = stale[index];
      const bool old_time = GST_CLOCK_TIME_IS_VALID(st->last_out) && GST_CLOCK_TIME_IS_VALID(t) && t <= st->last_out;
      if (old_pose || old_time) {
        GST_LOG_OBJECT(self, "%s: dropping a stale frame (%s)", GST_PAD_NAME(it->pad), old_pose ? "older pose" : "late");
        gst_aggregator_pad_drop_buffer(it->pad);
        gst_buffer_unref(it->buf);
        gst_object_unref(it->pad);
        it = inputs.erase(it);
        dropped = true;
      } else {
        ++it;
      }
    }
    if (dropped && !timeout) {
      for (auto& in : inputs) {
        gst_buffer_unref(in.buf);
        gst_object_unref(in.pad);
      }
      return GST_AGGREGATOR_FLOW_NEED_DATA;
    }
    if (inputs.empty()) return GST_AGGREGATOR_FLOW_NEED_DATA;
  }

  GstFlowReturn ret = GST_FLOW_OK;
  GstClockTime rt = GST_CLOCK_TIME_NONE, duration = GST_CLOCK_TIME_NONE;
  std::vector<WarpedView> views(inputs.size());
  std::vector<const WarpedView*> ptrs;
  std::vector<std::unique_ptr<RgbdFrame>> frames;
  PoseMeta pose{};
  bool have_pose = false;
  FuseParams params;
  {
    std::lock_guard<std::mutex> g(st->lock);
    params = st->params;
  }
  for (size_t i = 0; i < inputs.size(); ++i) {
    auto f = std::make_unique<RgbdFrame>();
    std::string err;
    // A gap (a camera that said it has nothing for this time) is normal: skip it quietly.
    if (GST_BUFFER_FLAG_IS_SET(inputs[i].buf, GST_BUFFER_FLAG_GAP) || gst_buffer_get_size(inputs[i].buf) == 0)
      continue;
    if (!f->map(inputs[i].buf, inputs[i].info, GST_MAP_READ, &err)) {
      GST_ELEMENT_WARNING(self, STREAM, FAILED, ("pad %s: %s (frame skipped)", GST_PAD_NAME(inputs[i].pad),
                                                 err.c_str()),
                          (nullptr));
      continue;
    }
    views[i] = WarpedView{f->color(), f->depth(), f->label(), f->plane(Plane::Weight)};
    ptrs.push_back(&views[i]);
    frames.push_back(std::move(f));
    // The newest input is what the frame is as fresh as.
    const GstClockTime t = aggregator_pad_running_time(inputs[i].pad, inputs[i].buf);
    if (GST_CLOCK_TIME_IS_VALID(t) && (!GST_CLOCK_TIME_IS_VALID(rt) || t > rt)) {
      rt = t;
      duration = GST_BUFFER_DURATION(inputs[i].buf);
    }
    if (PoseMeta* m = buffer_get_pose_meta(inputs[i].buf); m && (!have_pose || m->seq < pose.seq)) {
      pose = *m;
      have_pose = true;
    }
  }
  if (!ptrs.empty() && st->have_out) {
    const int w = GST_VIDEO_INFO_WIDTH(&st->out_info), h = GST_VIDEO_INFO_HEIGHT(&st->out_info);
    GstBuffer* out = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&st->out_info), nullptr);
    GstMapInfo map;
    if (!gst_buffer_map(out, &map, GST_MAP_WRITE)) {
      gst_buffer_unref(out);
      GST_ELEMENT_ERROR(self, RESOURCE, FAILED, ("cannot map an output buffer"), (nullptr));
      ret = GST_FLOW_ERROR;
      goto done;
    }
    try {
      fuse_views(ptrs, params, &st->fused);
      cv::Mat dst(h, w, CV_8UC3, map.data, GST_VIDEO_INFO_PLANE_STRIDE(&st->out_info, 0));
      st->fused.color.copyTo(dst);
    } catch (const cv::Exception& e) {
      gst_buffer_unmap(out, &map);
      gst_buffer_unref(out);
      GST_ELEMENT_ERROR(self, STREAM, FAILED, ("fusion failed: %s", e.what()), (nullptr));
      ret = GST_FLOW_ERROR;
      goto done;
    }
    gst_buffer_unmap(out, &map);
    // Never back in time, whatever the inputs' timing.
    if (GST_CLOCK_TIME_IS_VALID(st->last_out) && (!GST_CLOCK_TIME_IS_VALID(rt) || rt <= st->last_out))
      rt = st->last_out + 1;
    st->last_out = rt;
    // Running time back into the output segment (it starts at a seek's position).
    GstClockTime pts = rt;
    GST_OBJECT_LOCK(agg);
    const GstClockTime in_segment = gst_segment_position_from_running_time(
        &GST_AGGREGATOR_PAD(agg->srcpad)->segment, GST_FORMAT_TIME, rt);
    GST_OBJECT_UNLOCK(agg);
    if (GST_CLOCK_TIME_IS_VALID(in_segment)) pts = in_segment;
    GST_BUFFER_PTS(out) = pts;
    GST_BUFFER_DURATION(out) = duration;
    if (have_pose) buffer_add_pose_meta(out, pose.seq, pose.viewer_time_ns);
    {
      GstSegment* seg = &GST_AGGREGATOR_PAD(agg->srcpad)->segment;
      GST_OBJECT_LOCK(agg);
      if (GST_CLOCK_TIME_IS_VALID(pts)) seg->position = pts + (GST_CLOCK_TIME_IS_VALID(duration) ? duration : 0);
      GST_OBJECT_UNLOCK(agg);
    }
    {
      std::lock_guard<std::mutex> g(st->lock);
      ++st->frames;
    }
    frames.clear();
    for (auto& in : inputs) gst_aggregator_pad_drop_buffer(in.pad);
    send_trace_pose(self);
    ret = gst_aggregator_finish_buffer(agg, out);
  } else {
    for (auto& in : inputs) gst_aggregator_pad_drop_buffer(in.pad);
  }
done:
  frames.clear();
  for (auto& in : inputs) {
    gst_buffer_unref(in.buf);
    gst_object_unref(in.pad);
  }
  GST_LOG_OBJECT(self, "fused %zu inputs (timeout %d)", ptrs.size(), timeout);
  return ret;
}

// After a flush (a seek) running time starts again: forget the last output time.
static GstFlowReturn gst_view_fuse_flush(GstAggregator* agg) {
  GST_VIEW_FUSE(agg)->st->last_out = GST_CLOCK_TIME_NONE;
  return GST_FLOW_OK;
}

static gboolean gst_view_fuse_start(GstAggregator* agg) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  FuseState* st = self->st;
  std::string path;
  {
    std::lock_guard<std::mutex> g(st->lock);
    path = st->trace_path;
    st->frames = 0;
  }
  {
    // Request pads outlive a restart; their caps (maybe a new virtual size) come again.
    std::lock_guard<std::mutex> g(st->lock);
    st->pad_info.clear();
  }
  st->trace.clear();
  st->trace_next = 0;
  st->last_out = GST_CLOCK_TIME_NONE;
  st->have_out = false;
  if (!path.empty()) {
    try {
      st->trace = load_pose_trace(path);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("property pose-trace of %s", GST_OBJECT_NAME(self)));
      return FALSE;
    }
    if (st->trace.empty()) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("pose trace %s has no poses", path.c_str()), (nullptr));
      return FALSE;
    }
  }
  return TRUE;
}

static GstAggregatorPad* gst_view_fuse_create_new_pad(GstAggregator* agg, GstPadTemplate* templ,
                                                      const gchar* req_name, const GstCaps* caps) {
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->create_new_pad(agg, templ, req_name, caps);
}

static void gst_view_fuse_release_pad(GstElement* element, GstPad* pad) {
  GstViewFuse* self = GST_VIEW_FUSE(element);
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    self->st->pad_info.erase(pad);
  }
  GST_ELEMENT_CLASS(gst_view_fuse_parent_class)->release_pad(element, pad);
}

static void gst_view_fuse_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  FuseState* st = GST_VIEW_FUSE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_POSE_TRACE:
      st->trace_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_DEPTH_TOLERANCE:
      st->params.depth_tol_mm = g_value_get_double(value);
      break;
    case PROP_FILL_HOLES:
      st->params.fill_holes = g_value_get_boolean(value);
      break;
    case PROP_POSE_WINDOW:
      st->pose_window = g_value_get_uint64(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_view_fuse_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  FuseState* st = GST_VIEW_FUSE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_POSE_TRACE:
      g_value_set_string(value, st->trace_path.c_str());
      break;
    case PROP_DEPTH_TOLERANCE:
      g_value_set_double(value, st->params.depth_tol_mm);
      break;
    case PROP_FILL_HOLES:
      g_value_set_boolean(value, st->params.fill_holes);
      break;
    case PROP_POSE_WINDOW:
      g_value_set_uint64(value, st->pose_window);
      break;
    case PROP_FRAMES_FUSED:
      g_value_set_uint64(value, st->frames);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_view_fuse_finalize(GObject* object) {
  delete GST_VIEW_FUSE(object)->st;
  G_OBJECT_CLASS(gst_view_fuse_parent_class)->finalize(object);
}

static void gst_view_fuse_class_init(GstViewFuseClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* agg_class = GST_AGGREGATOR_CLASS(klass);
  gobject_class->set_property = gst_view_fuse_set_property;
  gobject_class->get_property = gst_view_fuse_get_property;
  gobject_class->finalize = gst_view_fuse_finalize;
  const FuseParams d;
  g_object_class_install_property(
      gobject_class, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace (docs/pose.md) to play: pose i is sent upstream to every camera branch "
                          "as a vclassroom/pose event (seq i + 1) after output frame i - 1; the last pose is held. "
                          "Empty: poses come from downstream events only",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_DEPTH_TOLERANCE,
      g_param_spec_double("depth-tolerance", "Depth tolerance",
                          "Samples of several cameras within this many mm (or 3% of the depth when larger) of the "
                          "nearest are blended; farther ones are hidden",
                          0, 10000, d.depth_tol_mm,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_FILL_HOLES,
      g_param_spec_boolean("fill-holes", "Fill holes",
                           "Fill what no camera sees from its background side (else black)", d.fill_holes,
                           GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_POSE_WINDOW,
      g_param_spec_uint64("pose-window", "Pose window",
                          "Live: cameras' frames warped for poses the viewer took at most this many ns apart are "
                          "fused together; a frame warped for an older pose is dropped and its fresh one awaited "
                          "(0: only frames of exactly the same pose). The output is stamped with the oldest pose",
                          0, G_MAXINT64, kDefaultPoseWindow,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_FRAMES_FUSED,
      g_param_spec_uint64("frames-fused", "Frames fused", "Output frames produced since start", 0, G_MAXUINT64, 0,
                          GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template_with_gtype(element_class, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(element_class, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(
      element_class, "View fusion", "Mixer/Video",
      "Fuses the cameras warped to the virtual view (viewwarp outputs on cam_%u): z-buffer visibility, blending "
      "weighted by viewing angle, distance and warp quality, learners composited by depth, holes filled from the "
      "background side. Outputs video/x-raw RGB with the pose meta of the pose rendered. Forwards vclassroom/pose "
      "events to every input; cameras that are EOS (or, when live, late past the latency) are left out. Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=0 num-buffers=300 ! learnerseg ! viewwarp ! queue ! "
      "f.cam_0 rgbdtestsrc camera-id=2 num-buffers=300 ! learnerseg ! viewwarp ! queue ! "
      "f.cam_2 viewfuse name=f ! videoconvert ! autovideosink",
      "gst-vclassroom developers");
  agg_class->aggregate = GST_DEBUG_FUNCPTR(gst_view_fuse_aggregate);
  agg_class->sink_event = GST_DEBUG_FUNCPTR(gst_view_fuse_sink_event);
  agg_class->src_event = GST_DEBUG_FUNCPTR(gst_view_fuse_src_event);
  agg_class->update_src_caps = GST_DEBUG_FUNCPTR(gst_view_fuse_update_src_caps);
  agg_class->start = GST_DEBUG_FUNCPTR(gst_view_fuse_start);
  agg_class->flush = GST_DEBUG_FUNCPTR(gst_view_fuse_flush);
  agg_class->create_new_pad = GST_DEBUG_FUNCPTR(gst_view_fuse_create_new_pad);
  agg_class->get_next_time = gst_aggregator_simple_get_next_time;
  element_class->release_pad = GST_DEBUG_FUNCPTR(gst_view_fuse_release_pad);
  GST_DEBUG_CATEGORY_INIT(view_fuse_debug, "viewfuse", 0, "view fusion");
}

static void gst_view_fuse_init(GstViewFuse* self) { self->st = new FuseState(); }
