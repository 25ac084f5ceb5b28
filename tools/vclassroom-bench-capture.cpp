// CPU per frame of what rgbdsrc does with a 960x540 RGB-D camera, on one
// core: colour from MJPEG (or YUYV), depth from Z16, and registering depth
// into the colour camera (a depth lens 25 mm beside the colour lens). Frames
// are the synthetic classroom's, coded as a camera would send them, prepared
// before the clock starts; times are this thread's CPU time.
#include <cstdio>
#include <ctime>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/capture/depth_registration.h>
#include <gst/vclassroom/capture/pixel_formats.h>
#include <gst/vclassroom/core/jpeg.h>
#include <gst/vclassroom/synthetic/classroom.h>

#include "cpu_clock.h"
#include "tool_options.h"

using namespace vclassroom;

namespace {

double cpu_ms() { return vclassroom_tools::thread_cpu_ms(); }

}  // namespace

int main(int argc, char** argv) {
  gint frames = 100;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames timed per step (default 100)", "N"}, {}};
  vclassroom_tools::parse_command_line(&argc, &argv, "",
                                       "CPU per frame of rgbdsrc's work at 960x540: MJPEG/YUYV colour, Z16 depth, "
                                       "depth registration.",
                                       entries);
  if (frames < 1) vclassroom_tools::usage_error("--frames must be at least 1");
  cv::setNumThreads(0);
  const CameraCalib cam = default_classroom_rig().camera(0);
  ClassroomConfig cc;
  cc.learners = 6;
  const RenderOutput r = render(Classroom(cc), 2.0, cam);
  cv::Mat depth, color;
  apply_sensor_model(r, cam, SensorParams(), 1, 0, &depth, &color);
  std::vector<uint8_t> jpeg;
  encode_jpeg(color, 90, &jpeg, JpegChroma::kUvc422);  // a UVC camera's MJPEG is 4:2:2
  const std::vector<uint8_t> yuyv = rgb_to_yuyv(color);
  Eigen::Isometry3d depth_to_color = Eigen::Isometry3d::Identity();
  depth_to_color.translation() = Eigen::Vector3d(-0.025, 0, 0);
  DepthRegistration reg(cam, cam, depth_to_color);
  std::string err;
  cv::Mat out;
  auto time = [&](const char* what, auto&& step) {
    step();  // warm-up
    const double t0 = cpu_ms();
    for (int i = 0; i < frames; ++i) step();
    const double ms = (cpu_ms() - t0) / frames;
    std::printf("%-40s %6.2f ms\n", what, ms);
    return ms;
  };
  std::printf("%dx%d, %d frames a step, one thread (CPU time per frame)\n", cam.width, cam.height, frames);
  const double mjpg = time("colour MJPEG -> RGB (libjpeg-turbo)", [&] {
    capture_to_rgb(CapturePixelFormat::kMjpg, jpeg.data(), jpeg.size(), cam.width, cam.height, 0, &out, &err);
  });
  time("colour YUYV -> RGB", [&] {
    capture_to_rgb(CapturePixelFormat::kYuyv, yuyv.data(), yuyv.size(), cam.width, cam.height, 0, &out, &err);
  });
  const double z16 = time("depth Z16 -> mm", [&] {
    capture_to_depth_mm(CapturePixelFormat::kZ16, depth.data, depth.total() * 2, cam.width, cam.height, 0, 1.0, &out,
                        &err);
  });
  const double registration = time("depth registration (25 mm baseline)", [&] { reg.register_depth(depth, &out); });
  std::printf("rgbdsrc per frame, MJPEG colour + Z16 depth + registration: %.2f ms (target 4 ms)\n",
              mjpg + z16 + registration);
  return 0;
}
