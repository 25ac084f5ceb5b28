// libFuzzer target: what reaches the WHEP HTTP server before a request's body (issue #29): the request
// head as judge_request_head() sees it, and the connection counting a stream of accepts and closes drives.
// First byte even: a head. Bytes 1-8 the Content-Length (any int64, negative = absent), byte 9 bit 0
// chunked, then "method\npath\ntoken\nexpected token". The verdict must be one of the documented statuses;
// a request read on (status 0) must carry the token, a length within the limit, and a body only on POST.
// First byte odd: connection events, two bytes each (bit 7 of the first: close, else open; the address
// one of 8), against caps taken from bytes 1-2; the counts must stay within the caps and add up.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include <gst/vclassroom/webrtc/whep.h>

using namespace vclassroom;

namespace {

void judge(const uint8_t* data, size_t size) {
  if (size < 10) return;
  int64_t length;
  std::memcpy(&length, data + 1, sizeof length);
  const std::string_view text(reinterpret_cast<const char*>(data + 10), size - 10);
  std::vector<std::string_view> field;
  size_t start = 0;
  while (field.size() < 3) {
    const size_t end = text.find('\n', start);
    if (end == std::string_view::npos) break;
    field.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  if (field.size() < 3) return;
  const std::string_view expected = text.substr(start);
  WhepRequestHead head;
  head.method = field[0];
  head.path = field[1];
  head.token = field[2];
  head.content_length = length < 0 ? -1 : length;
  head.chunked = (data[9] & 1) != 0;
  WhepLimits limits;
  const WhepHeadVerdict v = judge_request_head(head, expected, limits);
  const int s = v.status;
  if (s != 0 && s != 400 && s != 401 && s != 413 && s != 414) std::abort();
  if (s != 0 && v.why.empty()) std::abort();
  if (!token_equal(expected, head.token) && s != 401) std::abort();
  if (s == 0) {
    if (head.content_length > 0 && static_cast<uint64_t>(head.content_length) > limits.max_offer_bytes) std::abort();
    if ((head.chunked || head.content_length > 0) && head.method != "POST") std::abort();
    if (head.path.size() > kMaxWhepPathBytes) std::abort();
  }
}

void count(const uint8_t* data, size_t size) {
  if (size < 3) return;
  const ConnectionLimits limits{size_t(data[1] % 32) + 1, size_t(data[2] % 8) + 1};
  ConnectionCounter counter(limits);
  size_t open[8] = {};
  for (size_t at = 3; at + 1 < size; at += 2) {
    const std::string address = "10.0.0." + std::to_string(data[at + 1] % 8);
    const size_t k = data[at + 1] % 8;
    if (data[at] & 0x80) {
      counter.release(address);
      if (open[k] > 0) --open[k];
    } else if (counter.admit(address)) {
      ++open[k];
    }
    size_t total = 0;
    for (size_t i = 0; i < 8; ++i) {
      if (open[i] > limits.max_per_address) std::abort();
      if (counter.from("10.0.0." + std::to_string(i)) != open[i]) std::abort();
      total += open[i];
    }
    if (total != counter.total() || total > limits.max_total) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (data[0] % 2 == 0)
    judge(data, size);
  else
    count(data, size);
  return 0;
}
