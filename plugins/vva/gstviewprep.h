#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_VIEW_PREP (gst_view_prep_get_type())
G_DECLARE_FINAL_TYPE(GstViewPrep, gst_view_prep, GST, VIEW_PREP, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(viewprep);

G_END_DECLS
