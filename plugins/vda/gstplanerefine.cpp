// planerefine: V-DA planar refinement of one camera's video/x-rgbd stream
// (docs/vda.md): depth on one of the static room's planes becomes the plane's
// exact depth along the pixel ray. Only the depth plane changes.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstplanerefine.h"

#include <mutex>
#include <string>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/vda/plane_refine.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/static_model.h>

#include "vda_buffer.h"

GST_DEBUG_CATEGORY_STATIC(plane_refine_debug);
#define GST_CAT_DEFAULT plane_refine_debug

using namespace vclassroom;

enum { PROP_0, PROP_MODEL, PROP_TOLERANCE, PROP_TOLERANCE_RATIO, PROP_USE_LABELS };

namespace {
struct RefineState {
  std::mutex lock;  // guards the properties
  std::string model_folder;
  PlaneTolerance tolerance;
  bool use_labels = true;

  // Streaming thread (set in set_caps).
  RgbdInfo info;
  PlaneMaps maps;
  bool have_maps = false;
  vda::RefusedStream refused;  // the model has not this camera at this size
};
}  // namespace

struct _GstPlaneRefine {
  GstBaseTransform parent;
  RefineState* st;
};

G_DEFINE_TYPE(GstPlaneRefine, gst_plane_refine, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(planerefine, "planerefine", GST_RANK_NONE, GST_TYPE_PLANE_REFINE);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_plane_refine_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps*) {
  GstPlaneRefine* self = GST_PLANE_REFINE(trans);
  RefineState* st = self->st;
  RgbdInfo info;
  std::string err;
  if (!rgbd_info_from_caps(incaps, &info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("planerefine: %s", err.c_str()), (nullptr));
    return FALSE;
  }
  if (!info.has(Plane::Depth)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION,
                      ("planerefine needs the depth plane; the stream has '%s'", info.planes_string().c_str()),
                      (nullptr));
    return FALSE;
  }
  std::string folder;
  {
    std::lock_guard<std::mutex> g(st->lock);
    folder = st->model_folder;
  }
  if (folder.empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("planerefine has no static model"),
                      ("set the 'model' property to a folder written by vclassroom-build-model"));
    return FALSE;
  }
  std::string refused;
  try {
    const StaticModel m = vda::load_model_for_stream(folder, info, &refused);
    if (refused.empty()) {
      // The planes are carried into this camera through the model's (refined) extrinsics.
      const CameraCalib& cam = m.rig.camera(info.camera.id);
      st->maps = plane_maps_for_camera(m.planes, cam, m.prior(cam.id));
    }
    st->have_maps = refused.empty();
  } catch (const Error& e) {
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("planerefine model=%s", folder.c_str()));
    return FALSE;
  }
  // As depthcomplete: a camera the model cannot serve has its frames dropped, the others go on.
  st->refused.set(refused, info.camera.id);
  st->info = info;
  if (st->have_maps)
    GST_INFO_OBJECT(self, "camera %d %dx%d: %d plane pixels", info.camera.id, info.width(), info.height(),
                    info.width() * info.height() - cv::countNonZero(st->maps.index == PlaneMaps::kNoPlane));
  return TRUE;
}

static GstFlowReturn gst_plane_refine_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* in, GstBuffer** out) {
  GstPlaneRefine* self = GST_PLANE_REFINE(trans);
  RefineState* st = self->st;
  if (st->refused.refused()) return st->refused.drop(GST_ELEMENT(self));
  PlaneTolerance tol;
  bool use_labels;
  {
    std::lock_guard<std::mutex> g(st->lock);
    tol = st->tolerance;
    use_labels = st->use_labels;
  }
  return vda::replace_depth(GST_ELEMENT(self), in, st->info,
                            [&](const RgbdFrame& frame, cv::Mat& depth_out) {
                              plane_refine(frame.depth(), st->maps, use_labels ? frame.label() : cv::Mat(), tol,
                                           depth_out);
                            },
                            out);
}

static GstFlowReturn gst_plane_refine_transform(GstBaseTransform*, GstBuffer*, GstBuffer*) {
  return GST_FLOW_OK;  // all work is done in prepare_output_buffer
}

static void gst_plane_refine_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  RefineState* st = GST_PLANE_REFINE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_MODEL: {
      const char* s = g_value_get_string(value);
      st->model_folder = s ? s : "";
      break;
    }
    case PROP_TOLERANCE:
      st->tolerance.min_mm = static_cast<int>(g_value_get_uint(value));
      break;
    case PROP_TOLERANCE_RATIO:
      st->tolerance.ratio = g_value_get_double(value);
      break;
    case PROP_USE_LABELS:
      st->use_labels = g_value_get_boolean(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_plane_refine_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  RefineState* st = GST_PLANE_REFINE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_MODEL:
      g_value_set_string(value, st->model_folder.c_str());
      break;
    case PROP_TOLERANCE:
      g_value_set_uint(value, static_cast<guint>(st->tolerance.min_mm));
      break;
    case PROP_TOLERANCE_RATIO:
      g_value_set_double(value, st->tolerance.ratio);
      break;
    case PROP_USE_LABELS:
      g_value_set_boolean(value, st->use_labels);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_plane_refine_finalize(GObject* object) {
  delete GST_PLANE_REFINE(object)->st;
  G_OBJECT_CLASS(gst_plane_refine_parent_class)->finalize(object);
}

static void gst_plane_refine_class_init(GstPlaneRefineClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_plane_refine_set_property;
  gobject_class->get_property = gst_plane_refine_get_property;
  gobject_class->finalize = gst_plane_refine_finalize;
  const PlaneTolerance d;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS);
  const auto ready = GParamFlags(flags | GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      gobject_class, PROP_MODEL,
      g_param_spec_string("model", "Static model folder",
                          "Folder written by vclassroom-build-model: its planes, carried into the stream's camera "
                          "(caps camera-id) through the model's rig, and that camera's prior depth, which tells "
                          "which plane each pixel shows (read when caps arrive; sizes must match)",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_TOLERANCE,
      g_param_spec_uint("tolerance", "Tolerance (mm)",
                        "Depth within max(tolerance, tolerance-ratio x depth) of the pixel's plane is snapped to "
                        "it; farther (learners, objects on the plane) is left alone",
                        0, 10000, static_cast<guint>(d.min_mm), GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_TOLERANCE_RATIO,
      g_param_spec_double("tolerance-ratio", "Tolerance ratio",
                          "Share of the depth added to the tolerance at range (sensor noise grows with depth)", 0.0,
                          1.0, d.ratio, GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property(
      gobject_class, PROP_USE_LABELS,
      g_param_spec_boolean("use-labels", "Use the label plane",
                           "When the stream has a label plane, never snap learner pixels (label > 0)", TRUE,
                           GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "V-DA planar refinement", "Filter/Effect/Video",
      "Snaps the depth of pixels on the static classroom's planes (floor, walls, desks, blackboard) to the plane's "
      "depth along the pixel ray; caps, timestamps and the other planes pass unchanged. The model folder is made "
      "by vclassroom-build-model (docs/vda.md). Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! depthcomplete model=out/classroom-model ! "
      "planerefine model=out/classroom-model ! rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! "
      "autovideosink",
      "gst-vclassroom developers");
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_plane_refine_set_caps);
  trans_class->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_plane_refine_prepare_output_buffer);
  trans_class->transform = GST_DEBUG_FUNCPTR(gst_plane_refine_transform);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(plane_refine_debug, "planerefine", 0, "V-DA planar refinement");
}

static void gst_plane_refine_init(GstPlaneRefine* self) { self->st = new RefineState(); }
