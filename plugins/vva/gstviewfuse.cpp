// viewfuse: fuses the cameras warped to the virtual view (one viewwarp per
// camera on request pads cam_%u) into the lecturer's video/x-raw RGB picture
// (V-VA step 3, docs/vva.md). Forwards pose events to every input and can play
// a pose trace itself.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewfuse.h"

#include <gst/video/video.h>

#include <atomic>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gst/vclassroom/vva/camera_liveness.h>
#include <gst/vclassroom/vva/fuse_inputs.h>
#include <gst/vclassroom/core/pose.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/pose_trace.h>
#include <gst/vclassroom/vva/navigation.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/virtual_view.h>
#include <gst/vclassroom/vva/warp_start.h>

GST_DEBUG_CATEGORY_STATIC(view_fuse_debug);
#define GST_CAT_DEFAULT view_fuse_debug

using namespace vclassroom;

enum {
  PROP_0,
  PROP_POSE_TRACE,
  PROP_DEPTH_TOLERANCE,
  PROP_FILL_HOLES,
  PROP_FILL_TEXTURE,
  PROP_FRAMES_FUSED,
  PROP_POSE_WINDOW,
  PROP_CAMERA_TIMEOUT,
  PROP_SHOW_MISSING,
  PROP_RIG,
  PROP_POSES_CLAMPED,
  PROP_UNSEEN_SHARE,
  PROP_STATS_INTERVAL,
  PROP_WARP_SYNC
};
// Live and without any input, the fuse thread wakes this often to notice lost
// cameras and to keep the lecturer's picture saying so; otherwise it sleeps.
constexpr GstClockTime kIdleWake = 100 * GST_MSECOND;

namespace {

struct FuseState {
  std::mutex lock;  // guards the properties, pad_info and inputs
  std::string trace_path;
  std::string rig_path;
  NavigationClamp bounds;  // every pose sent upstream stays inside the rig's navigation bounds
  std::optional<uint64_t> steering_session;  // the session of the latest pose sent upstream (stale_poses())
  double unseen_share = 0;  // of the last picture
  guint stats_interval = 0;  // frames between vclassroom-view-stats messages; 0: none
  FuseParams params;
  std::map<InputKey, RgbdInfo> pad_info;  // each pad's caps, to map its frames
  // Which pads are left out, lost, stale (the decisions of each round).
  FuseInputs inputs;
  guint64 frames = 0;
  // The cameras' warps start together (warp-sync); only live, as the aggregate thread last found.
  WarpStartBarrier warp_start;
  std::atomic<bool> live{false};

  // Streaming thread only.
  std::vector<PoseSample> trace;
  size_t trace_next = 0;
  uint64_t trace_session = 0;  // the trace's poses are a session of their own, new each start
  GstVideoInfo out_info{};
  bool have_out = false;
  FusedView fused;
  bool have_fused = false;  // fused holds the last picture sent
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
static gboolean push_pose_to_pad(GstElement*, GstPad* pad, gpointer event) {
  gst_pad_push_event(pad, gst_event_ref(GST_EVENT(event)));
  return TRUE;
}

// Any client's pose (a lecturer's, a headset's, the trace) leaves inside the
// navigation bounds; a pose outside is replaced by its nearest allowed one,
// and that is the pose the cameras render and the frame is stamped with.
static GstEvent* clamped_pose_event(GstViewFuse* self, GstEvent* event) {
  Pose pose;
  std::string warning;
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    if (!self->st->bounds.active() || !pose_event_parse(event, &pose, nullptr) ||
        !self->st->bounds.apply(&pose, int64_t(g_get_monotonic_time()) * 1000, "the lecturer", &warning))
      return event;
  }
  if (!warning.empty()) GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("%s", warning.c_str()), (nullptr));
  try {
    GstEvent* clamped = pose_event_new(pose);
    gst_event_unref(event);
    return clamped;
  } catch (const Error&) {
    return event;  // a clamped pose is a valid one; kept as it came should that ever fail
  }
}

