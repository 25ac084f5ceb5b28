// The camera link's colour conversions (docs/network.md, "The H.264 camera link"): 8-bit RGB to I420 on the
// camera and back on the server, where videoconvert's general path (unpack to AYUV, convert, pack) took about
// 2.8 ms and 1.2 ms of a 960x540 frame, beside 4 to 5 ms of x264enc or openh264dec. ITU-R BT.601, limited
// range (Y 16-235, Cb/Cr 16-240: GStreamer's colorimetry "bt601", its default for I420 of this size), each
// chroma sample the mean of its 2x2 pixels (centred: chroma-site "jpeg"), and back bilinearly from the centres.
// Not OpenCV's cvtColor I420 paths: they take no plane strides, and back to RGB they repeat each chroma sample
// (nearest) where the link interpolates it (34.5 dB against the camera's colour with these conversions).
#pragma once

#include <cstdint>

namespace vclassroom {

// `rgb`: w x h pixels, rows `rgb_stride` bytes apart. The planes: Y w x h, Cb and Cr ceil(w/2) x ceil(h/2),
// rows their strides apart. An odd last column or row is averaged with itself.
void rgb_to_i420(const uint8_t* rgb, int rgb_stride, int w, int h, uint8_t* y, int y_stride, uint8_t* cb,
                 int cb_stride, uint8_t* cr, int cr_stride);

// The inverse: `rgb` (w x h, rows `rgb_stride` bytes apart) from the planes as rgb_to_i420() lays them out; each
// pixel's chroma interpolated bilinearly between the four nearest chroma samples (weights 9, 3, 3, 1 / 16; at
// the image's edges the nearest sample repeats).
void i420_to_rgb(const uint8_t* y, int y_stride, const uint8_t* cb, int cb_stride, const uint8_t* cr, int cr_stride,
                 int w, int h, uint8_t* rgb, int rgb_stride);

}  // namespace vclassroom
