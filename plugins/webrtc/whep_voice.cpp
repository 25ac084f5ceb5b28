#include "whep_voice.h"

#include <utility>

namespace vclassroom {

namespace {

// A reference of the mixer's own (beside the bin's): the pointer stays valid whatever the bin does.
GstElement* make(const char* factory) {
  GstElement* e = gst_element_factory_make(factory, nullptr);
  if (!e) GST_WARNING("no element %s: the lecturers' voices need it (gstreamer1.0-plugins-base/good)", factory);
  return e ? GST_ELEMENT(gst_object_ref_sink(e)) : nullptr;
}

// Takes `e` out of `owner` where it still is in it, and drops the mixer's reference.
void take_out_of(GstBin* owner, GstElement* e) {
  if (!e) return;
  if (GST_OBJECT_PARENT(e) == GST_OBJECT_CAST(owner)) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(owner, e);
  }
  gst_object_unref(e);
}

}  // namespace

WhepVoiceMixer::WhepVoiceMixer(GstBin* owner, GstPadTemplate* templ) : owner_(owner) {
  silence_ = make("audiotestsrc");
  mixer_ = make("audiomixer");
  caps_ = make("capsfilter");
  if (!silence_ || !mixer_ || !caps_) {
    for (GstElement** e : {&silence_, &mixer_, &caps_})
      if (*e) gst_object_unref(std::exchange(*e, nullptr));
    return;
  }
  g_object_set(silence_, "wave", 4 /* silence */, "is-live", TRUE, "samplesperbuffer", 960, nullptr);
  GstCaps* caps = gst_caps_from_string(WHEP_VOICE_CAPS);
  g_object_set(caps_, "caps", caps, nullptr);
  gst_caps_unref(caps);
  gst_bin_add_many(owner_, silence_, mixer_, caps_, nullptr);
  gst_element_link_many(silence_, mixer_, caps_, nullptr);
  GstPad* target = gst_element_get_static_pad(caps_, "src");
  pad_ = gst_ghost_pad_new_from_template("voice", target, templ);
  gst_object_unref(target);
  gst_pad_set_active(pad_, TRUE);
  gst_element_add_pad(GST_ELEMENT(owner_), pad_);
  for (GstElement* e : {caps_, mixer_, silence_}) gst_element_sync_state_with_parent(e);
}

void WhepVoiceMixer::take_out() {
  std::map<std::string, Voice> voices;
  {
    std::lock_guard<std::mutex> g(lock_);
    closed_ = true;
    voices.swap(voices_);
  }
  for (auto& v : voices) {
    remove_voice(v.second);
    gst_object_unref(v.second.rtp_src);
  }
  if (pad_) gst_element_remove_pad(GST_ELEMENT(owner_), pad_);
  pad_ = nullptr;
  for (GstElement** e : {&silence_, &mixer_, &caps_}) take_out_of(owner_, std::exchange(*e, nullptr));
}

WhepVoiceMixer::~WhepVoiceMixer() {
  for (auto& v : voices_)
    for (GstElement* e : {v.second.depay, v.second.decoder, v.second.convert, v.second.resample}) gst_object_unref(e);
  for (auto& v : voices_) gst_object_unref(v.second.mixer_pad);
  for (auto& v : voices_) gst_object_unref(v.second.rtp_src);
  for (GstElement* e : {silence_, mixer_, caps_})
    if (e) gst_object_unref(e);
}

bool WhepVoiceMixer::add(const std::string& session, GstPad* rtp_src) {
  {
    std::lock_guard<std::mutex> g(lock_);
    if (closed_ || !mixer_) return false;
  }
  Voice v{make("rtpopusdepay"), make("opusdec"), make("audioconvert"), make("audioresample"), nullptr,
          GST_PAD(gst_object_ref(rtp_src))};
  if (!v.depay || !v.decoder || !v.convert || !v.resample) {
    for (GstElement* e : {v.depay, v.decoder, v.convert, v.resample})
      if (e) gst_object_unref(e);
    gst_object_unref(v.rtp_src);
    return false;
  }
  // A lost packet is concealed (and, where the browser sent it, rebuilt from the next one's FEC).
  g_object_set(v.decoder, "plc", TRUE, "use-inband-fec", TRUE, nullptr);
  gst_bin_add_many(owner_, v.depay, v.decoder, v.convert, v.resample, nullptr);
  gst_element_link_many(v.depay, v.decoder, v.convert, v.resample, nullptr);
  v.mixer_pad = gst_element_request_pad_simple(mixer_, "sink_%u");
  GstPad* out = gst_element_get_static_pad(v.resample, "src");
  GstPad* in = gst_element_get_static_pad(v.depay, "sink");
  const bool linked = gst_pad_link(out, v.mixer_pad) == GST_PAD_LINK_OK;
  gst_object_unref(out);
  for (GstElement* e : {v.resample, v.convert, v.decoder, v.depay}) gst_element_sync_state_with_parent(e);
  const bool joined = linked && gst_pad_link(rtp_src, in) == GST_PAD_LINK_OK;
  gst_object_unref(in);
  if (!joined) {
    remove_voice(v);
    gst_object_unref(v.rtp_src);
    return false;
  }
  Voice previous{};
  bool replaced = false;
  {
    std::lock_guard<std::mutex> g(lock_);
    auto old = voices_.find(session);
    replaced = old != voices_.end();
    if (replaced) previous = old->second;
    voices_[session] = v;
  }
  if (replaced) {
    remove_voice(previous);
    gst_object_unref(previous.rtp_src);
  }
  return true;
}

GstPad* WhepVoiceMixer::remove(const std::string& session) {
  Voice v{};
  {
    std::lock_guard<std::mutex> g(lock_);
    auto it = voices_.find(session);
    if (it == voices_.end()) return nullptr;
    v = it->second;
    voices_.erase(it);
  }
  remove_voice(v);
  return v.rtp_src;
}

void WhepVoiceMixer::remove_voice(const Voice& v) {
  for (GstElement* e : {v.depay, v.decoder, v.convert, v.resample}) take_out_of(owner_, e);
  if (!v.mixer_pad) return;
  if (mixer_ && GST_OBJECT_PARENT(v.mixer_pad) == GST_OBJECT_CAST(mixer_))
    gst_element_release_request_pad(mixer_, v.mixer_pad);
  gst_object_unref(v.mixer_pad);
}

}  // namespace vclassroom