static void forward_pose(GstViewFuse* self, GstEvent* event) {
  event = clamped_pose_event(self, event);
  guint64 session = 0;  // absent: the unnamed session
  gst_structure_get_uint64(gst_event_get_structure(event), "session", &session);
  {
    std::lock_guard<std::mutex> g(self->st->lock);
    self->st->steering_session = session;
  }
  gst_element_foreach_sink_pad(GST_ELEMENT(self), push_pose_to_pad, event);
  gst_event_unref(event);
}

static gboolean gst_view_fuse_src_event(GstAggregator* agg, GstEvent* event) {
  if (is_pose_event(event)) {
    forward_pose(GST_VIEW_FUSE(agg), event);
    return TRUE;
  }
  return GST_AGGREGATOR_CLASS(gst_view_fuse_parent_class)->src_event(agg, event);
}

static int64_t time_ns(GstClockTime t) { return GST_CLOCK_TIME_IS_VALID(t) ? int64_t(t) : -1; }

// A camera's viewwarp is about to read the pose: live, it waits here for the view's other cameras.
static gboolean gst_view_fuse_sink_query(GstAggregator* agg, GstAggregatorPad* pad, GstQuery* query) {
  FuseState* st = GST_VIEW_FUSE(agg)->st;
  const GstStructure* s = GST_QUERY_TYPE(query) == GST_QUERY_CUSTOM ? gst_query_get_structure(query) : nullptr;
  if (s && gst_structure_has_name(s, kWarpStartQueryName)) {
    guint64 frame = GST_CLOCK_TIME_NONE;
    gst_structure_get_uint64(s, "running-time", &frame);
    if (st->live) {
      uint64_t group = 0;
      st->warp_start.arrive(pad, g_get_monotonic_time() * 1000, time_ns(frame), &group);
      // The cameras that go together share it (whepviewsink's views take turns by these rounds).
      gst_structure_set(gst_query_writable_structure(query), "group", G_TYPE_UINT64, guint64(group), nullptr);
    }
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


static void send_trace_pose(GstViewFuse* self) {
  FuseState* st = self->st;
  if (st->trace.empty()) return;
  Pose pose = trace_pose_in_turn(st->trace, st->trace_next++);
  pose.viewer_time_ns = g_get_monotonic_time() * 1000;
  pose.session = st->trace_session;
  try {
    forward_pose(self, pose_event_new(pose));
  } catch (const Error& e) {
    GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("pose trace line %zu: %s", size_t(pose.seq), e.what()), (nullptr));
  }
}

// GstClockTime as the library's nanoseconds (< 0: unknown) and back.
static GstClockTime clock_time(int64_t ns) { return ns < 0 ? GST_CLOCK_TIME_NONE : GstClockTime(ns); }

// Running time on the element's clock now; GST_CLOCK_TIME_NONE without a clock.
static GstClockTime running_time_now(GstElement* element) {
  GstClock* clock = gst_element_get_clock(element);
  if (!clock) return GST_CLOCK_TIME_NONE;
  const GstClockTime now = gst_clock_get_time(clock);
  gst_object_unref(clock);
  const GstClockTime base = gst_element_get_base_time(element);
  return now > base ? now - base : 0;
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

// Drops the queued frame of every pad whose verdict is `which`.
static void drop_buffers(const std::vector<GstAggregatorPad*>& pads, const std::vector<FrameVerdict>& verdicts,
                         FrameVerdict which) {
  for (size_t i = 0; i < pads.size(); ++i)
    if (verdicts[i] == which) gst_aggregator_pad_drop_buffer(pads[i]);
}

// A camera lost or back: a bus warning (lost) or info (back) for a person and
// a vclassroom-camera-status element message for programs.
static void post_camera_status(GstViewFuse* self, const CameraStatusChange& change, const std::vector<int>& missing,
                               bool all_lost) {
  GstStructure* s = gst_structure_new(
      "vclassroom-camera-status", "camera-id", G_TYPE_INT, change.camera_id, "status", G_TYPE_STRING,
      change.lost ? "lost" : "returned", "silent-ns", G_TYPE_UINT64, guint64(change.silent_ns), "missing",
      G_TYPE_STRING, camera_id_list(missing).c_str(), "cameras-missing", G_TYPE_UINT, guint(missing.size()),
      "since-start", G_TYPE_BOOLEAN, gboolean(change.never_seen), nullptr);
  const std::string text = camera_status_text(change, missing, all_lost);
  if (change.lost)
    GST_ELEMENT_WARNING(self, STREAM, FAILED, ("%s", text.c_str()), (nullptr));
  else  // gst-launch-1.0 prints only an info's debug text: the same words there.
    GST_ELEMENT_INFO(self, RESOURCE, READ, ("%s", text.c_str()), ("%s", text.c_str()));
  // After the text for people, so that a program seeing the status has the text too.
  gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), s));
}

