// The camera link's colour conversion (docs/network.md, "The H.264 camera link"): 8-bit RGB to I420 on the
// camera, where videoconvert's general path (unpack to AYUV, convert, pack) took about 2.8 ms of a 960x540
// frame, two thirds of the colour's CPU time beside x264enc. ITU-R BT.601, limited range (Y 16-235, Cb/Cr
// 16-240: GStreamer's colorimetry "bt601", its default for I420 of this size), each chroma sample the mean of
// its 2x2 pixels (centred: chroma-site "jpeg").
#pragma once

#include <cstdint>

namespace vclassroom {

// `rgb`: w x h pixels, rows `rgb_stride` bytes apart. The planes: Y w x h, Cb and Cr ceil(w/2) x ceil(h/2),
// rows their strides apart. An odd last column or row is averaged with itself.
void rgb_to_i420(const uint8_t* rgb, int rgb_stride, int w, int h, uint8_t* y, int y_stride, uint8_t* cb,
                 int cb_stride, uint8_t* cr, int cr_stride);

}  // namespace vclassroom
