// libFuzzer target: the dataset reader's two inputs from outside, chosen by the
// first byte: an image file's bytes (decode_image, as Dataset::load,
// load_static_model and the Middlebury import read them; the size declared in
// the header is checked before decoding), or a folder listing (pair_by_name:
// lines "c <colour file>" / "d <depth file>"), or a live recording's records
// (index_coded_stream, as Dataset::open reads cam<ID>/stream.vcrs). Only
// vclassroom::Error may come out.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include <gst/vclassroom/datasets/dataset.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t mode = data[0] % 4;
  ++data;
  --size;
  try {
    if (mode == 0 || mode == 1) {
      // A rig camera of 40x30, as the tests' small datasets; mode 0 reads depth, 1 colour.
      const cv::Mat m = decode_image(data, size, mode == 0 ? cv::IMREAD_UNCHANGED : cv::IMREAD_COLOR,
                                     mode == 0 ? "depth" : "colour", "fuzz.png", cv::Size(40, 30), "rig camera 0");
      if (m.cols != 40 || m.rows != 30) std::abort();
    } else if (mode == 3) {
      auto read = [&](uint64_t offset, uint8_t* out, size_t n) {
        if (offset > size || n > size - offset) return false;
        std::memcpy(out, data + offset, n);
        return true;
      };
      const CodedStreamIndex index = index_coded_stream(read, size, "fuzz.vcrs", 1000);
      uint64_t end = kCodedStreamHeaderSize;
      for (const auto& f : index.frames) {
        // Every indexed frame lies inside the bytes, after the one before.
        if (f.offset < end || f.size == 0 || f.offset + f.size > size) std::abort();
        end = f.offset + f.size;
      }
    } else {
      std::vector<std::string> color, depth;
      const std::string text(reinterpret_cast<const char*>(data), size);
      size_t at = 0;
      while (at < text.size()) {
        size_t end = text.find('\n', at);
        if (end == std::string::npos) end = text.size();
        const std::string line = text.substr(at, end - at);
        if (line.size() > 2 && line[1] == ' ') (line[0] == 'c' ? color : depth).push_back(line.substr(2));
        at = end + 1;
      }
      const std::vector<std::string> paired = pair_by_name(color, depth, "depth");
      if (!depth.empty() && paired.size() != color.size()) std::abort();
    }
  } catch (const Error&) {
  }
  return 0;
}
