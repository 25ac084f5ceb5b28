#include "pose_rtp_task.h"

#include "poseback.h"

GST_DEBUG_CATEGORY_EXTERN(pose_send_debug);
#define GST_CAT_DEFAULT pose_send_debug

namespace vclassroom {

namespace {
// Packets made but not yet pushed: a handful is plenty (a newer pose makes the older ones moot), so beyond
// this the oldest is dropped.
constexpr size_t kOutboxLimit = 32;
}  // namespace

PoseRtpTask::~PoseRtpTask() {
  for (GstBuffer* b : outbox_) gst_buffer_unref(b);
}

gboolean PoseRtpTask::activate(GstPadMode mode, gboolean active) {
  if (mode != GST_PAD_MODE_PUSH) return FALSE;
  {
    std::lock_guard<std::mutex> g(lock_);
    flushing_ = !active;
    started_ = eos_pending_ = eos_sent_ = false;
    for (GstBuffer* b : outbox_) gst_buffer_unref(b);
    outbox_.clear();
    wake_.notify_all();
  }
  return active ? gst_pad_start_task(pad_, loop, this, nullptr) : gst_pad_stop_task(pad_);
}

void PoseRtpTask::set_stream(guint payload_type, guint32 ssrc) {
  std::lock_guard<std::mutex> g(lock_);
  payload_type_ = payload_type;
  ssrc_ = ssrc;
}

bool PoseRtpTask::accepting() {
  std::lock_guard<std::mutex> g(lock_);
  return !flushing_ && !eos_pending_ && !eos_sent_;
}

void PoseRtpTask::push(GstBuffer* packet) {
  std::lock_guard<std::mutex> g(lock_);
  if (flushing_ || eos_pending_ || eos_sent_) {
    gst_buffer_unref(packet);
    return;
  }
  if (outbox_.size() >= kOutboxLimit) {
    gst_buffer_unref(outbox_.front());
    outbox_.pop_front();
  }
  outbox_.push_back(packet);
  wake_.notify_one();
}

void PoseRtpTask::end() {
  std::lock_guard<std::mutex> g(lock_);
  if (!eos_sent_) eos_pending_ = true;
  wake_.notify_one();
}

guint64 PoseRtpTask::sent() {
  std::lock_guard<std::mutex> g(lock_);
  return sent_;
}

// Stream-start, caps, segment and a GAP; the lock is released while pushing them.
void PoseRtpTask::start_stream(std::unique_lock<std::mutex>& lk) {
  started_ = true;
  GstCaps* caps = gst_caps_from_string(kPoseRtpCaps);
  gst_caps_set_simple(caps, "payload", G_TYPE_INT, static_cast<int>(payload_type_), "ssrc", G_TYPE_UINT, ssrc_,
                      nullptr);
  lk.unlock();
  gchar* id = gst_pad_create_stream_id(pad_, GST_ELEMENT(GST_PAD_PARENT(pad_)), "pose");
  gst_pad_push_event(pad_, gst_event_new_stream_start(id));
  g_free(id);
  gst_pad_push_event(pad_, gst_event_new_caps(caps));
  gst_caps_unref(caps);
  GstSegment seg;
  gst_segment_init(&seg, GST_FORMAT_TIME);
  gst_pad_push_event(pad_, gst_event_new_segment(&seg));
  // A sparse stream: the GAP lets a sink preroll before the first pose.
  gst_pad_push_event(pad_, gst_event_new_gap(0, GST_CLOCK_TIME_NONE));
}

// Starts the stream, then pushes what the outbox holds, then EOS; the lock is released while pushing.
void PoseRtpTask::loop(gpointer data) {
  PoseRtpTask* self = static_cast<PoseRtpTask*>(data);
  std::unique_lock<std::mutex> lk(self->lock_);
  if (!self->started_) {
    self->start_stream(lk);
    return;
  }
  self->wake_.wait(lk, [self] { return self->flushing_ || !self->outbox_.empty() || self->eos_pending_; });
  if (self->flushing_) {
    lk.unlock();
    gst_pad_pause_task(self->pad_);
    return;
  }
  if (!self->outbox_.empty()) {
    GstBuffer* buf = self->outbox_.front();
    self->outbox_.pop_front();
    lk.unlock();
    const GstFlowReturn r = gst_pad_push(self->pad_, buf);
    if (r == GST_FLOW_OK) {
      std::lock_guard<std::mutex> g(self->lock_);
      self->sent_++;
    } else if (r != GST_FLOW_NOT_LINKED) {
      GST_DEBUG_OBJECT(self->pad_, "pose push: %s", gst_flow_get_name(r));
    }
    return;
  }
  self->eos_pending_ = false;
  self->eos_sent_ = true;
  lk.unlock();
  gst_pad_push_event(self->pad_, gst_event_new_eos());
  gst_pad_pause_task(self->pad_);
}

}  // namespace vclassroom
