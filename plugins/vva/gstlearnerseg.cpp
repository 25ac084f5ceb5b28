/**
 * SECTION:element-learnerseg
 * @title: learnerseg
 *
 * V-VA step 1 (docs/vva.md): finds the learners in a classroom camera's video/x-rgbd stream and writes their
 * masks, with ids stable over time, into the label plane (0 static, k learner k); the label plane is added
 * when the input lacks it, the other planes pass unchanged (shared, not copied).
 *
 * A pixel is a learner when its depth is nearer than the empty room's by more than depth-margin (or 3% of
 * the depth), or, without depth, when its colour differs from the background model by more than
 * color-threshold. The empty room's depth is prior-depth (a 16-bit PNG in mm: V-DA's prior, or
 * vclassroom-eval-views --write-priors); without it the farthest stable depth at each pixel is learnt
 * online, so learners who never move stay background. A learner who disappears is remembered for
 * keep-lost-frames frames and gets its id back when it reappears.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! learnerseg ! rgbddemux name=d d.label ! videoconvert ! autovideosink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlearnerseg.h"

#include <string>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vva/learner_seg.h>
#include <gst/vclassroom/vva/prepared_frame.h>

GST_DEBUG_CATEGORY_STATIC(learner_seg_debug);
#define GST_CAT_DEFAULT learner_seg_debug

using namespace vclassroom;

enum { PROP_0, PROP_PRIOR_DEPTH, PROP_DEPTH_MARGIN, PROP_COLOR_THRESHOLD, PROP_KEEP_LOST };

namespace {

struct SegState {
  // The properties, under the base's lock.
  std::string prior_path;
  SegParams params;
  bool params_dirty = true;

  LearnerSegmenter seg;  // streaming thread
};

}  // namespace

struct _GstLearnerSeg {
  GstRgbdFilter parent;
  SegState* st;
};

G_DEFINE_TYPE(GstLearnerSeg, gst_learner_seg, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(learnerseg, "learnerseg", GST_RANK_NONE, GST_TYPE_LEARNER_SEG);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static gboolean gst_learner_seg_set_info(GstRgbdFilter* filter, const RgbdInfo&, const RgbdInfo&) {
  GST_LEARNER_SEG(filter)->st->seg.reset();
  return TRUE;
}

static gboolean gst_learner_seg_start(GstBaseTransform* trans) {
  GstRgbdFilter* filter = GST_RGBD_FILTER(trans);
  SegState* st = GST_LEARNER_SEG(trans)->st;
  std::string path;
  {
    const auto lock = rgbd_filter_lock(filter);
    path = st->prior_path;
    st->params_dirty = true;
  }
  st->seg.reset();
  st->seg.set_static_depth(cv::Mat());
  return rgbd_filter_guard_setup(filter, "property prior-depth", [&] {
    if (!path.empty()) st->seg.set_static_depth(load_static_depth(path));
    return true;
  });
}

static void gst_learner_seg_transform_plane(GstRgbdFilter* filter, const RgbdFrame& in, cv::Mat& labels) {
  SegState* st = GST_LEARNER_SEG(filter)->st;
  {
    const auto lock = rgbd_filter_lock(filter);
    if (st->params_dirty) {
      st->seg.set_params(st->params);  // from this frame on; the memory is kept
      st->params_dirty = false;
    }
  }
  // Written straight into the new plane (same size and type: segment() keeps it).
  st->seg.segment(in.color(), in.depth(), &labels);
  GST_LOG_OBJECT(filter, "%zu learners", st->seg.active().size());
}

static void gst_learner_seg_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  SegState* st = GST_LEARNER_SEG(object)->st;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (prop_id) {
    case PROP_PRIOR_DEPTH: st->prior_path = g_value_get_string(value) ? g_value_get_string(value) : ""; break;
    case PROP_DEPTH_MARGIN: st->params.depth_margin_mm = g_value_get_double(value); break;
    case PROP_COLOR_THRESHOLD: st->params.color_threshold = g_value_get_int(value); break;
    case PROP_KEEP_LOST: st->params.keep_lost_frames = g_value_get_int(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec); return;
  }
  st->params_dirty = true;
}

static void gst_learner_seg_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  SegState* st = GST_LEARNER_SEG(object)->st;
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  switch (prop_id) {
    case PROP_PRIOR_DEPTH: g_value_set_string(value, st->prior_path.c_str()); break;
    case PROP_DEPTH_MARGIN: g_value_set_double(value, st->params.depth_margin_mm); break;
    case PROP_COLOR_THRESHOLD: g_value_set_int(value, st->params.color_threshold); break;
    case PROP_KEEP_LOST: g_value_set_int(value, st->params.keep_lost_frames); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_learner_seg_finalize(GObject* object) {
  delete GST_LEARNER_SEG(object)->st;
  G_OBJECT_CLASS(gst_learner_seg_parent_class)->finalize(object);
}

static void gst_learner_seg_class_init(GstLearnerSegClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstRgbdFilterClass* filter_class = GST_RGBD_FILTER_CLASS(klass);
  gobject_class->set_property = gst_learner_seg_set_property;
  gobject_class->get_property = gst_learner_seg_get_property;
  gobject_class->finalize = gst_learner_seg_finalize;
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const SegParams d;
  g_object_class_install_property(
      gobject_class, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth",
                          "16-bit PNG (mm) of the empty room seen by this camera (empty: learnt online)", "", ready));
  g_object_class_install_property(
      gobject_class, PROP_DEPTH_MARGIN,
      g_param_spec_double("depth-margin", "Depth margin",
                          "Nearer than the empty room by more than this (mm, or 3% of depth): a learner", 0, 10000,
                          d.depth_margin_mm, ready));
  g_object_class_install_property(
      gobject_class, PROP_COLOR_THRESHOLD,
      g_param_spec_int("color-threshold", "Colour threshold",
                       "Sum of |RGB - background| above which a pixel without depth is a learner", 0, 765,
                       d.color_threshold, ready));
  g_object_class_install_property(
      gobject_class, PROP_KEEP_LOST,
      g_param_spec_int("keep-lost-frames", "Keep lost learners",
                       "Frames a vanished learner is remembered, to get its id back", 0, G_MAXINT,
                       d.keep_lost_frames, ready));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Learner segmentation", "Filter/Analyzer/Video",
                                        "Writes the masks of the learners a classroom camera sees, with ids stable "
                                        "over time, into the label plane of its RGB-D stream.",
                                        "gst-vclassroom developers");
  GST_BASE_TRANSFORM_CLASS(klass)->start = GST_DEBUG_FUNCPTR(gst_learner_seg_start);
  filter_class->required_planes = 0;
  filter_class->new_plane = Plane::Label;
  filter_class->set_info = GST_DEBUG_FUNCPTR(gst_learner_seg_set_info);
  filter_class->transform_plane = GST_DEBUG_FUNCPTR(gst_learner_seg_transform_plane);
  GST_DEBUG_CATEGORY_INIT(learner_seg_debug, "learnerseg", 0, "learner segmentation");
}

static void gst_learner_seg_init(GstLearnerSeg* self) { self->st = new SegState(); }
