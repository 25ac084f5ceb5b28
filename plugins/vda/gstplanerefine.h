#pragma once

#include <gst/vclassroom/core/rgbd_filter.h>

G_BEGIN_DECLS

#define GST_TYPE_PLANE_REFINE (gst_plane_refine_get_type())
G_DECLARE_FINAL_TYPE(GstPlaneRefine, gst_plane_refine, GST, PLANE_REFINE, GstRgbdFilter)

GST_ELEMENT_REGISTER_DECLARE(planerefine);

G_END_DECLS
