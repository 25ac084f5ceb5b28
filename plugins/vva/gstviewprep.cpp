// viewprep: prepares one camera's frames for every view's viewwarp (docs/vva.md): the background memory and
// the half of the warp that does not depend on the lecturer's pose, once per camera instead of once per view.
// The frames pass unchanged, with the prepared frame as a meta that viewwarp takes when its edge-to-near and
// boundary are the same.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewprep.h"

#include <mutex>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/prepared_frame.h>

GST_DEBUG_CATEGORY_STATIC(view_prep_debug);
#define GST_CAT_DEFAULT view_prep_debug

using namespace vclassroom;

enum { PROP_0, PROP_PRIOR_DEPTH, PROP_BACKGROUND_MEMORY, PROP_EMPTY_ROOM, PROP_EDGE_TO_NEAR, PROP_BOUNDARY };

namespace {

struct PrepState {
  std::mutex lock;  // guards the properties
  std::string prior_path, empty_room_path;
  int memory_frames = 0;
  bool edge_to_near = true;
  int boundary_px = 0;

  // Streaming thread only.
  RgbdInfo info;
  cv::Mat prior, empty_room;
  FramePreparer preparer;
};

}  // namespace

struct _GstViewPrep {
  GstBaseTransform parent;
  PrepState* st;
};

