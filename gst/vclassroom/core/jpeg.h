// Colour images as baseline JPEG (libjpeg-turbo): the camera link's colour codec and a UVC camera's MJPEG
// frames use the same two functions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vclassroom {

// RGB (CV_8UC3) <-> baseline JPEG. Decoding takes any chroma sampling and
// rejects corrupt data (libjpeg's warnings count as corruption) and images of
// another size. The encoder samples the chroma as the project's colour codec
// does (full at quality 90 and above, else halved both ways), or halved across
// only, as a UVC camera's MJPEG frames are (4:2:2; the camera stand-ins).
enum class JpegChroma { kByQuality, kUvc422 };
void encode_jpeg(const cv::Mat& rgb, int quality, std::vector<uint8_t>* out,
                 JpegChroma chroma = JpegChroma::kByQuality);
bool decode_jpeg(const uint8_t* data, size_t size, int width, int height, cv::Mat* rgb, std::string* error);

}  // namespace vclassroom
