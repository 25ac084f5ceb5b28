// The WHEP side of the browser lecturer, shared by whepserversink (one view for
// every lecturer) and whepviewsink (a view per lecturer): the libsoup 3 server in
// its own thread (page, token, OPTIONS/POST/DELETE, STUN/TURN servers), one
// session per lecturer fed by an H.264 source the element provides, through a
// WhepSendBranch (whep_send_branch.h: queue, payloader, webrtcbin, the echo), and
// the pose data channel.
// Request checks, session ids and message formats are the library's
// (gst/vclassroom/webrtc/whep.h); this is their GStreamer/libsoup glue.
#pragma once

#include <gst/gst.h>

#include <functional>
#include <memory>
#include <string>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

// What the element does for a session.
struct WhepEndpointHooks {
  // Adds the session's encoded video to the element's bin and returns (a reference to) its source pad:
  // H.264 constrained baseline, byte-stream, whose buffers keep the frames' pose meta. nullptr refuses the
  // session (the POST gets 503). Called from the WHEP server's thread, without the endpoint's lock.
  std::function<GstPad*(const std::string& session)> attach;
  // Optional: the session's branch is linked and playing, the element may start feeding its source (until
  // then an element whose source is not a tee's must hold its data back: an unlinked pad stops a stream).
  std::function<void(const std::string& session)> start;
  // Takes that source out again; the endpoint has unlinked `pad` and removed its own elements.
  std::function<void(const std::string& session, GstPad* pad)> detach;
  // A well-formed, plausible pose from the session's page (parse_pose_message, pose_is_plausible).
  std::function<void(const std::string& session, const Pose& pose)> pose;
  // Optional: the session's bitrate (kbit/s, at most the bitrate property) after its browser reported
  // losses (LossBasedRate); the element sets its encoder. Called from webrtcbin's thread.
  std::function<void(const std::string& session, int kbit)> rate;
};

class WhepEndpoint {
 public:
  WhepEndpoint(GstBin* owner, const char* debug_name, WhepEndpointHooks hooks);
  ~WhepEndpoint();
  WhepEndpoint(const WhepEndpoint&) = delete;
  WhepEndpoint& operator=(const WhepEndpoint&) = delete;

  // The endpoint's properties (port, token, tls-certificate, tls-key, bitrate, max-sessions, web-root,
  // bound-port, sessions, playout-delay, stun-server, turn-server, lecturer-timeout, listen-addresses,
  // http-timeout, max-connections, max-connections-per-address) on the element's class, with ids from `first_id`; returns the next free id.
  static guint install_properties(GObjectClass* klass, guint first_id);
  // False when `id` is not one of the endpoint's.
  bool set_property(guint id, const GValue* value);
  bool get_property(guint id, GValue* value);

  guint bitrate_kbit() const;
  // The element's request pads for sound, by the template's name (null for another, or one it has already):
  //  - "audio" (sink, audio/x-opus): the classroom's sound, a ghost pad of a tee in the element's bin that
  //    every session whose offer takes Opus gets a branch of (sessions started before it go on without);
  //  - "voice" (src, audio/x-raw): the lecturers' voices mixed for the classroom (WhepVoiceMixer), from
  //    every session whose browser sends its microphone (sessions started before it are not heard).
  // Call release_pad from the element's release_pad: false when `pad` is neither.
  GstPad* request_pad(GstPadTemplate* templ);
  bool release_pad(GstPad* pad);
  // Those two pads' templates, on the element's class.
  static void add_sound_pad_templates(GstElementClass* klass);
  // NULL -> READY: checks the settings and listens; false after posting an error on the owner.
  bool start();
  // READY -> NULL: ends every session and stops listening.
  void stop();

  struct State;

 private:
  std::unique_ptr<State> st_;
};

}  // namespace vclassroom
