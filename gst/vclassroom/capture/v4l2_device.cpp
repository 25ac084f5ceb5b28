#include <gst/vclassroom/capture/v4l2_device.h>

#include <gst/vclassroom/core/limits.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

namespace vclassroom {

namespace {

struct FourccFormat {
  uint32_t fourcc;
  CapturePixelFormat format;
};
constexpr FourccFormat kFormats[] = {
    {V4L2_PIX_FMT_YUYV, CapturePixelFormat::kYuyv}, {V4L2_PIX_FMT_RGB24, CapturePixelFormat::kRgb3},
    {V4L2_PIX_FMT_MJPEG, CapturePixelFormat::kMjpg}, {V4L2_PIX_FMT_Z16, CapturePixelFormat::kZ16},
    {V4L2_PIX_FMT_Y16, CapturePixelFormat::kY16},
};

bool format_of(uint32_t fourcc, CapturePixelFormat* f) {
  for (const FourccFormat& k : kFormats)
    if (k.fourcc == fourcc) {
      *f = k.format;
      return true;
    }
  return false;
}

uint32_t fourcc_of(CapturePixelFormat f) {
  for (const FourccFormat& k : kFormats)
    if (k.format == f) return k.fourcc;
  return 0;
}

// ioctl, again while a signal interrupts it.
int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do r = ioctl(fd, request, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

}  // namespace

std::string describe_modes(const std::vector<CaptureMode>& modes) {
  std::string s;
  for (const CaptureMode& m : modes) {
    if (!s.empty()) s += ", ";
    s += std::string(capture_format_name(m.format)) + " " + std::to_string(m.width) + "x" + std::to_string(m.height);
    if (m.fps_n) s += "@" + std::to_string(m.fps_n) + (m.fps_d == 1 ? "" : "/" + std::to_string(m.fps_d));
  }
  return s.empty() ? "nothing rgbdsrc can use" : s;
}

void V4l2Device::fail(const std::string& what, int err) {
  const std::string text = path_ + ": " + what + " (" + std::strerror(err) + ")";
  if (err == ENODEV || err == ENXIO) throw CaptureError(CaptureError::Kind::kVanished, text + ": the device went away");
  if (err == EBUSY) throw CaptureError(CaptureError::Kind::kBusy, text + ": another program is using it");
  throw CaptureError(CaptureError::Kind::kIo, text);
}

V4l2Device::V4l2Device(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int err = errno;
    if (err == ENOENT || err == ENODEV || err == ENXIO)
      throw CaptureError(CaptureError::Kind::kNoDevice, path + ": no such device (is the camera plugged in?)");
    if (err == EBUSY) throw CaptureError(CaptureError::Kind::kBusy, path + ": device busy (another program is using it)");
    throw CaptureError(CaptureError::Kind::kNoDevice, path + ": cannot open (" + std::strerror(err) + ")");
  }
  v4l2_capability cap{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw CaptureError(CaptureError::Kind::kNotCapture, path + ": not a V4L2 device (" + std::strerror(err) + ")");
  }
  // Fixed-size, NUL-padded fields from the driver: read no further than their size.
  card_.assign(reinterpret_cast<const char*>(cap.card), strnlen(reinterpret_cast<const char*>(cap.card), sizeof cap.card));
  bus_.assign(reinterpret_cast<const char*>(cap.bus_info),
              strnlen(reinterpret_cast<const char*>(cap.bus_info), sizeof cap.bus_info));
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
    ::close(fd_);
    fd_ = -1;
    throw CaptureError(CaptureError::Kind::kNotCapture,
                       path + ": not a video capture device with streaming (a metadata or output node?)");
  }
}

V4l2Device::~V4l2Device() {
  try {
    stop();
  } catch (const Error&) {
  }
  if (fd_ >= 0) ::close(fd_);
}

