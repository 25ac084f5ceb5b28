#include <gst/vclassroom/datasets/posed_sequence.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/datasets/dataset.h>

namespace fs = std::filesystem;

namespace vclassroom {

namespace {

constexpr size_t kMaxListBytes = size_t(1) << 20;
constexpr int kMaxSequenceFrames = 1000;

std::string read_text(const fs::path& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw Error(path.string() + ": cannot read it (" + ec.message() + ")");
  if (size > kMaxListBytes) throw Error(path.string() + ": larger than 1 MiB");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The lines of a text that hold more than blanks.
std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.find_first_not_of(" \t\r") != std::string::npos) lines.push_back(line);
  return lines;
}

}  // namespace

std::vector<Eigen::Isometry3d> parse_trajectory_log(const std::string& text, const std::string& name) {
  if (text.size() > kMaxListBytes) throw Error(name + ": larger than 1 MiB");
  const std::vector<std::string> lines = lines_of(text);
  if (lines.size() % 5 != 0) throw Error(name + ": expected 5 lines per frame (\"i j n\" and a 4x4 matrix)");
  std::vector<Eigen::Isometry3d> poses;
  for (size_t f = 0; f < lines.size() / 5; ++f) {
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      std::istringstream row(lines[5 * f + 1 + r]);
      for (int c = 0; c < 4; ++c)
        if (!(row >> m(r, c)) || !std::isfinite(m(r, c)))
          throw Error(name + ":" + std::to_string(5 * f + 2 + r) + ": expected 4 numbers");
    }
    const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
    if (!((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() <= 1e-3) || !(R.determinant() >= 0.99))
      throw Error(name + ": frame " + std::to_string(f) + "'s matrix is not a rotation and a translation");
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
    pose.translation() = m.topRightCorner<3, 1>();
    poses.push_back(pose);
  }
  return poses;
}

ImportSummary import_posed_sequence(const std::string& scene_dir, const std::string& out,
                                    const PosedSequenceIntrinsics& k) {
  const fs::path dir(scene_dir);
  const std::vector<std::string> pairs = lines_of(read_text(dir / "rgbd.match"));
  const std::vector<Eigen::Isometry3d> poses =
      parse_trajectory_log(read_text(dir / "trajectory.log"), (dir / "trajectory.log").string());
  if (pairs.empty()) throw Error((dir / "rgbd.match").string() + ": no frames");
  if (pairs.size() > size_t(kMaxSequenceFrames)) throw Error((dir / "rgbd.match").string() + ": more than 1000 frames");
  if (poses.size() < pairs.size())
    throw Error((dir / "trajectory.log").string() + ": " + std::to_string(poses.size()) + " poses for " +
                std::to_string(pairs.size()) + " frames");
  ImportSummary sum;
  sum.rig.name = "sequence-" + dir.filename().string();
  for (size_t f = 0; f < pairs.size(); ++f) {
    std::istringstream line(pairs[f]);
    std::string depth_file, color_file;
    if (!(line >> depth_file >> color_file))
      throw Error((dir / "rgbd.match").string() + ":" + std::to_string(f + 1) + ": expected a depth and a colour file");
    RgbdImages images;
    cv::cvtColor(read_color_image((dir / color_file).string(), "colour"), images.color,
                 cv::COLOR_BGR2RGB);
    images.depth = read_depth_mm((dir / depth_file).string(), k.depth_mm_per_unit, images.color.size(),
                                 "its colour image");
    CameraCalib cam;
    cam.id = int(f);
    cam.name = "frame" + std::to_string(f);
    cam.width = images.color.cols;
    cam.height = images.color.rows;
    cam.fx = k.fx;
    cam.fy = k.fy;
    cam.cx = k.cx;
    cam.cy = k.cy;
    cam.cam_to_rig = poses[f];
    const int known = cv::countNonZero(images.depth);
    sum.depth_pixels += known;
    sum.unknown_pixels += int(images.depth.total()) - known;
    dataset_write_frame(out, cam.id, 0, images);
    sum.rig.cameras.push_back(cam);
  }
  save_rig(sum.rig, (fs::path(out) / "rig.yaml").string());
  return sum;
}

}  // namespace vclassroom
