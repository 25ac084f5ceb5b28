#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_PLANE_REFINE (gst_plane_refine_get_type())
G_DECLARE_FINAL_TYPE(GstPlaneRefine, gst_plane_refine, GST, PLANE_REFINE, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(planerefine);

G_END_DECLS
