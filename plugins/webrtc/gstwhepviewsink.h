#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

GType gst_whep_view_sink_get_type(void);
#define GST_TYPE_WHEP_VIEW_SINK (gst_whep_view_sink_get_type())

GST_ELEMENT_REGISTER_DECLARE(whepviewsink);

G_END_DECLS
