// Errors raised by the GStreamer-free part of gst-vclassroom.
#pragma once

#include <stdexcept>
#include <string>

namespace vclassroom {

// Thrown for bad input files and values. The message is complete and meant
// for a person: it names the file (when there is one), the camera and the
// field, and what was expected, so elements can post it on the bus unchanged.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace vclassroom
