// depthcomplete: V-DA depth completion of one camera's video/x-rgbd stream
// (docs/vda.md): prior depth of the static room, image-guided completion,
// colorization-style fill. Only the depth plane changes.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstdepthcomplete.h"

#include <memory>
#include <mutex>
#include <string>

#include <gst/vclassroom/vda/depth_completion.h>
#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/static_model.h>

#include "vda_buffer.h"

GST_DEBUG_CATEGORY_STATIC(depth_complete_debug);
#define GST_CAT_DEFAULT depth_complete_debug

using namespace vclassroom;

enum {
  PROP_0,
  PROP_MODEL,
  PROP_USE_PRIOR,
  PROP_IMAGE_GUIDED,
  PROP_COLORIZATION,
  PROP_USE_LABELS,
  PROP_PRIOR_TOLERANCE,
  PROP_LEARNER_GUARD,
  PROP_COLOR_TOLERANCE,
  PROP_COLORIZE_ITERATIONS,
};

namespace {
struct CompleteState {
  std::mutex lock;  // guards the properties
  std::string model_folder;
  DepthCompleteOptions options;
  bool use_labels = true;

  // Streaming thread (set in set_caps).
  RgbdInfo info;
  StaticPrior prior;
  vda::RefusedStream refused;  // the model has not this camera at this size
};
}  // namespace

struct _GstDepthComplete {
  GstBaseTransform parent;
  CompleteState* st;
};

G_DEFINE_TYPE(GstDepthComplete, gst_depth_complete, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(depthcomplete, "depthcomplete", GST_RANK_NONE, GST_TYPE_DEPTH_COMPLETE);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_depth_complete_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps*) {
  GstDepthComplete* self = GST_DEPTH_COMPLETE(trans);
  CompleteState* st = self->st;
  RgbdInfo info;
  std::string err;
  if (!rgbd_info_from_caps(incaps, &info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("depthcomplete: %s", err.c_str()), (nullptr));
    return FALSE;
  }
  if (!info.has(Plane::Depth) || !info.has(Plane::Color)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION,
                      ("depthcomplete needs the color and depth planes; the stream has '%s'",
                       info.planes_string().c_str()),
                      (nullptr));
    return FALSE;
  }
  std::string folder;
  bool use_prior;
  {
    std::lock_guard<std::mutex> g(st->lock);
    folder = st->model_folder;
    use_prior = st->options.use_prior;
  }
  st->prior = StaticPrior();
  std::string refused;
  if (!folder.empty()) {
    try {
      const StaticModel m = vda::load_model_for_stream(folder, info, &refused);
      if (refused.empty()) st->prior = m.prior_for(info.camera.id);
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("depthcomplete model=%s", folder.c_str()));
      return FALSE;
    }
  } else if (use_prior) {
    GST_ELEMENT_WARNING(self, RESOURCE, NOT_FOUND, ("depthcomplete has no static model: the prior stage is off"),
                        ("set the 'model' property to a folder written by vclassroom-build-model"));
  }
  // Caps come from the network: a camera the model cannot serve must not stop
  // the others, so its frames are dropped (with a warning) until caps it fits.
  st->refused.set(refused, info.camera.id);
  st->info = info;
  GST_INFO_OBJECT(self, "camera %d %dx%d, planes %s, model '%s'%s%s", info.camera.id, info.width(), info.height(),
                  info.planes_string().c_str(), folder.c_str(), refused.empty() ? "" : ": refused, ",
                  refused.c_str());
  return TRUE;
}

static GstFlowReturn gst_depth_complete_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* in,
                                                              GstBuffer** out) {
  GstDepthComplete* self = GST_DEPTH_COMPLETE(trans);
  CompleteState* st = self->st;
  if (st->refused.refused()) return st->refused.drop(GST_ELEMENT(self));
  DepthCompleteOptions o;
  bool use_labels;
  {
    std::lock_guard<std::mutex> g(st->lock);
    o = st->options;
    use_labels = st->use_labels;
  }
  return vda::replace_depth(GST_ELEMENT(self), in, st->info,
                            [&](const RgbdFrame& frame, cv::Mat& depth_out) {
                              const cv::Mat label = use_labels ? frame.label() : cv::Mat();
                              // Written straight into the output plane (same size and type,
                              // so depth_complete keeps its memory and stride).
                              depth_complete(frame.depth(), frame.color(), st->prior, label, o, depth_out);
                            },
                            out);
}

static GstFlowReturn gst_depth_complete_transform(GstBaseTransform*, GstBuffer*, GstBuffer*) {
  return GST_FLOW_OK;  // all work is done in prepare_output_buffer
}

