// One lecturer's view inside whepviewsink, and the camera inputs the views share:
//   cam_K -> viewprep -> tee -> fakesink (the camera's input, once; the sink drains it when nobody watches)
//   tee -> queue -> viewwarp -> viewfuse.cam_K (per view and camera)
//   viewfuse -> videoconvert -> x264enc -> capsfilter -> (WhepEndpoint's send branch)
// The element (gstwhepviewsink.cpp) keeps the cameras and views under its lock and calls these with it held;
// these only build and take apart the elements.
#pragma once

#include <gst/gst.h>

#include <string>
#include <vector>

#include <gst/vclassroom/net/pose_session.h>
#include <gst/vclassroom/vva/view_turns.h>

namespace vclassroom {

// whepviewsink's properties that shape the views (under the element's lock).
struct WhepViewSettings {
  std::string rig, navigation_rig, model;
  int width = 0, height = 0;
  guint64 fuse_latency = 100 * GST_MSECOND;
  guint64 warp_sync = 100 * GST_MSECOND;
  guint64 longest_turn = 100 * GST_MSECOND;
  int background_memory = 0;  // frames; 0: off
};

struct WhepCamera {
  int index;  // K of the cam_K pad: the viewfuse pad, and cam<K>.png among the model's priors
  GstElement* tee;
};

// A camera's tee and a pad on one side of it: a view's branch input not linked yet, or the tee's request pad.
struct WhepTeeLink {
  GstElement* tee;
  GstPad* pad;  // a reference
};

// One lecturer's view. The camera's viewprep before its tee has done the memory and the warp's first half
// once for all views.
struct WhepView {
  uint64_t id = 0;                    // its number among the views taking turns
  bool started = false;               // its webrtcbin is linked: camera branches are fed at once
  std::vector<WhepTeeLink> unlinked;  // branch inputs until whep_view_start links them to their tees
  std::vector<WhepTeeLink> tee_pads;
  std::vector<GstElement*> elements;
  GstElement* fuse = nullptr;
  GstElement* encoder = nullptr;  // its bitrate follows this lecturer's losses
  PoseSession poses;              // this lecturer's: latest wins
};

// Camera `index`'s input in `bin` (viewprep with the model's prior and empty room, tee, drain), brought to
// the bin's state. The viewprep's sink pad (a reference, for the cam_K ghost pad), or nullptr when viewprep
// or tee is missing.
GstPad* whep_camera_add(GstBin* bin, int index, const WhepViewSettings& settings, WhepCamera* camera);

// Whether every element a view needs is installed; otherwise a warning on `sink` names the one missing.
bool whep_view_elements_present(GstElement* sink);

// The view's fuse and encoder in `bin` (id and poses are the caller's); its encoded source pad (a reference).
GstPad* whep_view_build(GstBin* bin, WhepView* view, const WhepViewSettings& settings, guint bitrate_kbit);

// Camera `camera`'s branch of the view: queue -> viewwarp -> the fuse's cam_K pad, taking its turns from
// `turns`; fed from the camera's tee at once when the view has started (a camera linked while lecturers
// watch), else when it starts.
void whep_view_add_camera(GstBin* bin, WhepView* view, const WhepViewSettings& settings, const WhepCamera& camera,
                          ViewTurns* turns);

// The session's webrtcbin is linked: the cameras' frames flow into the view.
void whep_view_start(WhepView* view);

// Unlinks the view from the tees and takes its elements out of `bin` (its turns are the caller's).
void whep_view_remove(GstBin* bin, WhepView* view);

}  // namespace vclassroom