G_DEFINE_TYPE(GstViewPrep, gst_view_prep, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(viewprep, "viewprep", GST_RANK_NONE, GST_TYPE_VIEW_PREP);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_view_prep_start(GstBaseTransform* trans) {
  PrepState* st = GST_VIEW_PREP(trans)->st;
  std::string prior_path, empty_room_path;
  {
    std::lock_guard<std::mutex> g(st->lock);
    prior_path = st->prior_path;
    empty_room_path = st->empty_room_path;
  }
  st->prior.release();
  st->empty_room.release();
  try {
    if (!prior_path.empty()) st->prior = load_static_depth(prior_path);
    if (!empty_room_path.empty()) st->empty_room = load_empty_room(empty_room_path);
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(trans, RESOURCE, OPEN_READ, ("%s", e.what()),
                      ("properties prior-depth and empty-room of %s", GST_OBJECT_NAME(trans)));
    return FALSE;
  }
  return TRUE;
}

static gboolean gst_view_prep_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps*) {
  PrepState* st = GST_VIEW_PREP(trans)->st;
  std::string err;
  if (!rgbd_info_from_caps(incaps, &st->info, &err)) {
    GST_ELEMENT_ERROR(trans, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  // As viewwarp: a camera that changes its size is prepared without the prior and seed made for the other.
  const cv::Size size(st->info.width(), st->info.height());
  const bool prior_fits = st->prior.empty() || st->prior.size() == size;
  const bool seed_fits = st->empty_room.empty() || st->empty_room.size() == size;
  if (!prior_fits || !seed_fits)
    GST_ELEMENT_WARNING(trans, RESOURCE, SETTINGS,
                        ("prior-depth or empty-room is not of camera %d's size %dx%d: prepared without it",
                         st->info.camera.id, size.width, size.height),
                        (nullptr));
  st->preparer.set_static_depth(prior_fits ? st->prior : cv::Mat());
  return TRUE;
}

static GstFlowReturn gst_view_prep_transform_ip(GstBaseTransform* trans, GstBuffer* buf) {
  PrepState* st = GST_VIEW_PREP(trans)->st;
  WarpParams params;
  int memory_frames;
  {
    std::lock_guard<std::mutex> g(st->lock);
    params.edge_to_near = st->edge_to_near;
    params.boundary_px = st->boundary_px;
    memory_frames = st->memory_frames;
  }
  st->preparer.set_memory(memory_frames, st->empty_room);
  std::shared_ptr<const PreparedFrame> prepared;
  {
    RgbdFrame frame;
    std::string err;
    if (!frame.map(buf, st->info, GST_MAP_READ, &err)) {
      GST_ELEMENT_ERROR(trans, STREAM, FAILED, ("%s", err.c_str()), (nullptr));
      return GST_FLOW_ERROR;
    }
    try {
      prepared = st->preparer.prepare(st->info.camera, frame.color(), frame.depth(), frame.label(), params);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(trans, STREAM, FAILED, ("%s", e.what()), (nullptr));
      return GST_FLOW_ERROR;
    } catch (const cv::Exception& e) {
      GST_ELEMENT_ERROR(trans, STREAM, FAILED, ("preparing camera %d's frame failed: %s", st->info.camera.id, e.what()),
                        (nullptr));
      return GST_FLOW_ERROR;
    }
  }
  buffer_add_prepared_frame(buf, std::move(prepared));
  return GST_FLOW_OK;
}

static void gst_view_prep_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  PrepState* st = GST_VIEW_PREP(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (id) {
    case PROP_PRIOR_DEPTH: st->prior_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_EMPTY_ROOM: st->empty_room_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_BACKGROUND_MEMORY: st->memory_frames = g_value_get_int(value); break;
    case PROP_EDGE_TO_NEAR: st->edge_to_near = g_value_get_boolean(value); break;
    case PROP_BOUNDARY: st->boundary_px = g_value_get_int(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_view_prep_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  PrepState* st = GST_VIEW_PREP(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (id) {
    case PROP_PRIOR_DEPTH: g_value_set_string(value, st->prior_path.c_str()); break;
    case PROP_EMPTY_ROOM: g_value_set_string(value, st->empty_room_path.c_str()); break;
    case PROP_BACKGROUND_MEMORY: g_value_set_int(value, st->memory_frames); break;
    case PROP_EDGE_TO_NEAR: g_value_set_boolean(value, st->edge_to_near); break;
    case PROP_BOUNDARY: g_value_set_int(value, st->boundary_px); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_view_prep_init(GstViewPrep* self) {
  self->st = new PrepState;
  gst_base_transform_set_in_place(GST_BASE_TRANSFORM(self), TRUE);
}

static void gst_view_prep_finalize(GObject* object) {
  delete GST_VIEW_PREP(object)->st;
  G_OBJECT_CLASS(gst_view_prep_parent_class)->finalize(object);
}

static void gst_view_prep_class_init(GstViewPrepClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  GST_DEBUG_CATEGORY_INIT(view_prep_debug, "viewprep", 0, "A camera's frames prepared once for every view");
  gobject_class->set_property = gst_view_prep_set_property;
  gobject_class->get_property = gst_view_prep_get_property;
  gobject_class->finalize = gst_view_prep_finalize;
  const GParamFlags ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const GParamFlags playing = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(gobject_class, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth", "As viewwarp's: the static layer's depth, a 16-bit PNG (mm) "
                          "of the empty classroom seen by this camera. Empty: the stream's depth everywhere", "", ready));
  g_object_class_install_property(gobject_class, PROP_BACKGROUND_MEMORY,
      g_param_spec_int("background-memory", "Background memory",
                       "As viewwarp's: frames of the memory of the static room's colour, and with prior-depth the "
                       "room behind the learners (docs/vva.md). 0: off", 0, 64, 0, playing));
  g_object_class_install_property(gobject_class, PROP_EMPTY_ROOM,
      g_param_spec_string("empty-room", "Empty room", "As viewwarp's: RGB image of the empty classroom seen by this "
                          "camera that the memory starts from. Empty: it learns the room as it sees it", "", ready));
  g_object_class_install_property(gobject_class, PROP_EDGE_TO_NEAR,
      g_param_spec_boolean("edge-to-near", "Edge pixels to the near side",
                           "As viewwarp's; a viewwarp set otherwise prepares the frame itself", TRUE, playing));
  g_object_class_install_property(gobject_class, PROP_BOUNDARY,
      g_param_spec_int("boundary", "Edge boundary", "As viewwarp's; a viewwarp set otherwise prepares the frame itself",
                       0, 8, 0, playing));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Camera preparation for every view", "Filter/Video",
      "Prepares a camera's frames once for every lecturer's view: the background memory and the part of the "
      "warp that does not depend on the pose (layered depth, smoothed steps, rims), handed to each viewwarp "
      "downstream with the frame, which passes unchanged. Put it before the tee that feeds several views. "
      "Example: gst-launch-1.0 rgbdtestsrc num-buffers=10 ! learnerseg ! viewprep background-memory=8 ! tee name=t "
      "t. ! queue ! viewwarp ! fakesink t. ! queue ! viewwarp ! fakesink",
      "gst-vclassroom");
  bt->start = GST_DEBUG_FUNCPTR(gst_view_prep_start);
  bt->set_caps = GST_DEBUG_FUNCPTR(gst_view_prep_set_caps);
  bt->transform_ip = GST_DEBUG_FUNCPTR(gst_view_prep_transform_ip);
}
