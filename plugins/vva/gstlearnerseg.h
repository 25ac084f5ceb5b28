#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_LEARNER_SEG (gst_learner_seg_get_type())
G_DECLARE_FINAL_TYPE(GstLearnerSeg, gst_learner_seg, GST, LEARNER_SEG, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(learnerseg);

G_END_DECLS