// Sends st->fused.color, with the banner naming the missing cameras when
// `banner` is not empty, at running time `rt` (or just after the last output).
static GstFlowReturn push_picture(GstViewFuse* self, const std::string& banner, GstClockTime rt,
                                  GstClockTime duration, const WarpedPose* pose) {
  GstAggregator* agg = GST_AGGREGATOR(self);
  FuseState* st = self->st;
  const int w = GST_VIDEO_INFO_WIDTH(&st->out_info), h = GST_VIDEO_INFO_HEIGHT(&st->out_info);
  if (st->fused.color.cols != w || st->fused.color.rows != h || st->fused.color.type() != CV_8UC3)
    return GST_FLOW_OK;  // the output size changed since that picture
  GstBuffer* out = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&st->out_info), nullptr);
  GstMapInfo map;
  if (!gst_buffer_map(out, &map, GST_MAP_WRITE)) {
    gst_buffer_unref(out);
    GST_ELEMENT_ERROR(self, RESOURCE, FAILED, ("cannot map an output buffer"), (nullptr));
    return GST_FLOW_ERROR;
  }
  cv::Mat dst(h, w, CV_8UC3, map.data, GST_VIDEO_INFO_PLANE_STRIDE(&st->out_info, 0));
  st->fused.color.copyTo(dst);
  draw_missing_banner(dst, banner);
  gst_buffer_unmap(out, &map);
  rt = clock_time(next_output_time(time_ns(st->last_out), time_ns(rt)));
  st->last_out = rt;
  // Running time back into the output segment (it starts at a seek's position).
  GstClockTime pts = rt;
  GST_OBJECT_LOCK(agg);
  const GstClockTime in_segment =
      gst_segment_position_from_running_time(&GST_AGGREGATOR_PAD(agg->srcpad)->segment, GST_FORMAT_TIME, rt);
  GST_OBJECT_UNLOCK(agg);
  if (GST_CLOCK_TIME_IS_VALID(in_segment)) pts = in_segment;
  GST_BUFFER_PTS(out) = pts;
  GST_BUFFER_DURATION(out) = duration;
  if (pose) buffer_add_pose_meta(out, pose->seq, pose->viewer_time_ns, pose->rendered, pose->session);
  {
    GstSegment* seg = &GST_AGGREGATOR_PAD(agg->srcpad)->segment;
    GST_OBJECT_LOCK(agg);
    if (GST_CLOCK_TIME_IS_VALID(pts)) seg->position = pts + (GST_CLOCK_TIME_IS_VALID(duration) ? duration : 0);
    GST_OBJECT_UNLOCK(agg);
  }
  return gst_aggregator_finish_buffer(agg, out);
}

