#pragma once

#include <gst/base/gstaggregator.h>

G_BEGIN_DECLS

#define GST_TYPE_VIEW_FUSE (gst_view_fuse_get_type())
G_DECLARE_FINAL_TYPE(GstViewFuse, gst_view_fuse, GST, VIEW_FUSE, GstAggregator)

GST_ELEMENT_REGISTER_DECLARE(viewfuse);

G_END_DECLS
