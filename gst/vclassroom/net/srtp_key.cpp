#include <gst/vclassroom/net/srtp_key.h>

#include <fstream>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

std::vector<uint8_t> read_srtp_key(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("SRTP key file '" + path + "' cannot be read");
  std::vector<uint8_t> key(kSrtpKeyBytes + 1);
  in.read(reinterpret_cast<char*>(key.data()), static_cast<std::streamsize>(key.size()));
  const size_t got = static_cast<size_t>(in.gcount());
  if (got != kSrtpKeyBytes)
    throw Error("SRTP key file '" + path + "' must hold exactly 30 bytes (AES_CM_128_HMAC_SHA1_80: 16 key + 14 salt), " +
                (got > kSrtpKeyBytes ? std::string("it holds more") : "it holds " + std::to_string(got)) +
                "; make one with: head -c 30 /dev/urandom > srtp.key");
  key.resize(kSrtpKeyBytes);
  return key;
}

std::string to_hex(const std::vector<uint8_t>& bytes) {
  static const char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size() * 2);
  for (uint8_t b : bytes) {
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

}  // namespace vclassroom
