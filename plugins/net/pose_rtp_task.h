// posesend's rtp pad: the pose packets leave from the pad's own thread (a pad task), never from the thread
// that made them.
//
// Pose events arrive from downstream in the video streaming thread (posenav sends them while it handles a
// frame), and the video frames themselves push repeats in that thread too. Pushed there, a packet went
// synchronously into the rtp branch's sink; in a non-live pipeline that sink blocks every buffer in its
// preroll wait until the pipeline is PLAYING, and the pipeline reaches PLAYING only when the video sink has
// prerolled too, which it never does, since its only streaming thread is the one held in the other sink: a
// deadlock (a queue after the rtp pad used to hide it by giving the branch a thread of its own). The task is
// that thread. It also starts the rtp stream at once (stream-start, caps, segment and a GAP event, which
// prerolls a sink without any packet), so end-of-stream can always follow, whether or not a pose was ever
// sent.
#pragma once

#include <gst/gst.h>

#include <condition_variable>
#include <deque>
#include <mutex>

namespace vclassroom {

class PoseRtpTask {
 public:
  explicit PoseRtpTask(GstPad* rtppad) : pad_(rtppad) {}
  ~PoseRtpTask();
  PoseRtpTask(const PoseRtpTask&) = delete;
  PoseRtpTask& operator=(const PoseRtpTask&) = delete;

  // The rtp pad's activate_mode (push mode only): starts the task, or stops it after flushing the packets
  // not pushed yet.
  gboolean activate(GstPadMode mode, gboolean active);
  // The caps of the stream the next activation starts (the pad's template caps with these).
  void set_stream(guint payload_type, guint32 ssrc);
  // Whether a packet given now would be pushed: the pad is active and the stream has not ended.
  bool accepting();
  // Queues a packet for the task (taking it); beyond a handful the oldest is dropped, since a newer pose
  // makes the older ones moot. Dropped at once when not accepting.
  void push(GstBuffer* packet);
  // The stream ends after the packets queued (the video ended), whether or not a pose was sent.
  void end();
  // Packets pushed downstream so far.
  guint64 sent();

 private:
  static void loop(gpointer self);
  void start_stream(std::unique_lock<std::mutex>& lk);

  GstPad* const pad_;
  std::mutex lock_;               // all below; never held while pushing
  std::condition_variable wake_;  // the task waits on it for packets, EOS or flushing
  guint payload_type_ = 96;
  guint32 ssrc_ = 0;
  std::deque<GstBuffer*> outbox_;
  bool started_ = false;      // the task has sent stream-start, caps, segment and GAP
  bool eos_pending_ = false;  // EOS is to follow the packets in the outbox
  bool eos_sent_ = false;
  bool flushing_ = true;  // the pad is inactive: the task stops
  guint64 sent_ = 0;
};

}  // namespace vclassroom
