#include <gst/vclassroom/datasets/middlebury.h>

#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include <gst/vclassroom/datasets/dataset.h>

namespace fs = std::filesystem;

namespace vclassroom {

namespace {

// Rig frame of DESIGN.md §2.2: Y up, so a level OpenCV camera (y down, z
// forward) has rotation diag(1, -1, -1); all Middlebury views share it.
CameraCalib rectified_camera(int id, const cv::Size& size, double focal_px, double x_m) {
  CameraCalib c;
  c.id = id;
  c.name = "view" + std::to_string(id);
  c.width = size.width;
  c.height = size.height;
  c.fx = c.fy = focal_px;
  // The views are rectified with a common principal point; its exact place
  // does not change horizontal-only warps, so use the image centre.
  c.cx = (size.width - 1) / 2.0;
  c.cy = (size.height - 1) / 2.0;
  c.cam_to_rig.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  c.cam_to_rig.translation() = Eigen::Vector3d(x_m, 0, 0);
  return c;
}

cv::Mat read_checked(const fs::path& p, int flags) { return read_image(p.string(), flags, "Middlebury"); }

cv::Mat disparity_to_depth(const cv::Mat& disp8, double scale_to_px, double focal_px, double baseline_m,
                           ImportSummary* sum) {
  cv::Mat depth(disp8.size(), CV_16UC1);
  for (int y = 0; y < disp8.rows; ++y)
    for (int x = 0; x < disp8.cols; ++x) {
      const int v = disp8.at<uchar>(y, x);
      unsigned short z = v ? disparity_to_depth_mm(v * scale_to_px, focal_px, baseline_m) : 0;
      if (!v) ++sum->unknown_pixels;
      else if (!z) ++sum->out_of_range;
      else ++sum->depth_pixels;
      depth.at<unsigned short>(y, x) = z;
    }
  return depth;
}

void copy_color(const fs::path& src, const std::string& out, int id) {
  const fs::path dst = fs::path(dataset_camera_dir(out, id)) / "color" / ("000000" + src.extension().string());
  std::error_code ec;
  fs::create_directories(dst.parent_path(), ec);
  fs::copy_file(src, dst, fs::copy_options::overwrite_existing, ec);
  if (ec) throw Error(dst.string() + ": cannot copy colour image (" + ec.message() + ")");
}

void write_depth(const cv::Mat& depth, const std::string& out, int id) {
  const fs::path dir = fs::path(dataset_camera_dir(out, id)) / "depth";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!cv::imwrite((dir / "000000.png").string(), depth)) throw Error((dir / "000000.png").string() + ": cannot write");
}

}  // namespace

unsigned short disparity_to_depth_mm(double d, double focal_px, double baseline_m) {
  if (!(d > 0)) return 0;
  const double mm = focal_px * baseline_m * 1000.0 / d;
  if (mm > 65535.0) return 0;
  return static_cast<unsigned short>(std::lround(mm));
}

ImportSummary import_middlebury_multiview(const std::string& scene_dir, const std::string& out, bool noholes,
                                          const MiddleburyMultiviewGeometry& g) {
  const fs::path dir(scene_dir);
  ImportSummary sum;
  sum.rig.name = "middlebury-" + dir.filename().string();
  cv::Mat disp = read_checked(dir / (noholes ? "disp1_noholes.png" : "disp1.png"), cv::IMREAD_GRAYSCALE);
  std::error_code ec;
  fs::create_directories(out, ec);
  for (int k = 0; k <= 6; ++k) {
    const fs::path view = dir / ("view" + std::to_string(k) + ".png");
    if (!fs::exists(view, ec)) continue;
    cv::Mat im = read_checked(view, cv::IMREAD_COLOR);
    if (im.size() != disp.size())
      throw Error(view.string() + ": view is " + std::to_string(im.cols) + "x" + std::to_string(im.rows) +
                  " but the disparity map is " + std::to_string(disp.cols) + "x" + std::to_string(disp.rows));
    sum.rig.cameras.push_back(rectified_camera(k, im.size(), g.focal_px, g.view_spacing_m * (k - 1)));
    copy_color(view, out, k);
  }
  if (!sum.rig.find(1)) throw Error((dir / "view1.png").string() + ": file is missing (view 1 carries the depth)");
  // disp1 is the shift from view 1 to view 5, four view steps apart.
  write_depth(disparity_to_depth(disp, 1.0, g.focal_px, 4 * g.view_spacing_m, &sum), out, 1);
  save_rig(sum.rig, (fs::path(out) / "rig.yaml").string());
  return sum;
}

ImportSummary import_middlebury_2003(const std::string& scene_dir, const std::string& out) {
  const fs::path dir(scene_dir);
  const double focal_px = 3740.0 / 4;  // quarter size
  const double step_m = 0.040;
  ImportSummary sum;
  sum.rig.name = "middlebury2003-" + dir.filename().string();
  std::error_code ec;
  fs::create_directories(out, ec);
  for (int k : {2, 6}) {
    const fs::path view = dir / ("im" + std::to_string(k) + ".png");
    cv::Mat im = read_checked(view, cv::IMREAD_COLOR);
    cv::Mat disp = read_checked(dir / ("disp" + std::to_string(k) + ".pgm"), cv::IMREAD_GRAYSCALE);
    if (im.size() != disp.size()) throw Error(view.string() + ": size differs from its disparity map");
    sum.rig.cameras.push_back(rectified_camera(k, im.size(), focal_px, step_m * (k - 2)));
    copy_color(view, out, k);
    // Stored x4; the disparity spans views 2..6, four steps.
    write_depth(disparity_to_depth(disp, 0.25, focal_px, 4 * step_m, &sum), out, k);
  }
  save_rig(sum.rig, (fs::path(out) / "rig.yaml").string());
  return sum;
}

}  // namespace vclassroom
