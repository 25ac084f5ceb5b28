// A stand-in for an RGB-D camera's V4L2 nodes, for the tests of rgbdsrc on a
// machine without a camera. Preloaded (LD_PRELOAD), it answers open, ioctl,
// mmap, munmap and close for the fake device paths named in the environment
// exactly as a V4L2 capture driver does (QUERYCAP, ENUM_FMT/FRAMESIZES/
// FRAMEINTERVALS, S_FMT, S_PARM, REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON/OFF,
// capture timestamps on CLOCK_MONOTONIC); every other file goes to the real
// calls. The file descriptor is an eventfd, so poll() works unchanged. Frames
// are rendered by the synthetic classroom.
//
// VCLASSROOM_FAKE_V4L2 = device;device;..., each a comma-separated list of
// key=value: path (required), format (YUYV, RGB3, MJPG, Z16, Y16), width,
// height, fps (30), camera (rig camera id, 0), learners (3; 0: the empty room), rig (rig file; default: the
// default classroom rig), seed (1), and misbehaviour: drop (share of instants
// skipped), jitter_ms (timestamp jitter), short_at (this frame comes short),
// eio_at (DQBUF fails with EIO at this frame), enodev_at (the device vanishes
// at this frame), counting from the stream's start, and busy (1: another
// program holds it: S_FMT and REQBUFS fail with EBUSY). board=1 carries the
// calibration board through the room (rgbdtestsrc's calibration-board): each
// instant n is then rendered anew at scene time n / fps, the same on every node.
//
// Every frame carries its instant n (frames of one instant on two nodes are
// one moment): depth pixel (0, 0) holds n + 1, and colour's top-left 8x8 block
// the grey level 20 + (37 n) mod 200.
// Both open and open64 (and mmap, mmap64) are defined here: whatever a caller
// was built with, its call lands in this file.
#undef _FILE_OFFSET_BITS
#ifndef _LARGEFILE64_SOURCE
#define _LARGEFILE64_SOURCE 1
#endif
#include <dlfcn.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdarg>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/synthetic/board_trace.h>
#include <gst/vclassroom/synthetic/classroom.h>

