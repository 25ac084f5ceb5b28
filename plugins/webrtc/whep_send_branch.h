// One WHEP session's video on its way out, for WhepEndpoint:
//   queue (GopSendGate; answers serialized queries) ! rtph264pay (send-time
//   stamps; the playout-delay extension) ! webrtcbin (nothing synced to the clock)
// and, where the offer has Opus and the element has the classroom's sound,
//   queue (leaky, 200 ms) ! rtpopuspay ! webrtcbin
// (the lecturer's voice, where the element takes it, comes out of webrtcbin: WhepEndpoint takes it).
// and, over the session's data channel, the echo of the pose each frame was
// rendered for; from the browser's receiver reports, the session's bitrate
// (LossBasedRate) and whether the lecturer is still there (LecturerSilence).
// Signalling (offer, answer, ICE) stays with the endpoint.
#pragma once

#include <gst/gst.h>
#include <gst/webrtc/webrtc.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gst/vclassroom/webrtc/whep.h>

namespace vclassroom {

struct WhepSendSettings {
  int payload = 96;                // the offer's H.264 payload type
  int playout_extension_id = 0;    // the offer's id for the playout-delay extension; 0: not sent
  int playout_delay_ms = 100;      // its maximum (the minimum is 0)
  int opus_payload = -1;           // the offer's Opus payload type; -1: no audio
  bool send_sound = false;         // the classroom's sound goes to the lecturer there (audio_sink())
  bool take_voice = false;         // the lecturer's voice comes back there (webrtcbin's audio src pad)
  // A stream webrtcbin receives from the browser (its new src pad, from its streaming thread): true when
  // taken (linked); anything not taken goes to a sink of the branch's, since an unlinked pad would stop the
  // whole pipeline (a browser may send what it was not asked for).
  std::function<bool(GstPad* pad)> on_incoming;
  std::vector<IceServer> ice_servers;
  int max_kbit = 4000;  // the element's bitrate: the session's rate starts there and never exceeds it
  // The session's rate changed (LossBasedRate, on a new receiver report with this loss); called from
  // webrtcbin's thread, never after the branch is gone.
  std::function<void(int kbit, double fraction_lost)> on_rate;
  // No receiver report for this long while frames were offered: the lecturer is gone (LecturerSilence);
  // <= 0: never.
  int64_t lecturer_timeout_ns = 0;
};

class WhepSendBranch {
 public:
  // Adds the branch to `owner` and brings it to the owner's state; `session` names it in the log.
  WhepSendBranch(GstBin* owner, const std::string& session, const WhepSendSettings& settings);
  // Takes the elements out of the owner (the caller unlinked the sink pad first).
  ~WhepSendBranch();
  WhepSendBranch(const WhepSendBranch&) = delete;
  WhepSendBranch& operator=(const WhepSendBranch&) = delete;

  GstElement* webrtc() const;
  // Where the encoded view goes in (owned by the branch).
  GstPad* sink() const;
  // Where the classroom's sound (audio/x-opus) goes in, or null (no Opus offered, or settings.send_sound off).
  GstPad* audio_sink() const;
  // Links `pad` (one of webrtcbin's src pads, unlinked) to a sink of the branch's that drops what comes.
  void drain(GstPad* pad);
  // settings.on_incoming's answer for `pad` (false without one).
  bool take_incoming(GstPad* pad);
  // The page's data channel, once it opens one: the echo goes there. False (nothing taken) when the branch
  // has one already: a page opens one channel, others are ignored.
  bool set_echo_channel(GstWebRTCDataChannel* channel);
  // Asks webrtcbin for its statistics; when they hold a receiver report not seen before, its loss updates
  // the session's rate (settings.on_rate). Returns at once; the answer comes in webrtcbin's thread.
  void poll_receiver_reports();
  // Whether the lecturer is gone (settings.lecturer_timeout_ns); *silent_ns: how long no new receiver
  // report came (as far as the polls saw).
  bool lecturer_gone(int64_t* silent_ns) const;

  struct State;
  struct ReportWatch;

 private:
  std::unique_ptr<State> st_;
  std::shared_ptr<ReportWatch> reports_;  // shared with webrtcbin's pending statistics answers
};

}  // namespace vclassroom
