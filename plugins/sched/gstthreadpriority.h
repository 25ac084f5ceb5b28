#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_THREAD_PRIORITY (gst_thread_priority_get_type())
G_DECLARE_FINAL_TYPE(GstThreadPriority, gst_thread_priority, GST, THREAD_PRIORITY, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE(threadpriority);

G_END_DECLS
