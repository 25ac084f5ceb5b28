#include "rgbdcoded.h"

#include <string>

GstCaps* rgbd_caps_renamed(GstCaps* caps, const char* name, bool coded) {
  GstCaps* out = gst_caps_copy(caps);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    gst_structure_set_name(s, name);
    if (coded) {
      gst_structure_set(s, "codec", G_TYPE_STRING, "vcrd1", nullptr);
      // Only colour, depth and labels are coded; the coded caps say what arrives.
      if (const char* planes = gst_structure_get_string(s, "planes")) {
        std::string kept;
        gchar** names = g_strsplit(planes, ",", -1);
        for (gchar** n = names; *n; ++n) {
          const std::string name = g_strstrip(*n);
          if (name == "color" || name == "depth" || name == "label") kept += (kept.empty() ? "" : ",") + name;
        }
        g_strfreev(names);
        gst_structure_set(s, "planes", G_TYPE_STRING, kept.c_str(), nullptr);
      }
    } else {
      gst_structure_remove_field(s, "codec");
    }
  }
  return out;
}

GstCaps* caps_filtered(GstCaps* caps, GstCaps* filter) {
  if (!filter) return caps;
  GstCaps* out = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
  gst_caps_unref(caps);
  return out;
}

bool take_queued_input(GstBaseTransform* trans, gboolean negotiated, GstBuffer** in, GstFlowReturn* ret) {
  *in = trans->queued_buf;
  trans->queued_buf = nullptr;
  *ret = GST_FLOW_OK;
  if (!*in) return false;
  if (!negotiated) {
    gst_buffer_unref(*in);
    *in = nullptr;
    *ret = GST_FLOW_NOT_NEGOTIATED;
    return false;
  }
  return true;
}