static void gst_depth_complete_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  CompleteState* st = GST_DEPTH_COMPLETE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  DepthCompleteOptions& o = st->options;
  switch (prop_id) {
    case PROP_MODEL: {
      const char* s = g_value_get_string(value);
      st->model_folder = s ? s : "";
      break;
    }
    case PROP_USE_PRIOR:
      o.use_prior = g_value_get_boolean(value);
      break;
    case PROP_IMAGE_GUIDED:
      o.image_guided = g_value_get_boolean(value);
      break;
    case PROP_COLORIZATION:
      o.colorization = g_value_get_boolean(value);
      break;
    case PROP_USE_LABELS:
      st->use_labels = g_value_get_boolean(value);
      break;
    case PROP_PRIOR_TOLERANCE:
      o.prior.tolerance_min_mm = static_cast<int>(g_value_get_uint(value));
      break;
    case PROP_LEARNER_GUARD:
      o.prior.learner_guard_px = static_cast<int>(g_value_get_uint(value));
      break;
    case PROP_COLOR_TOLERANCE:
      o.prior.color_tolerance = static_cast<int>(g_value_get_uint(value));
      break;
    case PROP_COLORIZE_ITERATIONS:
      o.colorize.iterations = static_cast<int>(g_value_get_uint(value));
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_depth_complete_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  CompleteState* st = GST_DEPTH_COMPLETE(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  const DepthCompleteOptions& o = st->options;
  switch (prop_id) {
    case PROP_MODEL:
      g_value_set_string(value, st->model_folder.c_str());
      break;
    case PROP_USE_PRIOR:
      g_value_set_boolean(value, o.use_prior);
      break;
    case PROP_IMAGE_GUIDED:
      g_value_set_boolean(value, o.image_guided);
      break;
    case PROP_COLORIZATION:
      g_value_set_boolean(value, o.colorization);
      break;
    case PROP_USE_LABELS:
      g_value_set_boolean(value, st->use_labels);
      break;
    case PROP_PRIOR_TOLERANCE:
      g_value_set_uint(value, static_cast<guint>(o.prior.tolerance_min_mm));
      break;
    case PROP_LEARNER_GUARD:
      g_value_set_uint(value, static_cast<guint>(o.prior.learner_guard_px));
      break;
    case PROP_COLOR_TOLERANCE:
      g_value_set_uint(value, static_cast<guint>(o.prior.color_tolerance));
      break;
    case PROP_COLORIZE_ITERATIONS:
      g_value_set_uint(value, static_cast<guint>(o.colorize.iterations));
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_depth_complete_finalize(GObject* object) {
  delete GST_DEPTH_COMPLETE(object)->st;
  G_OBJECT_CLASS(gst_depth_complete_parent_class)->finalize(object);
}

static void gst_depth_complete_class_init(GstDepthCompleteClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_depth_complete_set_property;
  gobject_class->get_property = gst_depth_complete_get_property;
  gobject_class->finalize = gst_depth_complete_finalize;
  const DepthCompleteOptions d;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS);
  const auto live = GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(
      gobject_class, PROP_MODEL,
      g_param_spec_string("model", "Static model folder",
                          "Folder written by vclassroom-build-model; the prior depth of the stream's camera-id is "
                          "used (read when caps arrive). A stream of a camera the model lacks, or of another size, has its frames "
                          "dropped with a rate-limited warning. Empty: no prior stage",
                          "", GParamFlags(flags | GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property(
      gobject_class, PROP_USE_PRIOR,
      g_param_spec_boolean("use-prior", "Use prior depth",
                           "Fill holes (and replace agreeing noisy depth) with the static room's prior depth; live "
                           "depth in front of the prior (learners) is kept",
                           d.use_prior, live));
  g_object_class_install_property(
      gobject_class, PROP_IMAGE_GUIDED,
      g_param_spec_boolean("image-guided", "Image-guided completion",
                           "Ku et al.-style completion: diamond dilation, closing and hole fill of small holes "
                           "where the depths around agree, colour-guided fill of the rest, median over filled pixels",
                           d.image_guided, live));
  g_object_class_install_property(
      gobject_class, PROP_COLORIZATION,
      g_param_spec_boolean("colorization", "Colorization fill",
                           "Levin et al.-style colour-weighted relaxation of the filled pixels (and fill of any "
                           "left); measured depth is never changed",
                           d.colorization, live));
  g_object_class_install_property(
      gobject_class, PROP_USE_LABELS,
      g_param_spec_boolean("use-labels", "Use the label plane",
                           "When the stream has a label plane, never put prior depth on learner pixels (label > 0)",
                           TRUE, live));
  g_object_class_install_property(
      gobject_class, PROP_PRIOR_TOLERANCE,
      g_param_spec_uint("prior-tolerance", "Prior tolerance (mm)",
                        "Live depth within max(this, 3% of depth) of the prior agrees with the static room", 0,
                        10000, static_cast<guint>(d.prior.tolerance_min_mm), live));
  g_object_class_install_property(
      gobject_class, PROP_LEARNER_GUARD,
      g_param_spec_uint("learner-guard", "Learner guard (px)",
                        "Holes this close to live depth in front of the prior (a learner) get no prior", 0, 100,
                        static_cast<guint>(d.prior.learner_guard_px), live));
  g_object_class_install_property(
      gobject_class, PROP_COLOR_TOLERANCE,
      g_param_spec_uint("color-tolerance", "Colour tolerance",
                        "A hole takes the prior only where the live colour differs from the empty room's by at "
                        "most this (largest RGB channel difference, 8-bit); 0 = no colour test",
                        0, 255, static_cast<guint>(d.prior.color_tolerance), live));
  g_object_class_install_property(
      gobject_class, PROP_COLORIZE_ITERATIONS,
      g_param_spec_uint("colorize-iterations", "Colorization iterations",
                        "Successive over-relaxation sweeps of the colorization stage per frame", 0, 10000,
                        static_cast<guint>(d.colorize.iterations), live));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "V-DA depth completion", "Filter/Effect/Video",
      "Fills the holes of an RGB-D stream's depth from the static classroom model's prior depth, image-guided "
      "completion (Ku et al. style) and colorization (Levin et al. style); caps, timestamps and the other planes "
      "pass unchanged. The model folder is made by vclassroom-build-model (docs/vda.md). Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! depthcomplete model=out/classroom-model ! "
      "rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! autovideosink",
      "gst-vclassroom developers");
  trans_class->set_caps = GST_DEBUG_FUNCPTR(gst_depth_complete_set_caps);
  trans_class->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_depth_complete_prepare_output_buffer);
  trans_class->transform = GST_DEBUG_FUNCPTR(gst_depth_complete_transform);
  trans_class->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(depth_complete_debug, "depthcomplete", 0, "V-DA depth completion");
}

static void gst_depth_complete_init(GstDepthComplete* self) { self->st = new CompleteState(); }