namespace {

using namespace vclassroom;

struct Config {
  std::string path;
  uint32_t fourcc = V4L2_PIX_FMT_YUYV;
  int width = 64, height = 48, fps = 30, camera = 0;
  std::string rig;
  uint64_t seed = 1;
  int learners = 3;  // the synthetic classroom's learners (0: the empty room)
  double drop = 0, jitter_ms = 0;
  long short_at = -1, eio_at = -1, enodev_at = -1;
  bool busy = false;
  bool vanish_once = false;  // after it vanished, the node comes back for good (a camera plugged in again)
  bool board = false;
};

struct Buffer {
  void* data = nullptr;
  size_t length = 0;
  uint32_t bytesused = 0;
  timeval timestamp{};
  uint32_t sequence = 0;
  bool queued = false, done = false;
};

struct Device {
  Config cfg;
  int fd = -1;
  std::mutex lock;
  std::condition_variable wake;
  std::vector<Buffer> buffers;
  std::deque<uint32_t> queued, done;
  bool streaming = false, vanished = false, stop = false;
  long eio_pending = -1;
  std::thread producer;
  cv::Mat color, depth;  // the rendered scene, RGB and mm
  // board=1: the scene and the camera each instant is rendered from.
  std::unique_ptr<Classroom> room;
  CameraCalib camera;
  ClassroomRenderer renderer;
  RenderOutput frame;
};

std::mutex g_lock;
std::map<int, std::shared_ptr<Device>> g_devices;
std::atomic<int> g_device_count{0};  // munmap looks no further while there is none
std::vector<Config> g_configs;
std::string g_parsed_from;
std::vector<std::string> g_vanished;  // paths that went away once (vanish_once)  // the environment the configs were read from: a test may change it between runs

// The instants' common epoch: frames of one instant on two nodes share a time.
std::chrono::steady_clock::time_point epoch() {
  static const auto t = std::chrono::steady_clock::now();
  return t;
}

template <typename F>
F real(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

uint32_t fourcc_from(const std::string& s) {
  if (s == "YUYV") return V4L2_PIX_FMT_YUYV;
  if (s == "RGB3") return V4L2_PIX_FMT_RGB24;
  if (s == "MJPG") return V4L2_PIX_FMT_MJPEG;
  if (s == "Z16") return V4L2_PIX_FMT_Z16;
  if (s == "Y16") return V4L2_PIX_FMT_Y16;
  return 0;
}

void parse_configs() {
  const char* env = getenv("VCLASSROOM_FAKE_V4L2");
  const std::string all = env ? env : "";
  if (all == g_parsed_from && !g_configs.empty()) return;
  g_parsed_from = all;
  g_configs.clear();
  size_t at = 0;
  while (at <= all.size()) {
    size_t end = all.find(';', at);
    if (end == std::string::npos) end = all.size();
    const std::string dev = all.substr(at, end - at);
    at = end + 1;
    if (dev.empty()) continue;
    Config c;
    size_t p = 0;
    while (p <= dev.size()) {
      size_t e = dev.find(',', p);
      if (e == std::string::npos) e = dev.size();
      const std::string kv = dev.substr(p, e - p);
      p = e + 1;
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) continue;
      const std::string k = kv.substr(0, eq), v = kv.substr(eq + 1);
      if (k == "path") c.path = v;
      else if (k == "format") c.fourcc = fourcc_from(v);
      else if (k == "width") c.width = std::stoi(v);
      else if (k == "height") c.height = std::stoi(v);
      else if (k == "fps") c.fps = std::stoi(v);
      else if (k == "camera") c.camera = std::stoi(v);
      else if (k == "rig") c.rig = v;
      else if (k == "seed") c.seed = std::stoull(v);
      else if (k == "learners") c.learners = std::stoi(v);
      else if (k == "drop") c.drop = std::stod(v);
      else if (k == "jitter_ms") c.jitter_ms = std::stod(v);
      else if (k == "short_at") c.short_at = std::stol(v);
      else if (k == "eio_at") c.eio_at = std::stol(v);
      else if (k == "enodev_at") c.enodev_at = std::stol(v);
      else if (k == "busy") c.busy = v == "1";
      else if (k == "vanish_once") c.vanish_once = v == "1";
      else if (k == "board") c.board = v == "1";
    }
    if (!c.path.empty()) g_configs.push_back(c);
  }
}

bool is_depth(uint32_t f) { return f == V4L2_PIX_FMT_Z16 || f == V4L2_PIX_FMT_Y16; }

size_t frame_bytes(const Config& c) {
  return size_t(c.width) * c.height * (c.fourcc == V4L2_PIX_FMT_RGB24 ? 3 : 2) + (c.fourcc == V4L2_PIX_FMT_MJPEG ? 65536 : 0);
}

void render_scene(Device* d) {
  Rig rig = d->cfg.rig.empty() ? default_classroom_rig() : load_rig(d->cfg.rig);
  // A depth node of a camera whose rig gives the depth lens apart sees from that lens.
  const CameraCalib& rig_camera = rig.camera(d->cfg.camera);
  const CameraCalib cam =
      scale_camera(is_depth(d->cfg.fourcc) ? depth_sensor_of(rig_camera) : rig_camera, d->cfg.width, d->cfg.height);
  ClassroomConfig cc;
  cc.seed = d->cfg.seed;
  cc.learners = d->cfg.learners;
  const RenderOutput r = render(Classroom(cc), 0.0, cam);
  d->color = r.color.clone();
  d->depth = r.depth.clone();
  if (d->cfg.board) {
    d->room = std::make_unique<Classroom>(cc);
    d->camera = cam;
  }
}

// Writes instant n's frame into `b`; returns its byte count.
uint32_t fill(Device* d, long n, Buffer* b) {
  const Config& c = d->cfg;
  cv::Mat scene_color = d->color, scene_depth = d->depth;
  if (c.board) {
    const double t = double(n) / std::max(1, c.fps);
    d->renderer.render(*d->room, t, d->camera, &d->frame);
    draw_board(trace_board(), board_pose_on_trace(*d->room, t), d->camera, &d->frame);
    scene_color = d->frame.color;
    scene_depth = d->frame.depth;
  }
  if (is_depth(c.fourcc)) {
    cv::Mat depth = scene_depth.clone();
    depth.at<uint16_t>(0, 0) = uint16_t(n + 1);
    const size_t bytes = depth.total() * 2;
    std::memcpy(b->data, depth.data, bytes);
    return uint32_t(bytes);
  }
  cv::Mat rgb = scene_color.clone();
  rgb(cv::Rect(0, 0, 8, 8)).setTo(cv::Scalar::all(20 + (37 * n) % 200));
  if (c.fourcc == V4L2_PIX_FMT_RGB24) {
    std::memcpy(b->data, rgb.data, rgb.total() * 3);
    return uint32_t(rgb.total() * 3);
  }
  if (c.fourcc == V4L2_PIX_FMT_MJPEG) {
    std::vector<uint8_t> jpeg;
    encode_jpeg(rgb, 92, &jpeg, JpegChroma::kUvc422);  // as a UVC camera sends MJPEG
    const size_t bytes = std::min(jpeg.size(), b->length);
    std::memcpy(b->data, jpeg.data(), bytes);
    return uint32_t(bytes);
  }
  const std::vector<uint8_t> yuyv = rgb_to_yuyv(rgb);  // as a UVC camera sends it
  std::memcpy(b->data, yuyv.data(), yuyv.size());
  return uint32_t(yuyv.size());
}

void produce(std::shared_ptr<Device> d) {
  std::mt19937 rng(uint32_t(d->cfg.seed * 7919 + uint64_t(d->cfg.fourcc)));
  std::uniform_real_distribution<double> uni(0, 1);
  const auto period = std::chrono::nanoseconds(1000000000LL / std::max(1, d->cfg.fps));
  const auto start = std::chrono::steady_clock::now();
  // The first instant at or after this stream's start, on the common clock.
  const long first = long((start - epoch()) / period) + 1;
  for (long n = first;; ++n) {
    const long k = n - first;  // the misbehaviours count frames from the stream's start
    const auto due = epoch() + n * period;
    {
      std::unique_lock<std::mutex> lk(d->lock);
      if (d->wake.wait_until(lk, due, [&] { return d->stop; })) return;
      if (d->cfg.drop > 0 && uni(rng) < d->cfg.drop) continue;  // the sensor skipped this instant
      if (d->cfg.enodev_at >= 0 && k >= d->cfg.enodev_at && !d->vanished) {
        d->vanished = true;
        if (d->cfg.vanish_once) {
          std::lock_guard<std::mutex> g(g_lock);
          g_vanished.push_back(d->cfg.path);
        }
        const uint64_t one = 1;
        (void)!write(d->fd, &one, sizeof one);  // wakes poll; DQBUF then says ENODEV
        return;
      }
      if (d->queued.empty()) continue;  // no buffer: a driver drops the frame
      const uint32_t i = d->queued.front();
      d->queued.pop_front();
      Buffer& b = d->buffers[i];
      b.bytesused = fill(d.get(), n, &b);
      if (k == d->cfg.short_at) b.bytesused /= 2;
      if (k == d->cfg.eio_at) d->eio_pending = long(i);
      double jitter = 0;
      if (d->cfg.jitter_ms > 0) jitter = (uni(rng) * 2 - 1) * d->cfg.jitter_ms * 1e6;
      // The capture time, as a driver stamps it: the instant's own time (steady_clock is
      // CLOCK_MONOTONIC here), not when this thread got round to it.
      int64_t t = std::chrono::duration_cast<std::chrono::nanoseconds>(due.time_since_epoch()).count() +
                  int64_t(jitter);
      b.timestamp.tv_sec = t / 1000000000;
      b.timestamp.tv_usec = (t % 1000000000) / 1000;
      b.sequence = uint32_t(n);
      b.queued = false;
      b.done = true;
      d->done.push_back(i);
    }
    const uint64_t one = 1;
    (void)!write(d->fd, &one, sizeof one);
  }
}

std::shared_ptr<Device> device_of(int fd) {
  std::lock_guard<std::mutex> g(g_lock);
  auto it = g_devices.find(fd);
  return it == g_devices.end() ? nullptr : it->second;
}

int fail(int err) {
  errno = err;
  return -1;
}

int fake_ioctl(Device* d, unsigned long request, void* arg) {
  std::unique_lock<std::mutex> lk(d->lock);
  if (d->vanished) return fail(ENODEV);
  const Config& c = d->cfg;
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      std::memset(cap, 0, sizeof *cap);
      std::snprintf(reinterpret_cast<char*>(cap->driver), sizeof cap->driver, "fakev4l2");
      std::snprintf(reinterpret_cast<char*>(cap->card), sizeof cap->card, "Fake RGB-D %s", is_depth(c.fourcc) ? "depth" : "colour");
      // One USB device per rig camera: its colour and depth nodes share the bus, as on a real camera.
      std::snprintf(reinterpret_cast<char*>(cap->bus_info), sizeof cap->bus_info, "usb-fake-%d", c.camera + 1);
      cap->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
      cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* f = static_cast<v4l2_fmtdesc*>(arg);
      if (f->index != 0 || f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return fail(EINVAL);
      f->pixelformat = c.fourcc;
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      auto* s = static_cast<v4l2_frmsizeenum*>(arg);
      if (s->index != 0 || s->pixel_format != c.fourcc) return fail(EINVAL);
      s->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      s->discrete.width = uint32_t(c.width);
      s->discrete.height = uint32_t(c.height);
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto* i = static_cast<v4l2_frmivalenum*>(arg);
      if (i->index != 0 || i->pixel_format != c.fourcc || int(i->width) != c.width || int(i->height) != c.height)
        return fail(EINVAL);
      i->type = V4L2_FRMIVAL_TYPE_DISCRETE;
      i->discrete.numerator = 1;
      i->discrete.denominator = uint32_t(c.fps);
      return 0;
    }
    case VIDIOC_S_FMT: {
      if (c.busy) return fail(EBUSY);
      auto* f = static_cast<v4l2_format*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return fail(EINVAL);
      // As a driver: the nearest it has, whatever was asked.
      f->fmt.pix.pixelformat = c.fourcc;
      f->fmt.pix.width = uint32_t(c.width);
      f->fmt.pix.height = uint32_t(c.height);
      f->fmt.pix.bytesperline = c.fourcc == V4L2_PIX_FMT_MJPEG ? 0 : uint32_t(c.width * (c.fourcc == V4L2_PIX_FMT_RGB24 ? 3 : 2));
      f->fmt.pix.sizeimage = uint32_t(frame_bytes(c));
      return 0;
    }
    case VIDIOC_S_PARM:
      return 0;
    case VIDIOC_REQBUFS: {
      if (c.busy) return fail(EBUSY);
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      if (r->memory != V4L2_MEMORY_MMAP || d->streaming) return fail(EINVAL);
      static auto real_munmap = real<int (*)(void*, size_t)>("munmap");
      for (Buffer& b : d->buffers) real_munmap(b.data, b.length);
      d->buffers.clear();
      d->queued.clear();
      d->done.clear();
      r->count = std::min<uint32_t>(r->count, 8);
      static auto real_mmap = real<void* (*)(void*, size_t, int, int, int, off_t)>("mmap");
      for (uint32_t i = 0; i < r->count; ++i) {
        Buffer b;
        b.length = frame_bytes(c);
        b.data = real_mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        d->buffers.push_back(b);
      }
      return 0;
    }
    case VIDIOC_QUERYBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->index >= d->buffers.size()) return fail(EINVAL);
      b->length = uint32_t(d->buffers[b->index].length);
      b->m.offset = b->index << 24;
      return 0;
    }
    case VIDIOC_QBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->index >= d->buffers.size() || d->buffers[b->index].queued) return fail(EINVAL);
      d->buffers[b->index].queued = true;
      d->buffers[b->index].done = false;
      d->queued.push_back(b->index);
      return 0;
    }
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (d->done.empty()) return fail(EAGAIN);
      uint64_t count;
      (void)!read(d->fd, &count, sizeof count);  // the eventfd: one wake per frame, read them all
      const uint32_t i = d->done.front();
      d->done.pop_front();
      if (!d->done.empty()) {
        const uint64_t more = d->done.size();
        (void)!write(d->fd, &more, sizeof more);
      }
      Buffer& buf = d->buffers[i];
      buf.done = false;
      if (long(i) == d->eio_pending) {
        d->eio_pending = -1;
        d->queued.push_back(i);  // the driver keeps the buffer
        buf.queued = true;
        return fail(EIO);
      }
      b->index = i;
      b->bytesused = buf.bytesused;
      b->timestamp = buf.timestamp;
      b->sequence = buf.sequence;
      b->flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
      b->field = V4L2_FIELD_NONE;
      return 0;
    }
    case VIDIOC_STREAMON: {
      if (d->streaming) return 0;
      d->streaming = true;
      d->stop = false;
      lk.unlock();
      std::shared_ptr<Device> self = device_of(d->fd);
      d->producer = std::thread(produce, self);
      return 0;
    }
    case VIDIOC_STREAMOFF: {
      if (!d->streaming) return 0;
      d->stop = true;
      d->wake.notify_all();
      lk.unlock();
      if (d->producer.joinable()) d->producer.join();
      lk.lock();
      d->streaming = false;
      for (Buffer& b : d->buffers) b.queued = b.done = false;
      d->queued.clear();
      d->done.clear();
      return 0;
    }
    default:
      return fail(ENOTTY);
  }
}

}  // namespace