// Maps the frames to fuse, fuses them and sends the picture (stamped as output_stamp() says).
static GstFlowReturn fuse_and_push(GstViewFuse* self, const std::vector<GstAggregatorPad*>& pads,
                                   const std::vector<GstBuffer*>& bufs, const std::vector<RgbdInfo>& infos,
                                   const std::vector<PendingFrame>& pending, const FuseRound& round,
                                   const FuseParams& params) {
  FuseState* st = self->st;
  std::vector<WarpedView> views(pads.size());
  std::vector<const WarpedView*> ptrs;
  std::vector<std::unique_ptr<RgbdFrame>> frames;
  std::vector<FrameStamp> stamps;
  std::vector<size_t> fused;  // the index of each of them among the pads
  for (size_t i = 0; i < pads.size(); ++i) {
    if (round.verdicts[i] != FrameVerdict::kFuse) continue;
    auto f = std::make_unique<RgbdFrame>();
    std::string err;
    // A gap (a camera that said it has nothing for this time) is normal: skip it quietly.
    if (GST_BUFFER_FLAG_IS_SET(bufs[i], GST_BUFFER_FLAG_GAP) || gst_buffer_get_size(bufs[i]) == 0) continue;
    if (!f->map(bufs[i], infos[i], GST_MAP_READ, &err)) {
      GST_ELEMENT_WARNING(self, STREAM, FAILED, ("pad %s: %s (frame skipped)", GST_PAD_NAME(pads[i]), err.c_str()),
                          (nullptr));
      continue;
    }
    views[i] = WarpedView{f->color(), f->depth(), f->label(), f->plane(Plane::Weight)};
    ptrs.push_back(&views[i]);
    frames.push_back(std::move(f));
    stamps.push_back(FrameStamp{pending[i].running_time_ns, pending[i].pose});
    fused.push_back(i);
  }
  if (ptrs.empty() || !st->have_out) {
    drop_buffers(pads, round.verdicts, FrameVerdict::kFuse);
    return GST_FLOW_OK;
  }
  try {
    fuse_views(ptrs, params, &st->fused);
  } catch (const cv::Exception& e) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("fusion failed: %s", e.what()), (nullptr));
    st->have_fused = false;
    return GST_FLOW_ERROR;
  }
  st->have_fused = true;
  GstStructure* stats = nullptr;
  {
    std::lock_guard<std::mutex> g(st->lock);
    ++st->frames;
    st->unseen_share = st->fused.unseen_share;
    if (st->stats_interval && st->frames % st->stats_interval == 0)
      stats = gst_structure_new("vclassroom-view-stats", "frames", G_TYPE_UINT64, st->frames, "unseen-share",
                                G_TYPE_DOUBLE, st->unseen_share, "poses-clamped", G_TYPE_UINT64, st->bounds.clamped(),
                                nullptr);
  }
  if (stats) gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), stats));
  frames.clear();
  drop_buffers(pads, round.verdicts, FrameVerdict::kFuse);
  send_trace_pose(self);
  const OutputStamp stamp = output_stamp(stamps);
  const GstClockTime rt = stamp.time_from < 0 ? GST_CLOCK_TIME_NONE : clock_time(stamps[stamp.time_from].running_time_ns);
  const GstClockTime duration = stamp.time_from < 0 ? GST_CLOCK_TIME_NONE : GST_BUFFER_DURATION(bufs[fused[stamp.time_from]]);
  GST_LOG_OBJECT(self, "fused %zu inputs", ptrs.size());
  return push_picture(self, round.banner, rt, duration, stamp.pose_from < 0 ? nullptr : &stamps[stamp.pose_from].pose);
}

// FuseInputs decides (docs/vva.md); this posts, drops and fuses as it says.
static GstFlowReturn gst_view_fuse_aggregate(GstAggregator* agg, gboolean timeout) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  FuseState* st = self->st;
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
  ctx.live = GST_CLOCK_TIME_IS_VALID(gst_aggregator_get_latency(agg));
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

// After a flush (a seek) running time starts again: forget the last output time.
static GstFlowReturn gst_view_fuse_flush(GstAggregator* agg) {
  GST_VIEW_FUSE(agg)->st->last_out = GST_CLOCK_TIME_NONE;
  return GST_FLOW_OK;
}

