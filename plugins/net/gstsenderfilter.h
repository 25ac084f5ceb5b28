#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_SENDER_FILTER (gst_sender_filter_get_type())
G_DECLARE_FINAL_TYPE(GstSenderFilter, gst_sender_filter, GST, SENDER_FILTER, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(senderfilter);

G_END_DECLS
