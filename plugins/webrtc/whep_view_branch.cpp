#include "whep_view_branch.h"

#include <gst/vclassroom/vva/warp_start.h>

namespace vclassroom {

namespace {

GstElement* add_element(GstBin* bin, WhepView* view, const char* factory) {
  GstElement* e = gst_element_factory_make(factory, nullptr);
  if (!e) return nullptr;
  gst_bin_add(bin, e);
  view->elements.push_back(e);
  return e;
}

// A view's viewwarp takes its turn once viewfuse has let it start (the warp-start query's answer, which
// names the round of the view's cameras), and ends it when its frame is out.
struct TurnTaker {
  ViewTurns* turns;
  uint64_t view;
};

GstPadProbeReturn take_turn(GstPad*, GstPadProbeInfo* info, gpointer data) {
  const TurnTaker* taker = static_cast<const TurnTaker*>(data);
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
    taker->turns->end(taker->view);
    return GST_PAD_PROBE_OK;
  }
  if (!(GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_PULL)) return GST_PAD_PROBE_OK;  // not answered yet
  GstQuery* query = GST_PAD_PROBE_INFO_QUERY(info);
  const GstStructure* s = GST_QUERY_TYPE(query) == GST_QUERY_CUSTOM ? gst_query_get_structure(query) : nullptr;
  guint64 group;
  if (s && gst_structure_has_name(s, kWarpStartQueryName) && gst_structure_get_uint64(s, "group", &group))
    taker->turns->begin(taker->view, group);
  return GST_PAD_PROBE_OK;
}

void link_to_tee(WhepView* view, const WhepTeeLink& input) {
  GstPad* tee_pad = gst_element_request_pad_simple(input.tee, "src_%u");
  gst_pad_link(tee_pad, input.pad);
  gst_object_unref(input.pad);
  view->tee_pads.push_back(WhepTeeLink{input.tee, tee_pad});
}

}  // namespace

GstPad* whep_camera_add(GstBin* bin, int index, const WhepViewSettings& s, WhepCamera* camera) {
  GstElement* prep = gst_element_factory_make("viewprep", nullptr);
  GstElement* tee = gst_element_factory_make("tee", nullptr);
  if (!prep || !tee) {
    if (prep) gst_object_unref(prep);
    if (tee) gst_object_unref(tee);
    return nullptr;
  }
  // The memory and the warp's first half, once for every view of this camera.
  const std::string file = "cam" + std::to_string(index) + ".png";
  if (!s.model.empty()) g_object_set(prep, "prior-depth", (s.model + "/prior-depth/" + file).c_str(), nullptr);
  if (s.background_memory > 0) {
    g_object_set(prep, "background-memory", s.background_memory, nullptr);
    if (!s.model.empty()) g_object_set(prep, "empty-room", (s.model + "/prior-color/" + file).c_str(), nullptr);
  }
  g_object_set(tee, "allow-not-linked", TRUE, nullptr);
  // The camera's one permanent branch: a sink, so the bin posts EOS whether or not anyone watches.
  GstElement* drain = gst_element_factory_make("fakesink", nullptr);
  g_object_set(drain, "sync", FALSE, "async", FALSE, nullptr);
  gst_bin_add_many(bin, prep, tee, drain, nullptr);
  gst_element_link_many(prep, tee, drain, nullptr);
  gst_element_sync_state_with_parent(drain);
  gst_element_sync_state_with_parent(tee);
  gst_element_sync_state_with_parent(prep);
  *camera = WhepCamera{index, tee};
  return gst_element_get_static_pad(prep, "sink");
}

bool whep_view_elements_present(GstElement* sink) {
  for (const char* factory : {"queue", "viewwarp", "viewfuse", "videoconvert", "x264enc", "capsfilter"})
    if (GstElementFactory* f = gst_element_factory_find(factory)) {
      gst_object_unref(f);
    } else {
      GST_ELEMENT_WARNING(sink, CORE, MISSING_PLUGIN, ("no %s element: a lecturer's view cannot be made", factory),
                          ("x264enc is in gstreamer1.0-plugins-ugly"));
      return false;
    }
  return true;
}