static gboolean gst_view_fuse_start(GstAggregator* agg) {
  GstViewFuse* self = GST_VIEW_FUSE(agg);
  FuseState* st = self->st;
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
  }
  st->warp_start.resume();
  st->trace.clear();
  st->trace_next = 0;
  st->trace_session = new_pose_session_id();
  st->last_out = GST_CLOCK_TIME_NONE;
  st->have_out = false;
  st->have_fused = false;
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

// GstAggregator asks every sink pad's upstream for its latency and, when one
// cannot answer, takes the whole element for not live: it then waits for a
// frame on every pad, forever for a camera that never sends. A camera branch
// cannot answer while it is not connected to its source yet (server.sh's
// rtpssrcdemux makes the camera's pad at its first packet). Such a branch is
// answered here as an unlinked pad would be (GStreamer leaves those out): no
// latency of its own, so the view is live with the cameras that send.
static GstPadProbeReturn answer_latency_of_unconnected_branch(GstPad* pad, GstPadProbeInfo* info, gpointer) {
  GstQuery* query = GST_PAD_PROBE_INFO_QUERY(info);
  if (GST_QUERY_TYPE(query) != GST_QUERY_LATENCY) return GST_PAD_PROBE_OK;
  GstPad* peer = gst_pad_get_peer(pad);
  if (!peer) return GST_PAD_PROBE_OK;
  const gboolean answered = gst_pad_query(peer, query);
  gst_object_unref(peer);
  if (!answered) {
    GST_DEBUG_OBJECT(pad, "camera branch not connected to its source: no latency of its own");
    gst_query_set_latency(query, FALSE, 0, GST_CLOCK_TIME_NONE);
  }
  return GST_PAD_PROBE_HANDLED;
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
  FuseState* st = GST_VIEW_FUSE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  FuseInputsParams inputs = st->inputs.params();
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
    case PROP_FILL_TEXTURE:
      st->params.fill_texture = g_value_get_double(value);
      break;
    case PROP_POSE_WINDOW:
      inputs.pose_window_ns = int64_t(g_value_get_uint64(value));
      break;
    case PROP_CAMERA_TIMEOUT:
      inputs.camera_timeout_ns = int64_t(g_value_get_uint64(value));
      break;
    case PROP_SHOW_MISSING:
      inputs.show_missing = g_value_get_boolean(value);
      break;
    case PROP_RIG:
      st->rig_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_STATS_INTERVAL:
      st->stats_interval = g_value_get_uint(value);
      break;
    case PROP_WARP_SYNC: {
      WarpStartParams w = st->warp_start.params();
      w.max_wait_ns = int64_t(g_value_get_uint64(value));
      st->warp_start.set_params(w);
      break;
    }
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
  st->inputs.set_params(inputs);
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
    case PROP_FILL_TEXTURE:
      g_value_set_double(value, st->params.fill_texture);
      break;
    case PROP_POSE_WINDOW:
      g_value_set_uint64(value, guint64(st->inputs.params().pose_window_ns));
      break;
    case PROP_CAMERA_TIMEOUT:
      g_value_set_uint64(value, guint64(st->inputs.params().camera_timeout_ns));
      break;
    case PROP_SHOW_MISSING:
      g_value_set_boolean(value, st->inputs.params().show_missing);
      break;
    case PROP_FRAMES_FUSED:
      g_value_set_uint64(value, st->frames);
      break;
    case PROP_RIG:
      g_value_set_string(value, st->rig_path.c_str());
      break;
    case PROP_POSES_CLAMPED:
      g_value_set_uint64(value, st->bounds.clamped());
      break;
    case PROP_UNSEEN_SHARE:
      g_value_set_double(value, st->unseen_share);
      break;
    case PROP_STATS_INTERVAL:
      g_value_set_uint(value, st->stats_interval);
      break;
    case PROP_WARP_SYNC:
      g_value_set_uint64(value, guint64(st->warp_start.params().max_wait_ns));
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
  const FuseInputsParams di;
  g_object_class_install_property(
      gobject_class, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace (docs/pose.md) to play: pose i is sent upstream to every camera branch "
                          "as a vclassroom/pose event (seq i + 1) after output frame i - 1; the last pose is held. "
                          "Empty: poses come from downstream events only",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML file with a navigation section (vclassroom-build-model writes one, "
                          "docs/navigation.md): every pose sent upstream, from any client or the trace, is moved "
                          "into its bounds, with a rate-limited warning. Empty: poses are not bounded",
                          "", GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_POSES_CLAMPED,
      g_param_spec_uint64("poses-clamped", "Poses clamped", "Poses moved into the navigation bounds since start", 0,
                          G_MAXUINT64, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      gobject_class, PROP_UNSEEN_SHARE,
      g_param_spec_double("unseen-share", "Unseen share",
                          "Share of the last picture's pixels that no camera (nor the static model) provided: "
                          "filled, and faded to grey far from anything seen",
                          0, 1, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  g_object_class_install_property(
      gobject_class, PROP_STATS_INTERVAL,
      g_param_spec_uint("stats-interval", "Stats interval",
                        "Post a vclassroom-view-stats element message (frames, unseen-share of that picture, "
                        "poses-clamped) every this many output frames (1: every frame; 0: none)",
                        0, G_MAXUINT, 0, GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS)));
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
      gobject_class, PROP_FILL_TEXTURE,
      g_param_spec_double("fill-texture", "Fill texture",
                          "How much of the background's texture the hole filling carries into a hole: each filled "
                          "pixel gets this share of the detail of its mirror image across the hole's edge on the "
                          "background side, up to 16 px into the hole (0: a smooth fill; costs encoder work "
                          "downstream)",
                          0, 1, d.fill_texture,
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_POSE_WINDOW,
      g_param_spec_uint64("pose-window", "Pose window",
                          "Live: cameras' frames warped for poses the viewer took at most this many ns apart are "
                          "fused together; a frame warped for an older pose is dropped and its fresh one awaited "
                          "(0: only frames of exactly the same pose). The output is stamped with the oldest pose",
                          0, G_MAXINT64, guint64(di.pose_window_ns),
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_CAMERA_TIMEOUT,
      g_param_spec_uint64("camera-timeout", "Camera timeout",
                          "Live: a camera without a frame for this many ns is lost: a bus warning and a "
                          "vclassroom-camera-status element message (camera-id, status lost/returned, silent-ns, "
                          "missing), the same when it returns; the view goes on with the others (0: never lost)",
                          0, G_MAXINT64, guint64(di.camera_timeout_ns),
                          GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_SHOW_MISSING,
      g_param_spec_boolean("show-missing", "Show missing cameras",
                           "Draw a banner naming the lost cameras ('camera 2 missing') into the top-left corner of "
                           "the output; with every camera lost, keep sending the last picture so marked",
                           di.show_missing,
                           GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_WARP_SYNC,
      g_param_spec_uint64("warp-sync", "Warp sync",
                          "Live: each camera's viewwarp waits for the other cameras' next frames before it reads "
                          "the pose, at most two thirds of the cameras' frame interval and never longer than this "
                          "(ns), so they all warp for the same newest pose and a pose shows after one camera "
                          "frame, not after the last of several scattered ones (0: no wait)",
                          0, WarpStartParams::kLongestWaitNs, guint64(WarpStartParams().max_wait_ns),
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
      "events to every input; cameras that are EOS (or, when live, late past the latency) are left out, so is a "
      "camera whose view has another size (with a warning); live, a camera silent for camera-timeout is reported "
      "lost and named on the picture. Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=0 num-buffers=300 ! learnerseg ! viewwarp ! queue ! "
      "f.cam_0 rgbdtestsrc camera-id=2 num-buffers=300 ! learnerseg ! viewwarp ! queue ! "
      "f.cam_2 viewfuse name=f ! videoconvert ! autovideosink",
      "gst-vclassroom developers");
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

static void gst_view_fuse_init(GstViewFuse* self) { self->st = new FuseState(); }
