// A lossy network in one process: preloaded (LD_PRELOAD) into a program, it drops a share of the RTP and
// SRTP datagrams the program sends, as a Wi-Fi link that loses packets would, before the kernel sees them.
// Everything else passes: STUN and TURN (ICE), DTLS (the handshake, and the data channel inside it), RTCP,
// and any datagram that is not RTP (RFC 7983's first-byte ranges: RTP/RTCP 128..191, and RTCP's packet
// types 192..223 in the second byte). The program's own code runs unchanged: vclassroom-measure-lecturers
// --loss uses it to show what a lossy link does to the lecturer's picture, without a network namespace or
// netem (which this project's machines lack).
//
// VCLASSROOM_LOSS_PERCENT: the share of RTP datagrams dropped, 0..100 (unset or 0: nothing is dropped).
// VCLASSROOM_LOSS_SEED: the seed of the drop pattern (default 1): the same seed drops the same datagrams of
// the same sequence.
#include <dlfcn.h>
#include <sys/socket.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>

namespace {

double loss_share() {
  static const double share = [] {
    const char* v = std::getenv("VCLASSROOM_LOSS_PERCENT");
    const double p = v ? std::strtod(v, nullptr) : 0.0;
    return p > 0.0 ? (p < 100.0 ? p / 100.0 : 1.0) : 0.0;
  }();
  return share;
}

// splitmix64 over a shared counter: a reproducible pattern that any thread may draw from.
bool draw_drop() {
  static std::atomic<uint64_t> counter{0};
  static const uint64_t seed = [] {
    const char* v = std::getenv("VCLASSROOM_LOSS_SEED");
    return v ? std::strtoull(v, nullptr, 10) : 1ull;
  }();
  uint64_t z = seed + 0x9e3779b97f4a7c15ull * (counter.fetch_add(1) + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return double(z >> 11) * (1.0 / 9007199254740992.0) < loss_share();
}

bool is_rtp(const uint8_t* p, size_t n) {
  if (n < 12 || p[0] < 128 || p[0] > 191) return false;
  return p[1] < 192 || p[1] > 223;
}

// The first bytes of a message, gathered from its iovecs.
bool message_is_rtp(const struct msghdr* msg) {
  uint8_t head[12];
  size_t have = 0;
  for (size_t i = 0; i < msg->msg_iovlen && have < sizeof head; ++i) {
    const struct iovec& v = msg->msg_iov[i];
    const size_t take = v.iov_len < sizeof head - have ? v.iov_len : sizeof head - have;
    std::memcpy(head + have, v.iov_base, take);
    have += take;
  }
  return is_rtp(head, have);
}

size_t message_bytes(const struct msghdr* msg) {
  size_t total = 0;
  for (size_t i = 0; i < msg->msg_iovlen; ++i) total += msg->msg_iov[i].iov_len;
  return total;
}

template <typename F>
F real(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

}  // namespace

extern "C" {

ssize_t sendto(int fd, const void* buf, size_t len, int flags, const struct sockaddr* to, socklen_t to_len) {
  static auto next = real<ssize_t (*)(int, const void*, size_t, int, const struct sockaddr*, socklen_t)>("sendto");
  if (loss_share() > 0 && is_rtp(static_cast<const uint8_t*>(buf), len) && draw_drop()) return ssize_t(len);
  return next(fd, buf, len, flags, to, to_len);
}

ssize_t send(int fd, const void* buf, size_t len, int flags) { return sendto(fd, buf, len, flags, nullptr, 0); }

ssize_t sendmsg(int fd, const struct msghdr* msg, int flags) {
  static auto next = real<ssize_t (*)(int, const struct msghdr*, int)>("sendmsg");
  if (loss_share() > 0 && message_is_rtp(msg) && draw_drop()) return ssize_t(message_bytes(msg));
  return next(fd, msg, flags);
}

// Each message on its own: the dropped ones count as sent, as the network would have taken them.
int sendmmsg(int fd, struct mmsghdr* msgs, unsigned int count, int flags) {
  for (unsigned int i = 0; i < count; ++i) {
    const ssize_t n = sendmsg(fd, &msgs[i].msg_hdr, flags);
    if (n < 0) return i > 0 ? int(i) : -1;
    msgs[i].msg_len = unsigned(n);
  }
  return int(count);
}

}  // extern "C"
