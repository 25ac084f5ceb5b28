// viewfuse's output: the fused picture sent with its pose meta and the banner of missing cameras, the
// messages that report it (camera status, view stats), and the latency its unconnected camera branches answer.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <memory>

#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/vva/prepared_frame.h>

#include "gstviewfuse_state.h"

namespace vclassroom {

// Running time on the element's clock now; GST_CLOCK_TIME_NONE without a clock.
GstClockTime running_time_now(GstElement* element) {
  GstClock* clock = gst_element_get_clock(element);
  if (!clock) return GST_CLOCK_TIME_NONE;
  const GstClockTime now = gst_clock_get_time(clock);
  gst_object_unref(clock);
  const GstClockTime base = gst_element_get_base_time(element);
  return now > base ? now - base : 0;
}

// Drops the queued frame of every pad whose verdict is `which`.
void drop_buffers(const std::vector<GstAggregatorPad*>& pads, const std::vector<FrameVerdict>& verdicts,
                         FrameVerdict which) {
  for (size_t i = 0; i < pads.size(); ++i)
    if (verdicts[i] == which) gst_aggregator_pad_drop_buffer(pads[i]);
}

// A camera lost or back: a bus warning (lost) or info (back) for a person and
// a vclassroom-camera-status element message for programs.
void post_camera_status(GstViewFuse* self, const CameraStatusChange& change, const std::vector<int>& missing,
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
GstFlowReturn push_picture(GstViewFuse* self, const std::string& banner, GstClockTime rt,
                                  GstClockTime duration, const WarpedPose* pose) {
  GstAggregator* agg = GST_AGGREGATOR(self);
  ViewFuseState* st = self->st;
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

// The room of the cameras whose viewwarp warped only the learners (their RoomViewPart, one per fused frame or
// null), into st->room, at the view of the frame the picture names (`named`, an index into `parts`; else the
// first part's); false when there is none to draw. A part warped for a view of another size is left out.
bool draw_room(GstViewFuse* self, const std::vector<std::shared_ptr<const RoomViewPart>>& parts, int named,
               cv::Size size, const FuseParams& params) {
  ViewFuseState* st = self->st;
  std::vector<RoomCamera> cameras;
  const RoomViewPart* view_of = named >= 0 && parts[size_t(named)] ? parts[size_t(named)].get() : nullptr;
  for (const auto& p : parts) {
    if (!p || p->view.width != size.width || p->view.height != size.height) continue;
    cameras.push_back(RoomCamera{p->frame->room_shape.get(), p->texture});
    if (!view_of) view_of = p.get();
  }
  if (cameras.empty()) return false;
  GST_LOG_OBJECT(self, "the room of %zu camera(s) drawn", cameras.size());
  share_room_planes(size, &st->fused, &st->room);  // the room drawn into the picture, fused there in place
  st->room_renderer.render(cameras, view_of->view, room_lookup_params(params), &st->room);
  return true;
}

// Takes the round into ViewFuseState::learner_rounds: the cameras the next warps are told, and whether every
// camera a far one left its learners to drew its own in this round. Where one did not (its frame dropped or
// late, the camera lost, or its warp read another pose and left its learners too), nobody drew those
// learners: the round is not shown (the last picture stays), and the next warps, not told that camera until
// it is steady again, draw their own.
static bool learners_complete(GstViewFuse* self, const std::vector<RoundFrame>& round) {
  ViewFuseState* st = self->st;
  const bool complete = st->learner_rounds.take(round);
  std::lock_guard<std::mutex> g(st->lock);
  st->room_cameras = st->learner_rounds.steady();
  if (!complete) {
    ++st->rounds_without_learners;
    GST_DEBUG_OBJECT(self, "a round without a camera others left their learners to: not shown (%" G_GUINT64_FORMAT
                     " so far)", st->rounds_without_learners);
  }
  return complete;
}

// Maps the frames to fuse, fuses them and sends the picture (stamped as output_stamp() says).
GstFlowReturn fuse_and_push(GstViewFuse* self, const std::vector<GstAggregatorPad*>& pads,
                                   const std::vector<GstBuffer*>& bufs, const std::vector<RgbdInfo>& infos,
                                   const std::vector<PendingFrame>& pending, const FuseRound& round,
                                   const FuseParams& params) {
  ViewFuseState* st = self->st;
  std::vector<WarpedView> views(pads.size());
  std::vector<const WarpedView*> ptrs;
  std::vector<std::unique_ptr<RgbdFrame>> frames;
  std::vector<FrameStamp> stamps;
  std::vector<size_t> fused;  // the index of each of them among the pads
  std::vector<std::shared_ptr<const RoomViewPart>> room_parts;  // per fused frame: its room to draw here, or null
  std::vector<RoundFrame> round_frames;                          // per fused frame: who drew its learners
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
    views[i] = WarpedView{f->color(), f->depth(), f->label(), f->plane(Plane::Weight), SampleTiles()};
    room_parts.push_back(buffer_get_room_view_part(bufs[i]));
    // The caps name the source camera's id but the view's geometry: the camera's own is its room's.
    round_frames.push_back(RoundFrame{RoomCameraPlace{infos[i].camera.id, Eigen::Vector3d::Zero()}, false, {}});
    if (const auto& part = room_parts.back()) {
      views[i].tiles = part->tiles;
      const CameraCalib& source = part->frame->room_shape->camera();
      round_frames.back() = RoundFrame{RoomCameraPlace{source.id, source.center_in_rig()}, true, part->learners_left_to};
    }
    ptrs.push_back(&views[i]);
    frames.push_back(std::move(f));
    stamps.push_back(FrameStamp{pending[i].running_time_ns, pending[i].pose});
    fused.push_back(i);
  }
  // (A round of gaps alone is not taken: the cameras' streaks go on from the round before.)
  if (ptrs.empty() || !st->have_out || !learners_complete(self, round_frames)) {
    drop_buffers(pads, round.verdicts, FrameVerdict::kFuse);
    return GST_FLOW_OK;
  }
  const OutputStamp stamp = output_stamp(stamps);
  const WarpedPose pose = stamp.pose_from < 0 ? WarpedPose{} : stamps[size_t(stamp.pose_from)].pose;
  if (!same_rendered_view(pose, st->fill_pose)) st->fill_history.clear();  // another view: nothing to keep
  st->fill_pose = pose;
  try {
    FuseParams fuse = params;
    if (draw_room(self, room_parts, stamp.pose_from, ptrs.front()->depth.size(), params)) {
      ptrs.insert(ptrs.begin(), &st->room);  // the room first, the learners over it
      fuse.first_is_base = true;
    }
    fuse_views(ptrs, fuse, &st->fused, &st->fill_history);
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
  const GstClockTime rt = stamp.time_from < 0 ? GST_CLOCK_TIME_NONE : clock_time(stamps[stamp.time_from].running_time_ns);
  const GstClockTime duration = stamp.time_from < 0 ? GST_CLOCK_TIME_NONE : GST_BUFFER_DURATION(bufs[fused[stamp.time_from]]);
  GST_LOG_OBJECT(self, "fused %zu inputs", ptrs.size());
  return push_picture(self, round.banner, rt, duration, stamp.pose_from < 0 ? nullptr : &stamps[stamp.pose_from].pose);
}

namespace {

gboolean on_first_camera_due(GstClock*, GstClockTime, GstClockID, gpointer data) {
  GstViewFuse* self = GST_VIEW_FUSE(data);
  ViewFuseState* st = self->st;
  bool seen = false;
  int64_t timeout = 0;
  {
    std::lock_guard<std::mutex> g(st->lock);
    seen = bool(st->inputs.first_accepted());
    timeout = st->inputs.params().camera_timeout_ns;
  }
  if (!seen)
    GST_ELEMENT_WARNING(self, STREAM, FAILED,
                        ("no camera has sent a frame in the %.1f s since the view started: the lecturer sees nothing "
                         "until one does",
                         double(timeout) / 1e9),
                        ("%d camera input(s) linked", GST_ELEMENT(self)->numsinkpads));
  return TRUE;
}

}  // namespace

void watch_for_first_camera(GstViewFuse* self, bool on) {
  ViewFuseState* st = self->st;
  GstClockID previous = nullptr;
  int64_t timeout = 0;
  bool seen = false;
  {
    std::lock_guard<std::mutex> g(st->lock);
    std::swap(previous, st->first_camera_watch);
    timeout = st->inputs.params().camera_timeout_ns;
    seen = bool(st->inputs.first_accepted());
  }
  if (previous) {
    gst_clock_id_unschedule(previous);
    gst_clock_id_unref(previous);
  }
  if (!on || timeout <= 0 || seen) return;
  GstClock* clock = gst_element_get_clock(GST_ELEMENT(self));
  if (!clock) return;
  GstClockID id = gst_clock_new_single_shot_id(clock, gst_element_get_base_time(GST_ELEMENT(self)) + GstClockTime(timeout));
  gst_object_unref(clock);
  if (gst_clock_id_wait_async(id, on_first_camera_due, gst_object_ref(self), gst_object_unref) != GST_CLOCK_OK) {
    gst_clock_id_unref(id);
    return;
  }
  std::lock_guard<std::mutex> g(st->lock);
  st->first_camera_watch = id;
}

// GstAggregator asks every sink pad's upstream for its latency and, when one
// cannot answer, takes the whole element for not live: it then waits for a
// frame on every pad, forever for a camera that never sends. A camera branch
// cannot answer while it is not connected to its source yet (server.sh's
// rtpssrcdemux makes the camera's pad at its first packet). Such a branch is
// answered here as an unlinked pad would be (GStreamer leaves those out): no
// latency of its own, so the view is live with the cameras that send.
GstPadProbeReturn answer_latency_of_unconnected_branch(GstPad* pad, GstPadProbeInfo* info, gpointer) {
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

}  // namespace vclassroom
