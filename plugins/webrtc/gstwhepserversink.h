#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

GType gst_whep_server_sink_get_type(void);
#define GST_TYPE_WHEP_SERVER_SINK (gst_whep_server_sink_get_type())

GST_ELEMENT_REGISTER_DECLARE(whepserversink);

G_END_DECLS
