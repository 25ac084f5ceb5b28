#include <gst/vclassroom/capture/rgbd_camera.h>

#include <poll.h>

#include <cerrno>
#include <deque>
#include <iterator>

#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

// The colour formats in the order they are tried (the cheapest to convert first).
constexpr CapturePixelFormat kColorFormats[] = {CapturePixelFormat::kYuyv, CapturePixelFormat::kRgb3,
                                                CapturePixelFormat::kMjpg};
constexpr CapturePixelFormat kDepthFormats[] = {CapturePixelFormat::kZ16, CapturePixelFormat::kY16};

// Sets the first of `formats` the device offers at width x height.
void choose_mode(V4l2Device* dev, const CapturePixelFormat* formats, size_t n, int width, int height, int fps_n,
                 int fps_d, const char* whose) {
  const std::vector<CaptureMode> offered = dev->modes();
  for (size_t i = 0; i < n; ++i)
    for (const CaptureMode& m : offered)
      if (m.format == formats[i] && m.width == width && m.height == height) {
        CaptureMode want = m;
        want.fps_n = fps_n;
        want.fps_d = fps_d;
        dev->set_mode(want);
        return;
      }
  std::string wanted;
  for (size_t i = 0; i < n; ++i) wanted += std::string(wanted.empty() ? "" : " or ") + capture_format_name(formats[i]);
  throw CaptureError(CaptureError::Kind::kUnsupported,
                     dev->path() + ": offers no " + wanted + " at " + std::to_string(width) + "x" +
                         std::to_string(height) + " (" + whose + "); it offers " + describe_modes(offered));
}

}  // namespace

CameraCalib nominal_camera(const std::string& color_path, const std::string& depth_path, int id) {
  for (const RgbdCameraNodes& cam : find_rgbd_cameras({color_path, depth_path})) {
    if (cam.color_path != color_path || cam.depth_path != depth_path || cam.sizes.empty()) continue;
    CameraCalib c;
    c.id = id;
    c.width = cam.sizes.front().first;
    c.height = cam.sizes.front().second;
    c.fx = c.fy = 0.8 * c.width;
    c.cx = (c.width - 1) / 2.0;
    c.cy = (c.height - 1) / 2.0;
    return c;
  }
  throw CaptureError(CaptureError::Kind::kUnsupported,
                     color_path + " and " + depth_path +
                         " are not the colour and depth nodes of one camera at a common size (gst-device-monitor-1.0 "
                         "lists the cameras found)");
}

RgbdCamera::RgbdCamera(std::string color_path, std::string depth_path, const CameraCalib& camera, int fps_n, int fps_d,
                       int64_t max_skew_ns)
    : color_path_(std::move(color_path)),
      depth_path_(std::move(depth_path)),
      camera_(camera),
      fps_n_(fps_n),
      fps_d_(fps_d),
      pairer_(max_skew_ns) {
  if (needs_registration(camera_))
    registration_ = std::make_unique<DepthRegistration>(depth_sensor_of(camera_), camera_, *camera_.depth_to_color);
  open();
}

void RgbdCamera::open() {
  try {
    color_ = std::make_unique<V4l2Device>(color_path_);
    depth_ = std::make_unique<V4l2Device>(depth_path_);
    choose_mode(color_.get(), kColorFormats, std::size(kColorFormats), camera_.width, camera_.height, fps_n_, fps_d_,
                "the rig camera's size");
    const CameraCalib lens = depth_sensor_of(camera_);  // the depth node at the depth lens's own size
    choose_mode(depth_.get(), kDepthFormats, std::size(kDepthFormats), lens.width, lens.height, fps_n_, fps_d_,
                registration_ ? "the rig's depth lens size" : "the rig camera's size");
    color_->start();
    depth_->start();
  } catch (const CaptureError&) {
    color_.reset();
    depth_.reset();
    throw;
  }
}

void RgbdCamera::reopen() {
  color_.reset();
  depth_.reset();
  pairer_.clear();
  colors_.clear();
  depths_.clear();
  open();
}

// Takes one frame from `dev` if it has one, converts it, hands its buffer back
// at once and gives it to the pairer. A damaged frame (short, flagged by the
// driver, undecodable) is dropped and said in *losses.
void RgbdCamera::take(V4l2Device* dev, bool is_color, Losses* losses) {
  CapturedFrame f;
  if (!dev->next_frame(0, &f)) return;
  cv::Mat plane;
  std::string err = "the driver flagged it damaged";
  bool ok = false;
  const CaptureMode& mode = dev->mode();
  if (f.bytesused > 0)
    ok = is_color ? capture_to_rgb(mode.format, f.data, f.bytesused, mode.width, mode.height, f.stride, &plane, &err)
                  : capture_to_depth_mm(mode.format, f.data, f.bytesused, mode.width, mode.height, f.stride,
                                        camera_.depth_scale, &plane, &err);
  const int64_t time = f.timestamp_ns;
  dev->release(f);
  if (ok && !is_color && registration_) {
    try {
      cv::Mat registered;
      registration_->register_depth(plane, &registered);
      plane = registered;
    } catch (const Error& e) {
      ok = false;
      err = e.what();
    }
  }
  if (!ok) {
    losses->damaged.push_back(dev->path() + ": " + err);
    return;
  }
  const uint64_t id = next_id_++;
  if (is_color) {
    colors_[id] = plane;
    pairer_.push_color(id, time);
  } else {
    depths_[id] = plane;
    pairer_.push_depth(id, time);
  }
}

bool RgbdCamera::pop(Frame* out, Losses* losses) {
  std::deque<uint64_t> dropped_c, dropped_d;
  std::optional<FramePairer::Pair> pair = pairer_.pop(&dropped_c, &dropped_d);
  for (uint64_t id : dropped_c) colors_.erase(id);
  for (uint64_t id : dropped_d) depths_.erase(id);
  losses->unpaired += dropped_c.size() + dropped_d.size();
  if (!pair) return false;
  out->color = colors_[pair->color_id];
  out->depth = depths_[pair->depth_id];
  out->capture_ns = pair->color_time_ns;
  colors_.erase(pair->color_id);
  depths_.erase(pair->depth_id);
  return true;
}

bool RgbdCamera::next(int timeout_ms, Frame* out, Losses* losses) {
  if (pop(out, losses)) return true;
  pollfd fds[2] = {{color_->fd(), POLLIN, 0}, {depth_->fd(), POLLIN, 0}};
  if (poll(fds, 2, timeout_ms) < 0 && errno != EINTR) throw CaptureError(CaptureError::Kind::kIo, "poll failed");
  if (fds[0].revents) take(color_.get(), true, losses);
  if (fds[1].revents) take(depth_.get(), false, losses);
  return pop(out, losses);
}

}  // namespace vclassroom
