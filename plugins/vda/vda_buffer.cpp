#include "vda_buffer.h"

using namespace vclassroom;

namespace vda {

StaticModel load_model_for_stream(const std::string& folder, const RgbdInfo& info, std::string* refused) {
  StaticModel m = load_static_model(folder);
  *refused = model_stream_mismatch(m, folder, info.camera.id, info.width(), info.height());
  return m;
}

}  // namespace vda