std::vector<CaptureMode> V4l2Device::modes() {
  std::vector<CaptureMode> out;
  // Bounded loops: a driver (or anything pretending to be one) cannot make them run for ever.
  for (uint32_t i = 0; i < 64; ++i) {
    v4l2_fmtdesc fd{};
    fd.index = i;
    fd.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &fd) != 0) break;
    CapturePixelFormat f;
    if (!format_of(fd.pixelformat, &f)) continue;
    for (uint32_t j = 0; j < 64; ++j) {
      v4l2_frmsizeenum fs{};
      fs.index = j;
      fs.pixel_format = fd.pixelformat;
      if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &fs) != 0 || fs.type != V4L2_FRMSIZE_TYPE_DISCRETE) break;
      CaptureMode m{f, int(fs.discrete.width), int(fs.discrete.height), 0, 1};
      bool any_rate = false;
      for (uint32_t k = 0; k < 32; ++k) {
        v4l2_frmivalenum fi{};
        fi.index = k;
        fi.pixel_format = fd.pixelformat;
        fi.width = fs.discrete.width;
        fi.height = fs.discrete.height;
        if (xioctl(fd_, VIDIOC_ENUM_FRAMEINTERVALS, &fi) != 0 || fi.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;
        if (fi.discrete.numerator == 0 || fi.discrete.denominator == 0) continue;
        CaptureMode r = m;
        r.fps_n = int(fi.discrete.denominator);  // an interval of n/d s is d/n frames a second
        r.fps_d = int(fi.discrete.numerator);
        out.push_back(r);
        any_rate = true;
      }
      if (!any_rate) out.push_back(m);
    }
  }
  return out;
}

void V4l2Device::set_mode(const CaptureMode& mode) {
  if (mode.width < 1 || mode.height < 1 || mode.width > kMaxImageSide || mode.height > kMaxImageSide)
    throw CaptureError(CaptureError::Kind::kUnsupported, path_ + ": frame size out of range");
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = uint32_t(mode.width);
  fmt.fmt.pix.height = uint32_t(mode.height);
  fmt.fmt.pix.pixelformat = fourcc_of(mode.format);
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) != 0) {
    if (errno == EBUSY) fail("cannot set the format", errno);
    throw CaptureError(CaptureError::Kind::kUnsupported, path_ + ": cannot set " + capture_format_name(mode.format) +
                                                            " " + std::to_string(mode.width) + "x" +
                                                            std::to_string(mode.height) + "; the device offers " +
                                                            describe_modes(modes()));
  }
  // A driver answers S_FMT with the nearest it has: anything else is refused.
  if (fmt.fmt.pix.pixelformat != fourcc_of(mode.format) || int(fmt.fmt.pix.width) != mode.width ||
      int(fmt.fmt.pix.height) != mode.height)
    throw CaptureError(CaptureError::Kind::kUnsupported,
                       path_ + ": does not offer " + capture_format_name(mode.format) + " " +
                           std::to_string(mode.width) + "x" + std::to_string(mode.height) + "; it offers " +
                           describe_modes(modes()));
  const size_t pixel_bytes = mode.format == CapturePixelFormat::kRgb3 ? 3 : 2;
  stride_ = mode.format == CapturePixelFormat::kMjpg ? 0 : std::max<size_t>(fmt.fmt.pix.bytesperline, size_t(mode.width) * pixel_bytes);
  if (mode.fps_n > 0) {
    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe.numerator = uint32_t(mode.fps_d);
    parm.parm.capture.timeperframe.denominator = uint32_t(mode.fps_n);
    xioctl(fd_, VIDIOC_S_PARM, &parm);  // a driver without rate control keeps its own: not an error
  }
  mode_ = mode;
}

