// Shared by depthcomplete and planerefine: the camera's part of a static model folder.
#pragma once

#include <string>

#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/vda/static_model.h>

namespace vda {

// Loads `folder` (throws vclassroom::Error naming it when it cannot be read:
// the operator's own file, a setup error) and sets *refused to why the
// stream cannot use it (model_stream_mismatch: "" when it can).
vclassroom::StaticModel load_model_for_stream(const std::string& folder, const vclassroom::RgbdInfo& info,
                                              std::string* refused);

}  // namespace vda
