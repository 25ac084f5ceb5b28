// The SRTP master key of a deployment, from a file: 30 bytes (a 16-byte AES key and a 14-byte salt, as
// AES_CM_128_HMAC_SHA1_80 needs), made with e.g. `head -c 30 /dev/urandom > srtp.key`. GStreamer-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace vclassroom {

constexpr size_t kSrtpKeyBytes = 30;

// Reads the key; throws vclassroom::Error naming the file when it is missing or not exactly 30 bytes.
std::vector<uint8_t> read_srtp_key(const std::string& path);
// Lower-case hex, as srtpenc's key property and the srtp-key caps field take it.
std::string to_hex(const std::vector<uint8_t>& bytes);

}  // namespace vclassroom
