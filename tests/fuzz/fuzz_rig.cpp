// libFuzzer target: the rig file reader (parse_rig_text, what load_rig runs on
// a file's bytes). Only vclassroom::Error may come out (any other exception
// escapes this function and counts as a crash); an accepted rig is valid and
// survives save -> load unchanged.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <gst/vclassroom/core/rig.h>

using namespace vclassroom;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Rig rig;
  try {
    rig = parse_rig_text(text, "fuzz.yaml");
  } catch (const Error& e) {
    if (std::string(e.what()).rfind("fuzz.yaml", 0) != 0) std::abort();  // every message names the file
    return 0;
  }
  const Rig back = parse_rig_text(rig_to_text(rig), "again.yaml");  // throws (a crash) if it does not load
  if (back.name != rig.name || back.cameras.size() != rig.cameras.size()) std::abort();
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const CameraCalib &a = rig.cameras[i], &b = back.cameras[i];
    if (a.id != b.id || a.name != b.name || a.width != b.width || a.height != b.height || a.fx != b.fx ||
        a.fy != b.fy || a.cx != b.cx || a.cy != b.cy || a.distortion != b.distortion ||
        a.depth_scale != b.depth_scale || !(a.cam_to_rig.matrix() == b.cam_to_rig.matrix()) ||
        a.depth_to_color.has_value() != b.depth_to_color.has_value())
      std::abort();
  }
  return 0;
}
