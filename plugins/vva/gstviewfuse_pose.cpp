// viewfuse's poses upstream: every client's pose, and its own trace's, to every camera branch inside the
// navigation bounds (docs/navigation.md, docs/vva.md).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/vva/virtual_view.h>

#include "gstviewfuse_state.h"

namespace vclassroom {

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

void forward_pose(GstViewFuse* self, GstEvent* event) {
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

void send_trace_pose(GstViewFuse* self) {
  ViewFuseState* st = self->st;
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


}  // namespace vclassroom
