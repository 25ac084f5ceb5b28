#include "dataset.h"

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace fs = std::filesystem;

namespace vclassroom {

namespace {

std::vector<std::string> list_images(const fs::path& dir, std::initializer_list<const char*> exts) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    for (const char* x : exts)
      if (ext == x) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string size_str(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }

void check_size(const cv::Mat& m, const CameraCalib& c, const std::string& file, const char* what) {
  if (m.cols != c.width || m.rows != c.height)
    throw Error(file + ": " + what + " image is " + size_str(m) + ", but rig camera " + std::to_string(c.id) +
                " is " + std::to_string(c.width) + "x" + std::to_string(c.height));
}

cv::Mat read_image(const std::string& path, int flags, const char* what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path + ": " + what + " image file is missing");
  cv::Mat m;
  try {
    m = cv::imread(path, flags);
  } catch (const cv::Exception& e) {
    throw Error(path + ": cannot decode " + what + " image (" + e.msg + ")");
  }
  if (m.empty()) throw Error(path + ": cannot decode " + what + " image (corrupt, truncated or not an image)");
  return m;
}

std::mutex& rig_file_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

cv::Mat read_depth_mm(const std::string& path, double depth_scale) {
  cv::Mat raw = read_image(path, cv::IMREAD_UNCHANGED, "depth");
  if (raw.type() != CV_16UC1)
    throw Error(path + ": depth image must be single-channel 16-bit (got " + std::to_string(raw.channels()) +
                " channel(s) of " + std::to_string(8 * raw.elemSize1()) + " bit)");
  if (depth_scale == 1.0) return raw;
  cv::Mat mm;
  raw.convertTo(mm, CV_16U, depth_scale);  // rounds and saturates at 65535
  return mm;
}

std::string dataset_camera_dir(const std::string& folder, int camera_id) {
  return (fs::path(folder) / ("cam" + std::to_string(camera_id))).string();
}

Dataset Dataset::open(const std::string& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw Error(folder + ": dataset folder is missing");
  Dataset d;
  d.folder_ = folder;
  d.rig_ = load_rig((fs::path(folder) / "rig.yaml").string());
  for (const auto& c : d.rig_.cameras) {
    const fs::path dir = dataset_camera_dir(folder, c.id);
    Files f;
    f.id = c.id;
    f.color = list_images(dir / "color", {".png", ".jpg", ".jpeg", ".ppm"});
    f.depth = list_images(dir / "depth", {".png", ".pgm"});
    f.label = list_images(dir / "label", {".png"});
    f.depth_gt = list_images(dir / "depth-gt", {".png"});
    auto check_count = [&](const std::vector<std::string>& v, const char* what) {
      if (!v.empty() && v.size() != f.color.size())
        throw Error((dir / what).string() + ": " + std::to_string(v.size()) + " images, but color/ has " +
                    std::to_string(f.color.size()) + " (expected one per colour frame)");
    };
    if (f.color.empty()) throw Error((dir / "color").string() + ": no colour images (expected <frame>.png/jpg)");
    check_count(f.depth, "depth");
    check_count(f.label, "label");
    check_count(f.depth_gt, "depth-gt");
    d.cameras_.push_back(std::move(f));
  }
  return d;
}

const Dataset::Files& Dataset::camera(int id) const {
  for (const auto& f : cameras_)
    if (f.id == id) return f;
  rig_.camera(id);  // throws the rig's "no camera with id" message
  throw Error("dataset: no camera " + std::to_string(id));
}

RgbdImages Dataset::load(int camera_id, size_t index) const {
  const Files& f = camera(camera_id);
  const CameraCalib& c = rig_.camera(camera_id);
  if (index >= f.color.size())
    throw Error(folder_ + ": camera " + std::to_string(camera_id) + " has " + std::to_string(f.color.size()) +
                " frames, asked for frame " + std::to_string(index));
  RgbdImages out;
  cv::Mat bgr = read_image(f.color[index], cv::IMREAD_COLOR, "colour");
  check_size(bgr, c, f.color[index], "colour");
  cv::cvtColor(bgr, out.color, cv::COLOR_BGR2RGB);
  if (!f.depth.empty()) {
    out.depth = read_depth_mm(f.depth[index], c.depth_scale);
    check_size(out.depth, c, f.depth[index], "depth");
  } else {
    out.depth = cv::Mat::zeros(c.height, c.width, CV_16UC1);
  }
  if (!f.label.empty()) {
    out.label = read_image(f.label[index], cv::IMREAD_GRAYSCALE, "label");
    check_size(out.label, c, f.label[index], "label");
  }
  if (!f.depth_gt.empty()) {
    out.depth_gt = read_depth_mm(f.depth_gt[index], 1.0);
    check_size(out.depth_gt, c, f.depth_gt[index], "ground-truth depth");
  }
  return out;
}

void dataset_write_frame(const std::string& folder, int camera_id, size_t index, const RgbdImages& im) {
  char name[32];
  std::snprintf(name, sizeof name, "%06zu.png", index);
  const fs::path dir = dataset_camera_dir(folder, camera_id);
  auto write = [&](const char* sub, const cv::Mat& m) {
    if (m.empty()) return;
    std::error_code ec;
    fs::create_directories(dir / sub, ec);
    const std::string path = (dir / sub / name).string();
    bool ok = false;
    try {
      ok = cv::imwrite(path, m);
    } catch (const cv::Exception& e) {
      throw Error(path + ": cannot write image (" + e.msg + ")");
    }
    if (!ok) throw Error(path + ": cannot write image");
  };
  cv::Mat bgr;
  cv::cvtColor(im.color, bgr, cv::COLOR_RGB2BGR);
  write("color", bgr);
  write("depth", im.depth);
  write("label", im.label);
  write("depth-gt", im.depth_gt);
}

void dataset_write_camera(const std::string& folder, const CameraCalib& camera, const std::string& rig_name) {
  std::lock_guard<std::mutex> lock(rig_file_mutex());
  std::error_code ec;
  fs::create_directories(folder, ec);
  const std::string path = (fs::path(folder) / "rig.yaml").string();
  Rig rig;
  rig.name = rig_name;
  if (fs::exists(path, ec)) rig = load_rig(path);
  CameraCalib c = camera;
  c.depth_scale = 1.0;
  auto it = std::find_if(rig.cameras.begin(), rig.cameras.end(), [&](const CameraCalib& x) { return x.id == c.id; });
  if (it != rig.cameras.end()) *it = c;
  else rig.cameras.push_back(c);
  std::sort(rig.cameras.begin(), rig.cameras.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  // Write then rename, so a reader never sees half a rig file.
  const std::string tmp = path + ".tmp";
  save_rig(rig, tmp);
  fs::rename(tmp, path, ec);
  if (ec) throw Error(path + ": cannot write rig file (" + ec.message() + ")");
}

}  // namespace vclassroom
