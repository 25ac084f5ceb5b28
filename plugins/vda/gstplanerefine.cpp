/**
 * SECTION:element-planerefine
 * @title: planerefine
 *
 * V-DA planar refinement of one camera's video/x-rgbd stream (docs/vda.md): depth that lies on one of the
 * static classroom's planes (floor, walls, desks, blackboard) is snapped to the plane's exact depth along the
 * pixel ray. Depth farther from the plane than max(tolerance, tolerance-ratio x depth) (learners, objects on
 * the plane) is left alone, and with a label plane learner pixels are never snapped. Only the depth plane
 * changes.
 *
 * The model (made by vclassroom-build-model) is read when caps arrive: its planes are carried into the
 * stream's camera (caps camera-id) through the model's rig, and that camera's prior depth tells which plane
 * each pixel shows. A camera the model lacks, or a stream of another size, has its frames dropped with a
 * rate-limited warning while the other cameras go on.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! depthcomplete model=out/classroom-model ! planerefine model=out/classroom-model ! rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! autovideosink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstplanerefine.h"

#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/plane_refine.h>
#include <gst/vclassroom/vda/static_model.h>

#include "vda_buffer.h"

GST_DEBUG_CATEGORY_STATIC(plane_refine_debug);
#define GST_CAT_DEFAULT plane_refine_debug

using namespace vclassroom;

enum { PROP_0, PROP_MODEL, PROP_TOLERANCE, PROP_TOLERANCE_RATIO, PROP_USE_LABELS };

namespace {
struct Settings {  // the properties, under the base's lock
  std::string model_folder;
  PlaneTolerance tolerance;
  bool use_labels = true;
};
struct RefineState {
  Settings settings;
  PlaneMaps maps;  // streaming thread (set_info)
};
}  // namespace

struct _GstPlaneRefine {
  GstRgbdFilter parent;
  RefineState* st;
};

G_DEFINE_TYPE(GstPlaneRefine, gst_plane_refine, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(planerefine, "planerefine", GST_RANK_NONE, GST_TYPE_PLANE_REFINE);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_plane_refine_set_info(GstRgbdFilter* filter, const RgbdInfo& info, const RgbdInfo&) {
  RefineState* st = GST_PLANE_REFINE(filter)->st;
  const std::string folder = rgbd_filter_settings(filter, st->settings).model_folder;
  if (folder.empty()) {
    GST_ELEMENT_ERROR(filter, RESOURCE, NOT_FOUND, ("planerefine has no static model"),
                      ("set the 'model' property to a folder written by vclassroom-build-model"));
    return FALSE;
  }
  std::string refused;
  const StaticModel m = vda::load_model_for_stream(folder, info, &refused);
  if (!refused.empty()) {
    // As depthcomplete: a camera the model cannot serve has its frames dropped, the others go on.
    rgbd_filter_refuse_stream(filter, refused);
    return TRUE;
  }
  // The planes are carried into this camera through the model's (refined) extrinsics.
  const CameraCalib& cam = m.rig.camera(info.camera.id);
  st->maps = plane_maps_for_camera(m.planes, cam, m.prior(cam.id));
  GST_INFO_OBJECT(filter, "camera %d %dx%d: %d plane pixels", info.camera.id, info.width(), info.height(),
                  info.width() * info.height() - cv::countNonZero(st->maps.index == PlaneMaps::kNoPlane));
  return TRUE;
}

static void gst_plane_refine_transform_plane(GstRgbdFilter* filter, const RgbdFrame& frame, cv::Mat& depth_out) {
  RefineState* st = GST_PLANE_REFINE(filter)->st;
  const Settings s = rgbd_filter_settings(filter, st->settings);
  plane_refine(frame.depth(), st->maps, s.use_labels ? frame.label() : cv::Mat(), s.tolerance, depth_out);
}

static void gst_plane_refine_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  Settings& s = GST_PLANE_REFINE(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (prop_id) {
    case PROP_MODEL: s.model_folder = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_TOLERANCE: s.tolerance.min_mm = static_cast<int>(g_value_get_uint(value)); break;
    case PROP_TOLERANCE_RATIO: s.tolerance.ratio = g_value_get_double(value); break;
    case PROP_USE_LABELS: s.use_labels = g_value_get_boolean(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_plane_refine_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  const Settings& s = GST_PLANE_REFINE(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (prop_id) {
    case PROP_MODEL: g_value_set_string(value, s.model_folder.c_str()); break;
    case PROP_TOLERANCE: g_value_set_uint(value, static_cast<guint>(s.tolerance.min_mm)); break;
    case PROP_TOLERANCE_RATIO: g_value_set_double(value, s.tolerance.ratio); break;
    case PROP_USE_LABELS: g_value_set_boolean(value, s.use_labels); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_plane_refine_finalize(GObject* object) {
  delete GST_PLANE_REFINE(object)->st;
  G_OBJECT_CLASS(gst_plane_refine_parent_class)->finalize(object);
}

static void gst_plane_refine_class_init(GstPlaneRefineClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstRgbdFilterClass* filter_class = GST_RGBD_FILTER_CLASS(klass);
  gobject_class->set_property = gst_plane_refine_set_property;
  gobject_class->get_property = gst_plane_refine_get_property;
  gobject_class->finalize = gst_plane_refine_finalize;
  const PlaneTolerance d;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS);
  const auto playing = GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(
      gobject_class, PROP_MODEL,
      g_param_spec_string("model", "Static model folder",
                          "Folder written by vclassroom-build-model, read when caps arrive (sizes must match)", "",
                          GParamFlags(flags | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_TOLERANCE,
      g_param_spec_uint("tolerance", "Tolerance (mm)", "Depth this close to its pixel's plane is snapped to it", 0,
                        10000, static_cast<guint>(d.min_mm), playing));
  g_object_class_install_property(
      gobject_class, PROP_TOLERANCE_RATIO,
      g_param_spec_double("tolerance-ratio", "Tolerance ratio",
                          "Share of the depth added to the tolerance (noise grows with range)", 0.0, 1.0, d.ratio,
                          playing));
  g_object_class_install_property(
      gobject_class, PROP_USE_LABELS,
      g_param_spec_boolean("use-labels", "Use the label plane", "Never snap learner pixels (label > 0)", TRUE,
                           playing));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "V-DA planar refinement", "Filter/Effect/Video",
                                        "Snaps the depth of pixels on the static classroom's planes to the "
                                        "plane's depth along the pixel ray.",
                                        "gst-vclassroom developers");
  filter_class->required_planes = rgbd_plane_bit(Plane::Depth);
  filter_class->new_plane = Plane::Depth;
  filter_class->set_info = GST_DEBUG_FUNCPTR(gst_plane_refine_set_info);
  filter_class->transform_plane = GST_DEBUG_FUNCPTR(gst_plane_refine_transform_plane);
  GST_DEBUG_CATEGORY_INIT(plane_refine_debug, "planerefine", 0, "V-DA planar refinement");
}

static void gst_plane_refine_init(GstPlaneRefine* self) { self->st = new RefineState(); }
