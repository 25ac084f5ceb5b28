// learnerseg: learner masks with stable ids over time, written into the
// label plane of a video/x-rgbd stream (V-VA step 1, docs/vva.md).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlearnerseg.h"

#include <mutex>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/vva/learner_seg.h>
#include <gst/vclassroom/vva/prepared_frame.h>
#include <gst/vclassroom/core/rgbd.h>

GST_DEBUG_CATEGORY_STATIC(learner_seg_debug);
#define GST_CAT_DEFAULT learner_seg_debug

using namespace vclassroom;

enum { PROP_0, PROP_PRIOR_DEPTH, PROP_DEPTH_MARGIN, PROP_COLOR_THRESHOLD, PROP_KEEP_LOST };

namespace {

struct SegState {
  std::mutex lock;  // guards the properties
  std::string prior_path;
  SegParams params;
  bool params_dirty = true;

  // Streaming thread only.
  RgbdInfo in_info, out_info;
  LearnerSegmenter seg;
};

// "color,depth,..." with "label" added after depth when missing.
std::string planes_with_label(const std::string& planes) {
  if (("," + planes + ",").find(",label,") != std::string::npos) return planes;
  const std::string head = "color,depth";
  if (planes.rfind(head, 0) == 0) return head + ",label" + planes.substr(head.size());
  return planes + ",label";
}

}  // namespace

struct _GstLearnerSeg {
  GstBaseTransform parent;
  SegState* st;
};

G_DEFINE_TYPE(GstLearnerSeg, gst_learner_seg, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(learnerseg, "learnerseg", GST_RANK_NONE, GST_TYPE_LEARNER_SEG);

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

static GstCaps* gst_learner_seg_transform_caps(GstBaseTransform*, GstPadDirection direction, GstCaps* caps,
                                               GstCaps* filter) {
  GstCaps* out = gst_caps_copy(caps);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    const char* planes = gst_structure_get_string(s, "planes");
    if (direction == GST_PAD_SINK) {
      if (planes) gst_structure_set(s, "planes", G_TYPE_STRING, planes_with_label(planes).c_str(), nullptr);
    } else {
      // Upstream may or may not carry a label plane already.
      gst_structure_remove_field(s, "planes");
    }
  }
  if (filter) {
    GstCaps* tmp = gst_caps_intersect_full(filter, out, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(out);
    out = tmp;
  }
  return out;
}

static gboolean gst_learner_seg_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps* outcaps) {
  GstLearnerSeg* self = GST_LEARNER_SEG(trans);
  std::string err;
  if (!rgbd_info_from_caps(incaps, &self->st->in_info, &err) || !rgbd_info_from_caps(outcaps, &self->st->out_info, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s", err.c_str()), (nullptr));
    return FALSE;
  }
  self->st->seg.reset();
  return TRUE;
}

static gboolean gst_learner_seg_get_unit_size(GstBaseTransform*, GstCaps* caps, gsize* size) {
  RgbdInfo info;
  std::string err;
  if (!rgbd_info_from_caps(caps, &info, &err)) return FALSE;
  *size = info.default_total_size();
  return TRUE;
}

static gboolean gst_learner_seg_start(GstBaseTransform* trans) {
  GstLearnerSeg* self = GST_LEARNER_SEG(trans);
  SegState* st = self->st;
  std::string path;
  {
    std::lock_guard<std::mutex> g(st->lock);
    path = st->prior_path;
    st->params_dirty = true;
  }
  st->seg.reset();
  st->seg.set_static_depth(cv::Mat());
  if (!path.empty()) {
    try {
      st->seg.set_static_depth(load_static_depth(path));
    } catch (const Error& e) {
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.what()), ("property prior-depth of %s", GST_OBJECT_NAME(self)));
      return FALSE;
    }
  }
  return TRUE;
}

// All the work is here: the output is the input plus a new label plane, the
// other planes shared with the input (no copy).
static GstFlowReturn gst_learner_seg_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* inbuf,
                                                            GstBuffer** outbuf) {
  GstLearnerSeg* self = GST_LEARNER_SEG(trans);
  SegState* st = self->st;
  {
    std::lock_guard<std::mutex> g(st->lock);
    if (st->params_dirty) {
      st->seg.set_params(st->params);  // from this frame on; the memory is kept
      st->params_dirty = false;
    }
  }
  std::string err;
  RgbdPlaneOutput labels(st->out_info, Plane::Label);
  if (!labels.mat.empty()) {
    RgbdFrame in;
    if (!in.map(inbuf, st->in_info, GST_MAP_READ, &err)) {
      GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", err.c_str()), (nullptr));
      return GST_FLOW_ERROR;
    }
    try {
      // Written straight into the new plane (same size and type: segment() keeps it).
      st->seg.segment(in.color(), in.depth(), &labels.mat);
    } catch (const cv::Exception& e) {
      GST_ELEMENT_ERROR(self, STREAM, FAILED, ("segmentation failed: %s", e.what()), (nullptr));
      return GST_FLOW_ERROR;
    }
  }
  *outbuf = labels.finish(inbuf, st->in_info, &err);
  if (!*outbuf) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  GST_LOG_OBJECT(self, "%zu learners", st->seg.active().size());
  return GST_FLOW_OK;
}

