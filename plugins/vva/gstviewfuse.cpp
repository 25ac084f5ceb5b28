/**
 * SECTION:element-viewfuse
 * @title: viewfuse
 *
 * Fuses the cameras warped to the lecturer's virtual view (one viewwarp per camera, on request pads cam_%u)
 * into the lecturer's video/x-raw RGB picture (V-VA step 3, docs/vva.md): z-buffer visibility, blending
 * weighted by viewing angle, distance and warp quality, learners composited by depth, holes filled from the
 * background side. Each picture carries the pose meta of the pose it shows.
 *
 * Pose events from downstream go upstream to every camera branch, moved into the rig's navigation bounds
 * when `rig` has them (docs/navigation.md); `pose-trace` plays a trace the same way, pose i (seq i + 1) after
 * output frame i - 1, the last one held. Cameras that are EOS,
 * or live and late past the latency, are left out, so is a camera whose view has another size (with a
 * warning); live, a camera silent for `camera-timeout` is reported lost (a warning and a
 * vclassroom-camera-status message) and named on the picture, and the cameras' warps start together
 * (`warp-sync`, docs/lecturer.md). `stats-interval` posts vclassroom-view-stats messages.
 *
 * `room-view` (on by default) draws the room here: a viewwarp with `prior-depth` then warps only its camera's
 * learners (and what the room's mesh does not draw) and passes its frame's room along with the picture, and
 * this element rasterises every such camera's mesh of its static depth at the view and looks its colour up in
 * the cameras, the learners fused over it (docs/vva.md, "How a view is made"). Cameras without `prior-depth`
 * are warped whole, as with `room-view=false`. A camera far from the view leaves its learners to the nearer
 * ones that have been in the last rounds; a round in which one of those did not draw them (a dropped frame, a
 * lost camera) is not shown, and the next ones are warped without it until it is back for three rounds.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=0 num-buffers=30 ! learnerseg ! viewwarp ! queue ! f.cam_0 rgbdtestsrc camera-id=2 num-buffers=30 ! learnerseg ! viewwarp ! queue ! f.cam_2 viewfuse name=f ! videoconvert ! fakesink
 * ]|
 * Without a rig each viewwarp starts from its own camera's view; with one rig they all start from its
 * reference camera, and a pose event or `pose-trace` moves them together.
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <cstdio>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/rig.h>

#include "gstviewfuse_state.h"

GST_DEBUG_CATEGORY(view_fuse_debug);
#define GST_CAT_DEFAULT view_fuse_debug

using namespace vclassroom;

G_DEFINE_TYPE(GstViewFuse, gst_view_fuse, GST_TYPE_AGGREGATOR)
GST_ELEMENT_REGISTER_DEFINE(viewfuse, "viewfuse", GST_RANK_NONE, GST_TYPE_VIEW_FUSE)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "cam_%u", GST_PAD_SINK, GST_PAD_REQUEST,
    GST_STATIC_CAPS("video/x-rgbd, width = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], height = (int) [ 1, " G_STRINGIFY(
                        VCLASSROOM_MAX_IMAGE_SIDE) " ], "
                    "framerate = (fraction) [ 0/1, 2147483647/1 ], planes = (string) \"color,depth,label,weight\""));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGB")));

static gboolean gst_view_fuse_src_event(GstAggregator* agg, GstEvent* event) {
  if (is_pose_event(event)) {
    forward_pose(GST_VIEW_FUSE(agg), event);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->src_event(agg, event);
}

// A camera's viewwarp is about to read the pose: live, it waits here for the view's other cameras.
static gboolean gst_view_fuse_sink_query(GstAggregator* agg, GstAggregatorPad* pad, GstQuery* query) {
  ViewFuseState* st = GST_VIEW_FUSE(agg)->st;
  const GstStructure* s = GST_QUERY_TYPE(query) == GST_QUERY_CUSTOM ? gst_query_get_structure(query) : nullptr;
  if (s && gst_structure_has_name(s, kWarpStartQueryName)) {
    gst_structure_set(gst_query_writable_structure(query), "room-view", G_TYPE_BOOLEAN, gboolean(st->room_view.load()),
                      nullptr);
    guint64 frame = GST_CLOCK_TIME_NONE;
    gst_structure_get_uint64(s, "running-time", &frame);
    if (st->live) {
      uint64_t group = 0;
      st->warp_start.arrive(pad, g_get_monotonic_time() * 1000, time_ns(frame), &group);
      // The cameras that go together share it (whepviewsink's views take turns by these rounds).
      gst_structure_set(gst_query_writable_structure(query), "group", G_TYPE_UINT64, guint64(group), nullptr);
    }
    // After the wait: the cameras of the rounds fused until now.
    std::lock_guard<std::mutex> g(st->lock);
    warp_start_set_room_cameras(gst_query_writable_structure(query), st->room_cameras);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->sink_query(agg, pad, query);
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
    // A camera whose view changes size (another sender, another mode) must
    // not stop the others: its frames are left out until its size matches.
    std::string rejected;
    {
      std::lock_guard<std::mutex> g(self->st->lock);
      self->st->pad_info[pad] = info;
      rejected = self->st->inputs.configure(pad, info.camera.id, info.width(), info.height());
    }
    if (!rejected.empty())
      GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                          ("camera %d (pad %s) left out: %s", info.camera.id, GST_PAD_NAME(pad), rejected.c_str()),
                          (nullptr));
    else
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
    const InputKey first = self->st->inputs.first_accepted();
    if (!first) return GST_AGGREGATOR_FLOW_NEED_DATA;
    info = self->st->pad_info[first];
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


static bool any_pad_has_buffer(GstAggregator* agg) {
  bool any = false;
  GST_OBJECT_LOCK(agg);
  for (GList* l = GST_ELEMENT(agg)->sinkpads; l && !any; l = l->next)
    any = gst_aggregator_pad_has_buffer(GST_AGGREGATOR_PAD(l->data));
  GST_OBJECT_UNLOCK(agg);
  return any;
}

// Live and idle, it sleeps (fuse_wake_time()). Called with the aggregator's
// source lock held: gst_aggregator_get_latency() would deadlock here.
static GstClockTime gst_view_fuse_get_next_time(GstAggregator* agg) {
  const GstClockTime next = gst_aggregator_simple_get_next_time(agg);
  const GstClockTime now = running_time_now(GST_ELEMENT(agg));
  return clock_time(fuse_wake_time(time_ns(next), time_ns(now), any_pad_has_buffer(agg), int64_t(kIdleWake)));
}

// FuseInputs decides (docs/vva.md); this posts, drops and fuses as it says.
static GstFlowReturn gst_view_fuse_aggregate(GstAggregator* agg, gboolean timeout) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  ViewFuseState* st = self->st;
  if (st->trace_next == 0) send_trace_pose(self);

  std::vector<GstAggregatorPad*> pads;
  std::vector<GstBuffer*> bufs;
  std::vector<std::pair<InputKey, int>> every_pad;  // and the camera its name says (cam_K: camera K)
  bool all_eos = true;
  GST_OBJECT_LOCK(agg);
  for (GList* l = GST_ELEMENT(agg)->sinkpads; l; l = l->next) {
    GstAggregatorPad* pad = GST_AGGREGATOR_PAD(l->data);
    int named = 0;
    std::sscanf(GST_PAD_NAME(pad), "cam_%d", &named);
    every_pad.emplace_back(pad, named);
    GstBuffer* buf = gst_aggregator_pad_peek_buffer(pad);
    if (!gst_aggregator_pad_is_eos(pad) || buf) all_eos = false;
    if (buf) {
      pads.push_back(GST_AGGREGATOR_PAD(gst_object_ref(pad)));
      bufs.push_back(buf);
    }
  }
  GST_OBJECT_UNLOCK(agg);
  if (pads.empty() && all_eos) return GST_FLOW_EOS;
  RoundContext ctx;
  const GstClockTime latency = gst_aggregator_get_latency(agg);
  ctx.live = GST_CLOCK_TIME_IS_VALID(latency);
  ctx.latency_ns = time_ns(latency);
  st->live = ctx.live;
  const GstClockTime now = ctx.live ? running_time_now(GST_ELEMENT(agg)) : GST_CLOCK_TIME_NONE;
  ctx.now_ns = time_ns(now);
  ctx.timeout = timeout;
  ctx.last_out_ns = time_ns(st->last_out);
  ctx.have_picture = st->have_fused && st->have_out;
  ctx.monotonic_ns = g_get_monotonic_time() * 1000;
  std::vector<PendingFrame> pending(pads.size());
  for (size_t i = 0; i < pads.size(); ++i) {
    pending[i].key = pads[i];
    pending[i].running_time_ns = time_ns(aggregator_pad_running_time(pads[i], bufs[i]));
    if (const PoseMeta* m = buffer_get_pose_meta(bufs[i]))
      pending[i].pose = WarpedPose{true, m->seq, m->viewer_time_ns, m->rendered, m->session};
  }
  FuseRound round;
  std::vector<RgbdInfo> infos;
  FuseParams params;
  {
    std::lock_guard<std::mutex> g(st->lock);
    ctx.steering_session = st->steering_session;
    // A camera that never sends has no caps to name it: its pad does (server.sh feeds camera K to cam_K).
    for (const auto& [key, named] : every_pad) st->inputs.expect(key, named);
    round = st->inputs.decide(pending, ctx);
    for (GstAggregatorPad* pad : pads) infos.push_back(st->pad_info[pad]);
    params = st->params;
  }
  for (const auto& c : round.status_changes) post_camera_status(self, c, round.missing, round.all_lost);
  for (const auto& w : round.warnings) GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("%s", w.c_str()), (nullptr));
  drop_buffers(pads, round.verdicts, FrameVerdict::kLeftOut);
  for (size_t i = 0; i < pads.size(); ++i)
    if (round.verdicts[i] == FrameVerdict::kOlderPose || round.verdicts[i] == FrameVerdict::kLate) {
      GST_LOG_OBJECT(self, "%s: dropping a stale frame (%s)", GST_PAD_NAME(pads[i]),
                     round.verdicts[i] == FrameVerdict::kOlderPose ? "older pose" : "late");
      gst_aggregator_pad_drop_buffer(pads[i]);
    }
  GstFlowReturn ret = GST_AGGREGATOR_FLOW_NEED_DATA;
  if (round.action == RoundAction::kRepeatLast) {
    const GstClockTime latency = gst_aggregator_get_latency(agg);
    ret = push_picture(self, round.banner, now > latency ? now - latency : 0, kIdleWake, nullptr);
  } else if (round.action == RoundAction::kFuse) {
    ret = fuse_and_push(self, pads, bufs, infos, pending, round, params);
  }
  for (size_t i = 0; i < pads.size(); ++i) {
    gst_buffer_unref(bufs[i]);
    gst_object_unref(pads[i]);
  }
  return ret;
}

// After a flush (a seek) running time starts again: forget the last output time, and the last picture's
// fill (the next frame need not follow it).
static GstFlowReturn gst_view_fuse_flush(GstAggregator* agg) {
  vclassroom::ViewFuseState* st = GST_VIEW_FUSE(agg)->st;
  st->last_out = GST_CLOCK_TIME_NONE;
  st->fill_history.clear();
  st->fill_pose = vclassroom::WarpedPose{};
  return GST_FLOW_OK;
}

static gboolean gst_view_fuse_start(GstAggregator* agg) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  ViewFuseState* st = self->st;
  std::string path, rig_path;
  {
    std::lock_guard<std::mutex> g(st->lock);
    path = st->trace_path;
    rig_path = st->rig_path;
    st->frames = 0;
    // Request pads outlive a restart; their caps (maybe a new virtual size) come again.
    st->pad_info.clear();
    st->inputs.clear();
    st->steering_session.reset();
    st->room_cameras.clear();
  }
  st->learner_rounds.clear();
  st->warp_start.resume();
  st->trace.clear();
  st->trace_next = 0;
  st->trace_session = new_pose_session_id();
  st->last_out = GST_CLOCK_TIME_NONE;
  st->have_out = false;
  st->have_fused = false;
  st->fill_history.clear();
  st->fill_pose = WarpedPose{};
  NavigationClamp bounds;
  if (!rig_path.empty()) {
    try {
      bounds = NavigationClamp(load_rig(rig_path));
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("property rig of %s", GST_OBJECT_NAME(self)));
      return FALSE;
    }
    if (!bounds.active())
      GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS,
                          ("rig %s has no navigation section: poses are not bounded", rig_path.c_str()),
                          ("vclassroom-build-model writes one (docs/navigation.md)"));
  }
  {
    std::lock_guard<std::mutex> g(st->lock);
    st->bounds = bounds;
    st->unseen_share = 0;
  }
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

// Stopping: no camera's warp waits for the others any more.
static gboolean gst_view_fuse_stop(GstAggregator* agg) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  self->st->warp_start.release();
  self->st->live = false;
  return TRUE;
}

static GstAggregatorPad* gst_view_fuse_create_new_pad(GstAggregator* agg, GstPadTemplate* templ, const gchar* name,
                                                      const GstCaps* caps) {
  GstAggregatorPad* pad =
      GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->create_new_pad(agg, templ, name, caps);
  if (pad)
    gst_pad_add_probe(GST_PAD(pad), GstPadProbeType(GST_PAD_PROBE_TYPE_QUERY_UPSTREAM | GST_PAD_PROBE_TYPE_PUSH),
                      answer_latency_of_unconnected_branch, nullptr, nullptr);
  return pad;
}

static void gst_view_fuse_release_pad(GstElement* element, GstPad* pad) {
  GstViewFuse* self = GST_VIEW_FUSE(element);
  self->st->warp_start.forget(pad);
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    self->st->pad_info.erase(pad);
    self->st->inputs.release(pad);
  }
  GST_ELEMENT_CLASS(gst_view_fuse_parent_class)->release_pad(element, pad);
}

static void gst_view_fuse_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  view_fuse_set_property(object, prop_id, value, pspec);
}

static void gst_view_fuse_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  view_fuse_get_property(object, prop_id, value, pspec);
}

static void gst_view_fuse_finalize(GObject* object) {
  delete GST_VIEW_FUSE(object)->st;
  G_OBJECT_CLASS(gst_view_fuse_parent_class)->finalize(object);
}

static GstStateChangeReturn gst_view_fuse_change_state(GstElement* element, GstStateChange transition) {
  GstViewFuse* self = GST_VIEW_FUSE(element);
  if (transition == GST_STATE_CHANGE_PLAYING_TO_PAUSED) watch_for_first_camera(self, false);
  const GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_view_fuse_parent_class)->change_state(element, transition);
  if (transition == GST_STATE_CHANGE_PAUSED_TO_PLAYING && ret != GST_STATE_CHANGE_FAILURE) watch_for_first_camera(self, true);
  return ret;
}

static void gst_view_fuse_class_init(GstViewFuseClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* agg_class = GST_AGGREGATOR_CLASS(klass);
  gobject_class->set_property = gst_view_fuse_set_property;
  gobject_class->get_property = gst_view_fuse_get_property;
  gobject_class->finalize = gst_view_fuse_finalize;
  view_fuse_install_properties(gobject_class);
  gst_element_class_add_static_pad_template_with_gtype(element_class, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(element_class, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(element_class, "View fusion", "Mixer/Video",
                                        "Fuses the cameras warped to the lecturer's view into one RGB picture",
                                        "gst-vclassroom developers");
  element_class->change_state = GST_DEBUG_FUNCPTR(gst_view_fuse_change_state);
  agg_class->aggregate = GST_DEBUG_FUNCPTR(gst_view_fuse_aggregate);
  agg_class->sink_event = GST_DEBUG_FUNCPTR(gst_view_fuse_sink_event);
  agg_class->sink_query = GST_DEBUG_FUNCPTR(gst_view_fuse_sink_query);
  agg_class->stop = GST_DEBUG_FUNCPTR(gst_view_fuse_stop);
  agg_class->src_event = GST_DEBUG_FUNCPTR(gst_view_fuse_src_event);
  agg_class->update_src_caps = GST_DEBUG_FUNCPTR(gst_view_fuse_update_src_caps);
  agg_class->start = GST_DEBUG_FUNCPTR(gst_view_fuse_start);
  agg_class->flush = GST_DEBUG_FUNCPTR(gst_view_fuse_flush);
  agg_class->get_next_time = GST_DEBUG_FUNCPTR(gst_view_fuse_get_next_time);
  agg_class->create_new_pad = GST_DEBUG_FUNCPTR(gst_view_fuse_create_new_pad);
  element_class->release_pad = GST_DEBUG_FUNCPTR(gst_view_fuse_release_pad);
  GST_DEBUG_CATEGORY_INIT(view_fuse_debug, "viewfuse", 0, "view fusion");
}

static void gst_view_fuse_init(GstViewFuse* self) { self->st = new ViewFuseState(); }