GstPad* whep_view_build(GstBin* bin, WhepView* view, const WhepViewSettings& s, guint bitrate_kbit) {
  view->fuse = add_element(bin, view, "viewfuse");
  GstElement* convert = add_element(bin, view, "videoconvert");
  GstElement* encoder = view->encoder = add_element(bin, view, "x264enc");
  GstElement* caps = add_element(bin, view, "capsfilter");
  // Started late in a live pipeline: the fused output starts at the first frame, not at running time 0.
  gst_util_set_object_arg(G_OBJECT(view->fuse), "start-time-selection", "first");
  g_object_set(view->fuse, "latency", s.fuse_latency, "warp-sync", s.warp_sync, nullptr);
  if (!s.navigation_rig.empty()) g_object_set(view->fuse, "rig", s.navigation_rig.c_str(), nullptr);
  gst_util_set_object_arg(G_OBJECT(encoder), "tune", "zerolatency");
  gst_util_set_object_arg(G_OBJECT(encoder), "speed-preset", "ultrafast");
  g_object_set(encoder, "key-int-max", 60, "bitrate", bitrate_kbit, nullptr);
  GstCaps* c = gst_caps_from_string("video/x-h264,profile=constrained-baseline,stream-format=byte-stream");
  g_object_set(caps, "caps", c, nullptr);
  gst_caps_unref(c);
  gst_element_link_many(view->fuse, convert, encoder, caps, nullptr);
  for (auto it = view->elements.rbegin(); it != view->elements.rend(); ++it) gst_element_sync_state_with_parent(*it);
  return gst_element_get_static_pad(caps, "src");
}

void whep_view_add_camera(GstBin* bin, WhepView* view, const WhepViewSettings& s, const WhepCamera& cam,
                          ViewTurns* turns) {
  GstElement* queue = add_element(bin, view, "queue");
  GstElement* warp = add_element(bin, view, "viewwarp");
  g_object_set(queue, "max-size-buffers", 1, "max-size-time", guint64(0), "max-size-bytes", 0, nullptr);
  gst_util_set_object_arg(G_OBJECT(queue), "leaky", "downstream");
  g_object_set(warp, "width", s.width, "height", s.height, nullptr);
  if (!s.rig.empty()) g_object_set(warp, "rig", s.rig.c_str(), nullptr);
  gst_element_link(queue, warp);
  GstPad* warp_src = gst_element_get_static_pad(warp, "src");
  gst_pad_add_probe(warp_src, GstPadProbeType(GST_PAD_PROBE_TYPE_QUERY_DOWNSTREAM | GST_PAD_PROBE_TYPE_BUFFER), take_turn,
                    new TurnTaker{turns, view->id}, [](gpointer p) { delete static_cast<TurnTaker*>(p); });
  gst_object_unref(warp_src);
  const std::string fuse_pad = "cam_" + std::to_string(cam.index);
  gst_element_link_pads(warp, "src", view->fuse, fuse_pad.c_str());
  gst_element_sync_state_with_parent(warp);
  gst_element_sync_state_with_parent(queue);
  const WhepTeeLink input{cam.tee, gst_element_get_static_pad(queue, "sink")};
  if (view->started)
    link_to_tee(view, input);
  else
    view->unlinked.push_back(input);
}

void whep_view_start(WhepView* view) {
  for (const WhepTeeLink& input : view->unlinked) link_to_tee(view, input);
  view->unlinked.clear();
  view->started = true;
}

void whep_view_remove(GstBin* bin, WhepView* view) {
  for (const WhepTeeLink& input : view->unlinked) gst_object_unref(input.pad);  // never started
  view->unlinked.clear();
  for (const WhepTeeLink& link : view->tee_pads) {
    GstPad* peer = gst_pad_get_peer(link.pad);
    if (peer) {
      gst_pad_unlink(link.pad, peer);
      gst_object_unref(peer);
    }
    gst_element_release_request_pad(link.tee, link.pad);
    gst_object_unref(link.pad);
  }
  view->tee_pads.clear();
  for (GstElement* e : view->elements) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(bin, e);
  }
  view->elements.clear();
}

}  // namespace vclassroom