extern "C" {

int open(const char* path, int flags, ...) {
  static auto real_open = real<int (*)(const char*, int, ...)>("open");
  mode_t mode = 0;
  if (flags & (O_CREAT | O_TMPFILE)) {
    va_list ap;
    va_start(ap, flags);
    mode = mode_t(va_arg(ap, int));
    va_end(ap);
  }
  // Nothing is allocated or locked for a path the environment does not name:
  // open() is called everywhere, also where allocating is unsafe (a
  // sanitizer's report, which reads files to symbolize).
  const char* env = getenv("VCLASSROOM_FAKE_V4L2");
  if (!env || !path || !strstr(env, path)) return real_open(path, flags, mode);
  Config cfg;
  bool fake = false;
  {
    std::lock_guard<std::mutex> g(g_lock);
    parse_configs();
    for (const Config& c : g_configs)
      if (c.path == path) {
        cfg = c;
        fake = true;
      }
    if (fake && cfg.vanish_once && std::find(g_vanished.begin(), g_vanished.end(), cfg.path) != g_vanished.end())
      cfg.enodev_at = -1;
  }
  if (fake) {
    // Rendered without the lock: rendering allocates, and an allocator may
    // call mmap, which looks the lock up too.
    auto d = std::make_shared<Device>();
    d->cfg = cfg;
    d->fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (d->fd < 0) return -1;
    try {
      render_scene(d.get());
    } catch (const std::exception&) {
      ::close(d->fd);
      errno = EIO;
      return -1;
    }
    std::lock_guard<std::mutex> g(g_lock);
    g_devices[d->fd] = d;
    ++g_device_count;
    return d->fd;
  }
  return real_open(path, flags, mode);
}

int open64(const char* path, int flags, ...) {
  mode_t mode = 0;
  if (flags & (O_CREAT | O_TMPFILE)) {
    va_list ap;
    va_start(ap, flags);
    mode = mode_t(va_arg(ap, int));
    va_end(ap);
  }
  return open(path, flags, mode);
}

int ioctl(int fd, unsigned long request, ...) {
  va_list ap;
  va_start(ap, request);
  void* arg = va_arg(ap, void*);
  va_end(ap);
  if (std::shared_ptr<Device> d = device_of(fd)) return fake_ioctl(d.get(), request, arg);
  static auto real_ioctl = real<int (*)(int, unsigned long, ...)>("ioctl");
  return real_ioctl(fd, request, arg);
}

void* mmap(void* addr, size_t length, int prot, int flags, int fd, off_t offset) {
  if (std::shared_ptr<Device> d = fd < 0 ? nullptr : device_of(fd)) {
    std::lock_guard<std::mutex> g(d->lock);
    const size_t i = size_t(offset) >> 24;
    if (i >= d->buffers.size() || length > d->buffers[i].length) {
      errno = EINVAL;
      return MAP_FAILED;
    }
    return d->buffers[i].data;
  }
  static auto real_mmap = real<void* (*)(void*, size_t, int, int, int, off_t)>("mmap");
  return real_mmap(addr, length, prot, flags, fd, offset);
}

void* mmap64(void* addr, size_t length, int prot, int flags, int fd, off64_t offset) {
  return mmap(addr, length, prot, flags, fd, offset);
}

int munmap(void* addr, size_t length) {
  if (g_device_count > 0) {
    std::lock_guard<std::mutex> g(g_lock);
    for (auto& [fd, d] : g_devices)
      for (const Buffer& b : d->buffers)
        if (b.data == addr) return 0;  // the fake driver's own memory: freed with its buffers
  }
  static auto real_munmap = real<int (*)(void*, size_t)>("munmap");
  return real_munmap(addr, length);
}

int close(int fd) {
  std::shared_ptr<Device> d;
  {
    std::lock_guard<std::mutex> g(g_lock);
    auto it = g_devices.find(fd);
    if (it != g_devices.end()) {
      d = it->second;
      g_devices.erase(it);
      --g_device_count;
    }
  }
  if (d) {
    {
      std::lock_guard<std::mutex> g(d->lock);
      d->stop = true;
    }
    d->wake.notify_all();
    if (d->producer.joinable()) d->producer.join();
    static auto real_munmap = real<int (*)(void*, size_t)>("munmap");
    for (Buffer& b : d->buffers) real_munmap(b.data, b.length);
  }
  static auto real_close = real<int (*)(int)>("close");
  return real_close(fd);
}

}  // extern "C"
