/**
 * SECTION:element-depthcomplete
 * @title: depthcomplete
 *
 * V-DA depth completion of one camera's video/x-rgbd stream (docs/vda.md): the holes of the depth plane are
 * filled from the static classroom's prior depth (made by vclassroom-build-model), then by image-guided
 * completion (Ku et al. style) and a colorization-style relaxation (Levin et al. style). Only the depth plane
 * changes; caps, timestamps and the other planes pass unchanged (shared, not copied).
 *
 * The model is read when caps arrive. A stream of a camera the model lacks, or of another size, has its
 * frames dropped with a rate-limited warning while the other cameras go on. Without a model the prior stage
 * is off (with a warning when use-prior is set). With a label plane, learner pixels never get prior depth.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! depthcomplete model=out/classroom-model ! rgbddemux name=d d.depth ! depthcolorize ! videoconvert ! autovideosink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstdepthcomplete.h"

#include <string>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/depth_completion.h>
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
struct Settings {  // the properties, under the base's lock
  std::string model_folder;
  DepthCompleteOptions options;
  bool use_labels = true;
};
struct CompleteState {
  Settings settings;
  StaticPrior prior;  // streaming thread (set_info)
};
}  // namespace

struct _GstDepthComplete {
  GstRgbdFilter parent;
  CompleteState* st;
};

G_DEFINE_TYPE(GstDepthComplete, gst_depth_complete, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(depthcomplete, "depthcomplete", GST_RANK_NONE, GST_TYPE_DEPTH_COMPLETE);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_depth_complete_set_info(GstRgbdFilter* filter, const RgbdInfo& info, const RgbdInfo&) {
  CompleteState* st = GST_DEPTH_COMPLETE(filter)->st;
  const Settings s = rgbd_filter_settings(filter, st->settings);
  st->prior = StaticPrior();
  std::string refused;
  if (!s.model_folder.empty()) {
    const StaticModel m = vda::load_model_for_stream(s.model_folder, info, &refused);
    if (refused.empty()) st->prior = m.prior_for(info.camera.id);
  } else if (s.options.use_prior) {
    GST_ELEMENT_WARNING(filter, RESOURCE, NOT_FOUND, ("depthcomplete has no static model: the prior stage is off"),
                        ("set the 'model' property to a folder written by vclassroom-build-model"));
  }
  // Caps come from the network: a camera the model cannot serve must not stop the others.
  if (!refused.empty()) rgbd_filter_refuse_stream(filter, refused);
  return TRUE;
}

static void gst_depth_complete_transform_plane(GstRgbdFilter* filter, const RgbdFrame& frame, cv::Mat& depth_out) {
  CompleteState* st = GST_DEPTH_COMPLETE(filter)->st;
  const Settings s = rgbd_filter_settings(filter, st->settings);
  const cv::Mat label = s.use_labels ? frame.label() : cv::Mat();
  // Written straight into the output plane (same size and type, so depth_complete keeps its memory and stride).
  depth_complete(frame.depth(), frame.color(), st->prior, label, s.options, depth_out);
}

static void gst_depth_complete_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  Settings& s = GST_DEPTH_COMPLETE(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  DepthCompleteOptions& o = s.options;
  switch (prop_id) {
    case PROP_MODEL: s.model_folder = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_USE_PRIOR: o.use_prior = g_value_get_boolean(value); break;
    case PROP_IMAGE_GUIDED: o.image_guided = g_value_get_boolean(value); break;
    case PROP_COLORIZATION: o.colorization = g_value_get_boolean(value); break;
    case PROP_USE_LABELS: s.use_labels = g_value_get_boolean(value); break;
    case PROP_PRIOR_TOLERANCE: o.prior.tolerance_min_mm = static_cast<int>(g_value_get_uint(value)); break;
    case PROP_LEARNER_GUARD: o.prior.learner_guard_px = static_cast<int>(g_value_get_uint(value)); break;
    case PROP_COLOR_TOLERANCE: o.prior.color_tolerance = static_cast<int>(g_value_get_uint(value)); break;
    case PROP_COLORIZE_ITERATIONS: o.colorize.iterations = static_cast<int>(g_value_get_uint(value)); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_depth_complete_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  const Settings& s = GST_DEPTH_COMPLETE(object)->st->settings;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  const DepthCompleteOptions& o = s.options;
  switch (prop_id) {
    case PROP_MODEL: g_value_set_string(value, s.model_folder.c_str()); break;
    case PROP_USE_PRIOR: g_value_set_boolean(value, o.use_prior); break;
    case PROP_IMAGE_GUIDED: g_value_set_boolean(value, o.image_guided); break;
    case PROP_COLORIZATION: g_value_set_boolean(value, o.colorization); break;
    case PROP_USE_LABELS: g_value_set_boolean(value, s.use_labels); break;
    case PROP_PRIOR_TOLERANCE: g_value_set_uint(value, static_cast<guint>(o.prior.tolerance_min_mm)); break;
    case PROP_LEARNER_GUARD: g_value_set_uint(value, static_cast<guint>(o.prior.learner_guard_px)); break;
    case PROP_COLOR_TOLERANCE: g_value_set_uint(value, static_cast<guint>(o.prior.color_tolerance)); break;
    case PROP_COLORIZE_ITERATIONS: g_value_set_uint(value, static_cast<guint>(o.colorize.iterations)); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_depth_complete_finalize(GObject* object) {
  delete GST_DEPTH_COMPLETE(object)->st;
  G_OBJECT_CLASS(gst_depth_complete_parent_class)->finalize(object);
}

static void install_properties(GObjectClass* gobject_class) {
  const DepthCompleteOptions d;
  const auto flags = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS);
  const auto live = GParamFlags(flags | GST_PARAM_MUTABLE_PLAYING);
  auto boolean = [&](guint id, const char* name, const char* nick, const char* blurb, bool def) {
    g_object_class_install_property(gobject_class, id, g_param_spec_boolean(name, nick, blurb, def, live));
  };
  auto uint = [&](guint id, const char* name, const char* nick, const char* blurb, guint max, int def) {
    g_object_class_install_property(gobject_class, id,
                                    g_param_spec_uint(name, nick, blurb, 0, max, static_cast<guint>(def), live));
  };
  g_object_class_install_property(
      gobject_class, PROP_MODEL,
      g_param_spec_string("model", "Static model folder",
                          "Folder written by vclassroom-build-model, read when caps arrive (empty: no prior stage)", "",
                          GParamFlags(flags | GST_PARAM_MUTABLE_READY)));
  boolean(PROP_USE_PRIOR, "use-prior", "Use prior depth", "Fill holes with the static room's prior depth",
          d.use_prior);
  boolean(PROP_IMAGE_GUIDED, "image-guided", "Image-guided completion",
          "Fill holes guided by the colour image (Ku et al. style)", d.image_guided);
  boolean(PROP_COLORIZATION, "colorization", "Colorization fill",
          "Relax filled pixels with colour weights (Levin et al. style)", d.colorization);
  boolean(PROP_USE_LABELS, "use-labels", "Use the label plane", "Never put prior depth on learner pixels (label > 0)",
          true);
  uint(PROP_PRIOR_TOLERANCE, "prior-tolerance", "Prior tolerance (mm)",
       "Live depth this close to the prior (or 3% of depth) agrees with the room", 10000, d.prior.tolerance_min_mm);
  uint(PROP_LEARNER_GUARD, "learner-guard", "Learner guard (px)",
       "Holes this close to a learner get no prior depth", 100, d.prior.learner_guard_px);
  uint(PROP_COLOR_TOLERANCE, "color-tolerance", "Colour tolerance",
       "Largest RGB difference from the empty room for a hole to take the prior (0: no test)", 255,
       d.prior.color_tolerance);
  uint(PROP_COLORIZE_ITERATIONS, "colorize-iterations", "Colorization iterations",
       "Relaxation sweeps of the colorization stage per frame", 10000, d.colorize.iterations);
}

static void gst_depth_complete_class_init(GstDepthCompleteClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstRgbdFilterClass* filter_class = GST_RGBD_FILTER_CLASS(klass);
  gobject_class->set_property = gst_depth_complete_set_property;
  gobject_class->get_property = gst_depth_complete_get_property;
  gobject_class->finalize = gst_depth_complete_finalize;
  install_properties(gobject_class);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "V-DA depth completion", "Filter/Effect/Video",
                                        "Fills the holes of an RGB-D stream's depth from the static classroom model "
                                        "and the colour image.",
                                        "gst-vclassroom developers");
  filter_class->required_planes = rgbd_plane_bit(Plane::Color) | rgbd_plane_bit(Plane::Depth);
  filter_class->new_plane = Plane::Depth;
  filter_class->set_info = GST_DEBUG_FUNCPTR(gst_depth_complete_set_info);
  filter_class->transform_plane = GST_DEBUG_FUNCPTR(gst_depth_complete_transform_plane);
  GST_DEBUG_CATEGORY_INIT(depth_complete_debug, "depthcomplete", 0, "V-DA depth completion");
}

static void gst_depth_complete_init(GstDepthComplete* self) { self->st = new CompleteState(); }