static GstFlowReturn gst_learner_seg_transform(GstBaseTransform*, GstBuffer*, GstBuffer*) {
  return GST_FLOW_OK;  // all work is done in prepare_output_buffer
}

static void gst_learner_seg_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  SegState* st = GST_LEARNER_SEG(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_PRIOR_DEPTH:
      st->prior_path = g_value_get_string(value) ? g_value_get_string(value) : "";
      break;
    case PROP_DEPTH_MARGIN:
      st->params.depth_margin_mm = g_value_get_double(value);
      break;
    case PROP_COLOR_THRESHOLD:
      st->params.color_threshold = g_value_get_int(value);
      break;
    case PROP_KEEP_LOST:
      st->params.keep_lost_frames = g_value_get_int(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
      return;
  }
  st->params_dirty = true;
}

static void gst_learner_seg_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  SegState* st = GST_LEARNER_SEG(object)->st;
  std::lock_guard<std::mutex> g(st->lock);
  switch (prop_id) {
    case PROP_PRIOR_DEPTH:
      g_value_set_string(value, st->prior_path.c_str());
      break;
    case PROP_DEPTH_MARGIN:
      g_value_set_double(value, st->params.depth_margin_mm);
      break;
    case PROP_COLOR_THRESHOLD:
      g_value_set_int(value, st->params.color_threshold);
      break;
    case PROP_KEEP_LOST:
      g_value_set_int(value, st->params.keep_lost_frames);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

static void gst_learner_seg_finalize(GObject* object) {
  delete GST_LEARNER_SEG(object)->st;
  G_OBJECT_CLASS(gst_learner_seg_parent_class)->finalize(object);
}

static void gst_learner_seg_class_init(GstLearnerSegClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_learner_seg_set_property;
  gobject_class->get_property = gst_learner_seg_get_property;
  gobject_class->finalize = gst_learner_seg_finalize;
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const SegParams d;
  g_object_class_install_property(
      gobject_class, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth",
                          "16-bit PNG (mm) of the empty classroom seen by this camera (V-DA's prior depth, or "
                          "vclassroom-eval-views --write-priors). Empty: the static depth is learnt online as the "
                          "farthest stable depth at each pixel, so learners who never move stay background",
                          "", ready));
  g_object_class_install_property(
      gobject_class, PROP_DEPTH_MARGIN,
      g_param_spec_double("depth-margin", "Depth margin",
                          "A pixel is a learner when nearer than the empty room by more than this (mm; or 3% of "
                          "the depth when larger)",
                          0, 10000, d.depth_margin_mm, ready));
  g_object_class_install_property(
      gobject_class, PROP_COLOR_THRESHOLD,
      g_param_spec_int("color-threshold", "Colour threshold",
                       "Sum of |RGB - background colour| above which a pixel without depth is a learner (0..765)",
                       0, 765, d.color_threshold, ready));
  g_object_class_install_property(
      gobject_class, PROP_KEEP_LOST,
      g_param_spec_int("keep-lost-frames", "Keep lost learners",
                       "Frames a learner who disappeared (occluded, left) is remembered, so that it gets its id "
                       "back when it reappears",
                       0, G_MAXINT, d.keep_lost_frames, ready));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "Learner segmentation", "Filter/Analyzer/Video",
      "Finds the learners in a classroom camera's video/x-rgbd stream (depth in front of the empty room, colour "
      "change against a background model, temporal memory) and writes their masks with ids stable over time "
      "into the label plane (0 static, k learner k). Example: "
      "gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=300 ! learnerseg ! rgbddemux name=d d.label ! "
      "videoconvert ! autovideosink",
      "gst-vclassroom developers");
  bt->transform_caps = GST_DEBUG_FUNCPTR(gst_learner_seg_transform_caps);
  bt->set_caps = GST_DEBUG_FUNCPTR(gst_learner_seg_set_caps);
  bt->get_unit_size = GST_DEBUG_FUNCPTR(gst_learner_seg_get_unit_size);
  bt->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_learner_seg_prepare_output_buffer);
  bt->transform = GST_DEBUG_FUNCPTR(gst_learner_seg_transform);
  bt->start = GST_DEBUG_FUNCPTR(gst_learner_seg_start);
  GST_DEBUG_CATEGORY_INIT(learner_seg_debug, "learnerseg", 0, "learner segmentation");
}

static void gst_learner_seg_init(GstLearnerSeg* self) { self->st = new SegState(); }
