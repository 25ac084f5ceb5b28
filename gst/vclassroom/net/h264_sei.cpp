#include <gst/vclassroom/net/h264_sei.h>

#include <cstring>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

// Drawn once at random for this format ("VCDL" depth in the camera link).
const SeiUuid kDepthLinkSeiUuid = {0x6b, 0x1f, 0x2d, 0x90, 0x4e, 0x3a, 0x47, 0x0c,
                                   0x9d, 0x55, 0xa8, 0x21, 0xc3, 0x7e, 0x10, 0xd4};

namespace {

struct Nal {
  size_t start_code;  // where its start code begins
  size_t begin;       // its header byte
  size_t end;         // one past its last byte
};

// The NAL units of an Annex B stream, in order.
std::vector<Nal> split_nals(const uint8_t* p, size_t n) {
  std::vector<Nal> nals;
  size_t i = 0;
  while (i + 3 <= n) {
    if (p[i] == 0 && p[i + 1] == 0 && p[i + 2] == 1) {
      const size_t sc = (i > 0 && p[i - 1] == 0) ? i - 1 : i;
      if (!nals.empty()) {
        size_t e = sc;
        while (e > nals.back().begin && p[e - 1] == 0) --e;  // trailing zero bytes
        nals.back().end = e;
      }
      nals.push_back({sc, i + 3, n});
      i += 3;
    } else {
      ++i;
    }
  }
  return nals;
}

void write_ff_coded(size_t v, std::vector<uint8_t>* rbsp) {
  while (v >= 255) {
    rbsp->push_back(255);
    v -= 255;
  }
  rbsp->push_back(uint8_t(v));
}

// Emulation prevention (H.264 7.4.1): 0x000000..0x000003 never occur inside a NAL unit.
void escape_into(const std::vector<uint8_t>& rbsp, std::vector<uint8_t>* out) {
  int zeros = 0;
  for (uint8_t b : rbsp) {
    if (zeros >= 2 && b <= 3) {
      out->push_back(3);
      zeros = 0;
    }
    out->push_back(b);
    zeros = b == 0 ? zeros + 1 : 0;
  }
}

void unescape(const uint8_t* p, size_t n, std::vector<uint8_t>* rbsp) {
  rbsp->clear();
  rbsp->reserve(n);
  int zeros = 0;
  for (size_t i = 0; i < n; ++i) {
    if (zeros >= 2 && p[i] == 3) {
      zeros = 0;
      continue;
    }
    rbsp->push_back(p[i]);
    zeros = p[i] == 0 ? zeros + 1 : 0;
  }
}

// Reads an ff-coded value (payload type or size); false when cut short.
bool read_ff_coded(const std::vector<uint8_t>& r, size_t* i, size_t* v) {
  *v = 0;
  while (*i < r.size()) {
    const uint8_t b = r[(*i)++];
    *v += b;
    if (b != 255) return true;
    if (*v > (size_t(1) << 30)) return false;
  }
  return false;
}

}  // namespace

void h264_insert_user_data(const uint8_t* au, size_t size, const SeiUuid& uuid, const uint8_t* data, size_t len,
                           std::vector<uint8_t>* out) {
  const std::vector<Nal> nals = split_nals(au, size);
  size_t at = size;
  for (const Nal& nal : nals) {
    const int type = nal.begin < size ? au[nal.begin] & 0x1f : 0;
    if (type >= 1 && type <= 5) {
      at = nal.start_code;
      break;
    }
  }
  if (at == size) throw Error("H.264 access unit without a slice (expected an Annex B picture)");
  std::vector<uint8_t> rbsp;
  rbsp.reserve(len + 32);
  write_ff_coded(5, &rbsp);  // user_data_unregistered
  write_ff_coded(len + 16, &rbsp);
  rbsp.insert(rbsp.end(), uuid, uuid + 16);
  rbsp.insert(rbsp.end(), data, data + len);
  rbsp.push_back(0x80);  // rbsp_trailing_bits
  out->clear();
  out->reserve(size + len + len / 64 + 64);
  out->insert(out->end(), au, au + at);
  const uint8_t head[5] = {0, 0, 0, 1, 0x06};
  out->insert(out->end(), head, head + 5);
  escape_into(rbsp, out);
  out->insert(out->end(), au + at, au + size);
}

SeiFind h264_find_user_data(const uint8_t* au, size_t size, const SeiUuid& uuid, size_t max_len,
                            std::vector<uint8_t>* data, std::string* error) {
  std::vector<uint8_t> r;
  for (const Nal& nal : split_nals(au, size)) {
    if (nal.begin >= nal.end || (au[nal.begin] & 0x1f) != 6) continue;
    unescape(au + nal.begin + 1, nal.end - nal.begin - 1, &r);
    size_t i = 0;
    while (i < r.size() && !(i + 1 == r.size() && r[i] == 0x80)) {
      size_t type = 0, len = 0;
      if (!read_ff_coded(r, &i, &type) || !read_ff_coded(r, &i, &len) || len > r.size() - i) break;
      if (type == 5 && len >= 16 && std::memcmp(r.data() + i, uuid, 16) == 0) {
        if (len - 16 > max_len) {
          if (error) *error = "depth SEI of " + std::to_string(len - 16) + " bytes, beyond " + std::to_string(max_len);
          return SeiFind::kMalformed;
        }
        data->assign(r.begin() + long(i) + 16, r.begin() + long(i + len));
        return SeiFind::kFound;
      }
      i += len;
    }
    // A SEI NAL cut short: if ours was in it, it is damaged; otherwise nothing of ours was there.
    if (i < r.size() && !(i + 1 == r.size() && r[i] == 0x80) && r.size() - i >= 18) {
      for (size_t k = i; k + 16 <= r.size(); ++k) {
        if (std::memcmp(r.data() + k, uuid, 16) == 0) {
          if (error) *error = "depth SEI cut short";
          return SeiFind::kMalformed;
        }
      }
    }
  }
  return SeiFind::kAbsent;
}

bool h264_has_slice(const uint8_t* au, size_t size) {
  for (const Nal& nal : split_nals(au, size))
    if (nal.begin < nal.end && (au[nal.begin] & 0x1f) >= 1 && (au[nal.begin] & 0x1f) <= 5) return true;
  return false;
}

bool h264_is_idr(const uint8_t* au, size_t size) {
  for (const Nal& nal : split_nals(au, size))
    if (nal.begin < nal.end && (au[nal.begin] & 0x1f) == 5) return true;
  return false;
}

}  // namespace vclassroom
