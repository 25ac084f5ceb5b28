// Caps of the compressed stream shared by rgbdenc and rgbddec: the
// video/x-rgbd fields (size, rate, planes, calibration) under another name.
#pragma once

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>

inline constexpr const char* kRgbdCodedMediaType = "video/x-rgbd-coded";
inline constexpr const char* kRgbdCodedTemplateCaps =
    "video/x-rgbd-coded, codec = (string) vcrd1, width = (int) [ 1, 16384 ], height = (int) [ 1, 16384 ], "
    "framerate = (fraction) [ 0/1, 2147483647/1 ]";

// Renames every structure of `caps` to `name`, adding or removing the codec field.
GstCaps* rgbd_caps_renamed(GstCaps* caps, const char* name, bool coded);

// `caps` narrowed to `filter` (when given); takes ownership of `caps`.
GstCaps* caps_filtered(GstCaps* caps, GstCaps* filter);

// Takes the input buffer GstBaseTransform queued for generate_output. False
// when there is none or caps were never set (then *ret says which).
bool take_queued_input(GstBaseTransform* trans, gboolean negotiated, GstBuffer** in, GstFlowReturn* ret);
