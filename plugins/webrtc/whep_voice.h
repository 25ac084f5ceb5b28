// The lecturers' voices for the classroom, for WhepEndpoint: each session's Opus from its browser
//   (webrtcbin's audio src pad) ! rtpopusdepay ! opusdec (loss concealment) ! audioconvert ! audioresample
// into one audiomixer, beside a silent live source, so the element's `voice` pad (S16LE mono 48 kHz) runs on
// the clock whether or not anyone speaks: the classroom's loudspeaker (and an echo canceller's probe) never
// stall, and a lecturer who leaves is simply no longer in the mix.
#pragma once

#include <gst/gst.h>

#include <map>
#include <mutex>
#include <string>

// What the classroom's loudspeaker gets (the voice pad's caps): a voice needs no more, and one format keeps
// the mix cheap.
#define WHEP_VOICE_CAPS "audio/x-raw, format=S16LE, rate=48000, channels=1, layout=interleaved"

namespace vclassroom {

class WhepVoiceMixer {
 public:
  // Adds the mixer to `owner` and the ghost src pad `voice` (from `templ`) to it.
  WhepVoiceMixer(GstBin* owner, GstPadTemplate* templ);
  // Drops the mixer's own references (the owner disposes of the elements with itself).
  ~WhepVoiceMixer();
  // Takes the mixer, its pad and the sessions' decoders out of the owner (the pad was released); those the
  // owner already let go of (its own disposal releases the pad after its children) are left alone.
  void take_out();
  WhepVoiceMixer(const WhepVoiceMixer&) = delete;
  WhepVoiceMixer& operator=(const WhepVoiceMixer&) = delete;

  GstPad* pad() const { return pad_; }
  // A session's RTP audio (webrtcbin's src pad, Opus) joins the mix; false, with `rtp_src` left unlinked,
  // when it cannot (an element missing, a link refused, the mixer taken out). Any thread.
  bool add(const std::string& session, GstPad* rtp_src);
  // The session's decoder leaves the mix (when it has one); returns the pad it took from (a reference, now
  // unlinked: a pad of a live webrtcbin must then be linked elsewhere), or null. Not from its streaming thread.
  GstPad* remove(const std::string& session);

 private:
  struct Voice {
    GstElement* depay;
    GstElement* decoder;
    GstElement* convert;
    GstElement* resample;
    GstPad* mixer_pad;
    GstPad* rtp_src;  // the session's pad it takes (a reference)
  };
  void remove_voice(const Voice& v);
  GstBin* owner_;
  GstElement* silence_ = nullptr;
  GstElement* mixer_ = nullptr;
  GstElement* caps_ = nullptr;
  GstPad* pad_ = nullptr;
  std::mutex lock_;
  bool closed_ = false;  // taken out: no more voices
  std::map<std::string, Voice> voices_;
};

}  // namespace vclassroom
