// The largest image anywhere in the project: a rig camera, caps, a recorded or coded frame, a V4L2 mode.
// Every parser checks declared sizes against it before it allocates.
#pragma once

#include <glib.h>

// As a macro too, for static caps strings: "width = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ]".
#define VCLASSROOM_MAX_IMAGE_SIDE 16384

namespace vclassroom {

inline constexpr int kMaxImageSide = VCLASSROOM_MAX_IMAGE_SIDE;

}  // namespace vclassroom