void V4l2Device::start(unsigned count) {
  if (streaming_) return;
  v4l2_requestbuffers req{};
  req.count = count;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) != 0) fail("cannot get capture buffers", errno);
  if (req.count < 2 || req.count > 32)
    throw CaptureError(CaptureError::Kind::kIo, path_ + ": the driver gave " + std::to_string(req.count) +
                                                    " buffers (expected 2 to 32)");
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &b) != 0) fail("cannot query buffer " + std::to_string(i), errno);
    if (b.length == 0 || b.length > (1u << 28))
      throw CaptureError(CaptureError::Kind::kIo, path_ + ": buffer of " + std::to_string(b.length) + " bytes");
    void* p = mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
    if (p == MAP_FAILED) fail("cannot map buffer " + std::to_string(i), errno);
    buffers_.push_back({p, b.length});
    if (xioctl(fd_, VIDIOC_QBUF, &b) != 0) fail("cannot queue buffer " + std::to_string(i), errno);
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) != 0) fail("cannot start streaming", errno);
  streaming_ = true;
}

bool V4l2Device::next_frame(int timeout_ms, CapturedFrame* frame) {
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, timeout_ms);
  if (r < 0) {
    if (errno == EINTR) return false;
    fail("waiting for a frame", errno);
  }
  if (r == 0) return false;
  if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) fail("waiting for a frame", ENODEV);
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_DQBUF, &b) != 0) {
    if (errno == EAGAIN) return false;
    fail("cannot take a frame", errno);
  }
  if (b.index >= buffers_.size())
    throw CaptureError(CaptureError::Kind::kIo, path_ + ": the driver returned buffer " + std::to_string(b.index) +
                                                    " of " + std::to_string(buffers_.size()));
  frame->index = b.index;
  frame->data = static_cast<const uint8_t*>(buffers_[b.index].start);
  frame->bytesused = std::min<size_t>(b.bytesused, buffers_[b.index].length);
  frame->stride = stride_;
  frame->timestamp_ns = int64_t(b.timestamp.tv_sec) * 1000000000 + int64_t(b.timestamp.tv_usec) * 1000;
  frame->sequence = b.sequence;
  // A frame the driver marks as damaged is dropped by the caller like a short one.
  if (b.flags & V4L2_BUF_FLAG_ERROR) frame->bytesused = 0;
  return true;
}

void V4l2Device::release(const CapturedFrame& frame) {
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = frame.index;
  if (xioctl(fd_, VIDIOC_QBUF, &b) != 0) fail("cannot give a buffer back", errno);
}

void V4l2Device::stop() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(fd_, VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (const Mapping& m : buffers_) munmap(m.start, m.length);
  buffers_.clear();
  if (fd_ >= 0) {
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    xioctl(fd_, VIDIOC_REQBUFS, &req);
  }
}

std::vector<RgbdCameraNodes> find_rgbd_cameras(const std::vector<std::string>& paths) {
  struct Node {
    std::string path, card, bus;
    std::vector<CaptureMode> modes;
  };
  std::vector<Node> depth_nodes, color_nodes;
  for (const std::string& path : paths) {
    try {
      V4l2Device dev(path);
      Node n{path, dev.card(), dev.bus(), dev.modes()};
      bool depth = false, color = false;
      for (const CaptureMode& m : n.modes) (capture_format_is_depth(m.format) ? depth : color) = true;
      if (depth) depth_nodes.push_back(n);
      else if (color) color_nodes.push_back(n);
    } catch (const Error&) {
    }
  }
  std::vector<RgbdCameraNodes> cameras;
  for (const Node& d : depth_nodes)
    for (const Node& c : color_nodes) {
      if (c.bus != d.bus) continue;
      RgbdCameraNodes cam{d.card.empty() ? c.card : d.card, d.bus, c.path, d.path, {}};
      for (const CaptureMode& cm : c.modes)
        for (const CaptureMode& dm : d.modes) {
          const std::pair<int, int> size{cm.width, cm.height};
          if (cm.width == dm.width && cm.height == dm.height &&
              std::find(cam.sizes.begin(), cam.sizes.end(), size) == cam.sizes.end())
            cam.sizes.push_back(size);
        }
      if (!cam.sizes.empty()) cameras.push_back(cam);
      break;  // one colour node per depth node
    }
  return cameras;
}

}  // namespace vclassroom
