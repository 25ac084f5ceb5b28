/**
 * SECTION:element-viewprep
 * @title: viewprep
 *
 * Prepares one camera's frames once for every lecturer's view (docs/vva.md): the background memory and the
 * half of the warp that does not depend on the lecturer's pose (layered depth, smoothed steps, rims). The
 * frames pass unchanged, with the prepared frame as a meta that each viewwarp downstream takes when its
 * edge-to-near and boundary are the same as viewprep's (a viewwarp set otherwise prepares the frame itself).
 * Put it before the tee that feeds several views.
 *
 * prior-depth (a 16-bit PNG in mm of the empty classroom seen by this camera) is the static layer's depth;
 * without it the stream's depth is used everywhere. background-memory keeps that many frames of the static
 * room's colour, and with prior-depth the room behind the learners; empty-room (an RGB image of the empty
 * classroom) is what the memory starts from. A stream of another size than these images is prepared
 * without them, with a warning.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=10 ! learnerseg ! viewprep background-memory=8 ! tee name=t t. ! queue ! viewwarp ! fakesink t. ! queue ! viewwarp ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewprep.h"

#include <string>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/prepared_frame.h>

GST_DEBUG_CATEGORY_STATIC(view_prep_debug);
#define GST_CAT_DEFAULT view_prep_debug

using namespace vclassroom;

enum { PROP_0, PROP_PRIOR_DEPTH, PROP_BACKGROUND_MEMORY, PROP_EMPTY_ROOM, PROP_EDGE_TO_NEAR, PROP_BOUNDARY };

namespace {

struct Settings {  // the properties, under the base's lock
  std::string prior_path, empty_room_path;
  int memory_frames = 0;
  bool edge_to_near = true;
  int boundary_px = 0;
};

struct PrepState {
  Settings settings;
  // Streaming thread only.
  cv::Mat prior, empty_room;
  FramePreparer preparer;
};

}  // namespace

struct _GstViewPrep {
  GstRgbdFilter parent;
  PrepState* st;
};

G_DEFINE_TYPE(GstViewPrep, gst_view_prep, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(viewprep, "viewprep", GST_RANK_NONE, GST_TYPE_VIEW_PREP);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_view_prep_start(GstBaseTransform* trans) {
  GstRgbdFilter* filter = GST_RGBD_FILTER(trans);
  PrepState* st = GST_VIEW_PREP(trans)->st;
  const Settings s = rgbd_filter_settings(filter, st->settings);
  st->prior.release();
  st->empty_room.release();
  return rgbd_filter_guard_setup(filter, "properties prior-depth and empty-room", [&] {
    if (!s.prior_path.empty()) st->prior = load_static_depth(s.prior_path);
    if (!s.empty_room_path.empty()) st->empty_room = load_empty_room(s.empty_room_path);
    return true;
  });
}

static gboolean gst_view_prep_set_info(GstRgbdFilter* filter, const RgbdInfo& info, const RgbdInfo&) {
  PrepState* st = GST_VIEW_PREP(filter)->st;
  // As viewwarp: a camera that changes its size is prepared without the prior and seed made for the other.
  const cv::Size size(info.width(), info.height());
  const bool prior_fits = st->prior.empty() || st->prior.size() == size;
  const bool seed_fits = st->empty_room.empty() || st->empty_room.size() == size;
  if (!prior_fits || !seed_fits)
    GST_ELEMENT_WARNING(filter, RESOURCE, SETTINGS,
                        ("prior-depth or empty-room is not of camera %d's size %dx%d: prepared without it",
                         info.camera.id, size.width, size.height),
                        (nullptr));
  st->preparer.set_static_depth(prior_fits ? st->prior : cv::Mat());
  return TRUE;
}

static void gst_view_prep_transform_frame_ip(GstRgbdFilter* filter, GstBuffer* buf, const RgbdFrame& frame) {
  PrepState* st = GST_VIEW_PREP(filter)->st;
  const Settings s = rgbd_filter_settings(filter, st->settings);
  WarpParams params;
  params.edge_to_near = s.edge_to_near;
  params.boundary_px = s.boundary_px;
  st->preparer.set_memory(s.memory_frames, st->empty_room);
  const RgbdInfo& info = rgbd_filter_in_info(filter);
  buffer_add_prepared_frame(buf, st->preparer.prepare(info.camera, frame.color(), frame.depth(), frame.label(), params));
}

static void gst_view_prep_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  Settings& s = GST_VIEW_PREP(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (id) {
    case PROP_PRIOR_DEPTH: s.prior_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_EMPTY_ROOM: s.empty_room_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_BACKGROUND_MEMORY: s.memory_frames = g_value_get_int(value); break;
    case PROP_EDGE_TO_NEAR: s.edge_to_near = g_value_get_boolean(value); break;
    case PROP_BOUNDARY: s.boundary_px = g_value_get_int(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_view_prep_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  const Settings& s = GST_VIEW_PREP(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (id) {
    case PROP_PRIOR_DEPTH: g_value_set_string(value, s.prior_path.c_str()); break;
    case PROP_EMPTY_ROOM: g_value_set_string(value, s.empty_room_path.c_str()); break;
    case PROP_BACKGROUND_MEMORY: g_value_set_int(value, s.memory_frames); break;
    case PROP_EDGE_TO_NEAR: g_value_set_boolean(value, s.edge_to_near); break;
    case PROP_BOUNDARY: g_value_set_int(value, s.boundary_px); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_view_prep_init(GstViewPrep* self) { self->st = new PrepState; }

static void gst_view_prep_finalize(GObject* object) {
  delete GST_VIEW_PREP(object)->st;
  G_OBJECT_CLASS(gst_view_prep_parent_class)->finalize(object);
}

static void gst_view_prep_class_init(GstViewPrepClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstRgbdFilterClass* filter_class = GST_RGBD_FILTER_CLASS(klass);
  GST_DEBUG_CATEGORY_INIT(view_prep_debug, "viewprep", 0, "A camera's frames prepared once for every view");
  gobject_class->set_property = gst_view_prep_set_property;
  gobject_class->get_property = gst_view_prep_get_property;
  gobject_class->finalize = gst_view_prep_finalize;
  const GParamFlags ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const GParamFlags playing = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(gobject_class, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth",
                          "As viewwarp's: 16-bit PNG (mm) of the empty room (empty: the stream's depth)", "", ready));
  g_object_class_install_property(gobject_class, PROP_BACKGROUND_MEMORY,
      g_param_spec_int("background-memory", "Background memory",
                       "As viewwarp's: frames of the static room's remembered colour (0: off)", 0, 64, 0, playing));
  g_object_class_install_property(gobject_class, PROP_EMPTY_ROOM,
      g_param_spec_string("empty-room", "Empty room",
                          "As viewwarp's: RGB image of the empty room the memory starts from", "", ready));
  g_object_class_install_property(gobject_class, PROP_EDGE_TO_NEAR,
      g_param_spec_boolean("edge-to-near", "Edge pixels to the near side",
                           "As viewwarp's; a viewwarp set otherwise prepares the frame itself", TRUE, playing));
  g_object_class_install_property(gobject_class, PROP_BOUNDARY,
      g_param_spec_int("boundary", "Edge boundary", "As viewwarp's; a viewwarp set otherwise prepares the frame itself",
                       0, 8, 0, playing));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Camera preparation for every view", "Filter/Video",
                                        "Prepares a camera's frames once for every lecturer's viewwarp downstream, "
                                        "passing them unchanged with the prepared frame attached.",
                                        "gst-vclassroom");
  GST_BASE_TRANSFORM_CLASS(klass)->start = GST_DEBUG_FUNCPTR(gst_view_prep_start);
  filter_class->set_info = GST_DEBUG_FUNCPTR(gst_view_prep_set_info);
  filter_class->transform_frame_ip = GST_DEBUG_FUNCPTR(gst_view_prep_transform_frame_ip);
}
