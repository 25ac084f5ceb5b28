// H.264 access units (Annex B byte stream) carrying application data in SEI "user data unregistered"
// messages (ITU-T H.264 D.1.7 / D.2.7: a 16-byte UUID, then the data), which every decoder skips: the
// camera link's depth rides in its colour's access unit (docs/network.md). GStreamer-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vclassroom {

using SeiUuid = uint8_t[16];

// The UUID of the camera link's depth SEI (a random one, fixed for this format).
extern const SeiUuid kDepthLinkSeiUuid;

// Copies the access unit `au` into `out` with one SEI NAL unit (nal_ref_idc 0, type 6) holding `data` under
// `uuid` inserted before its first slice, emulation prevention applied. Throws vclassroom::Error when the
// access unit has no slice (not Annex B, or not a picture).
void h264_insert_user_data(const uint8_t* au, size_t size, const SeiUuid& uuid, const uint8_t* data, size_t len,
                           std::vector<uint8_t>* out);

enum class SeiFind { kFound, kAbsent, kMalformed };
// Finds the first user data unregistered message with `uuid` in the SEI NAL units of `au` and copies its
// data (emulation prevention removed) into `data`; kMalformed (with `error`) when a SEI under that UUID is
// cut short, declares more than it holds, or more than `max_len`.
SeiFind h264_find_user_data(const uint8_t* au, size_t size, const SeiUuid& uuid, size_t max_len,
                            std::vector<uint8_t>* data, std::string* error);

// Whether the access unit holds a slice (NAL types 1-5): a picture, not parameter sets alone.
bool h264_has_slice(const uint8_t* au, size_t size);
// Whether the access unit holds an IDR slice (NAL type 5).
bool h264_is_idr(const uint8_t* au, size_t size);

}  // namespace vclassroom
