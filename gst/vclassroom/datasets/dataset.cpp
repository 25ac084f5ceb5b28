#include <gst/vclassroom/datasets/dataset.h>

#include <gst/vclassroom/net/rgbd_codec.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
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

std::string stem_of(const std::string& path) { return fs::path(path).stem().string(); }

std::mutex& rig_file_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace


std::vector<std::string> pair_by_name(const std::vector<std::string>& color, const std::vector<std::string>& plane,
                                      const std::string& plane_name) {
  std::vector<std::string> paired;
  if (plane.empty()) return paired;
  if (plane.size() > kMaxFrames || color.size() > kMaxFrames)
    throw Error(plane_name + ": more than " + std::to_string(kMaxFrames) + " frames");
  std::map<std::string, const std::string*> by_name;
  for (const std::string& p : plane) {
    auto [it, fresh] = by_name.emplace(stem_of(p), &p);
    if (!fresh) throw Error(*it->second + " and " + p + ": two " + plane_name + " images of one frame");
  }
  std::set<std::string> color_names;
  for (const std::string& c : color) {
    auto it = by_name.find(stem_of(c));
    if (it == by_name.end()) {
      // Name the first of this plane's files no colour image claims: the likely partner.
      std::string unmatched;
      std::set<std::string> stems;
      for (const std::string& cc : color) stems.insert(stem_of(cc));
      for (const std::string& p : plane)
        if (!stems.count(stem_of(p))) {
          unmatched = p;
          break;
        }
      throw Error(c + " has no " + plane_name + " image of the same name" +
                  (unmatched.empty() ? "" : " (" + unmatched + " matches no colour image)") +
                  ": colour and " + plane_name + " pair by file name");
    }
    if (!color_names.insert(it->first).second) throw Error(c + ": two colour images of frame '" + it->first + "'");
    paired.push_back(*it->second);
  }
  if (paired.size() != plane.size())
    for (const std::string& p : plane)
      if (!color_names.count(stem_of(p)))
        throw Error(p + " matches no colour image (expected " + stem_of(p) + ".png or .jpg in color/)");
  return paired;
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
  bool any_recording = false;
  d.time_origin_ns_ = UINT64_MAX;
  for (const auto& c : d.rig_.cameras) {
    const fs::path dir = dataset_camera_dir(folder, c.id);
    Files f;
    f.id = c.id;
    const fs::path stream = dir / kCodedStreamFile;
    if (fs::exists(stream, ec)) {
      if (fs::is_directory(dir / "color", ec))
        throw Error(dir.string() + ": holds both a live recording (" + kCodedStreamFile +
                    ") and colour images: keep one");
      f.stream = stream.string();
      f.index = index_coded_stream_file(f.stream, kMaxFrames);
      if (f.index.frames.empty())
        throw Error(f.stream + ": no frames" + (f.index.tail_problem.empty() ? "" : " (" + f.index.tail_problem + ")"));
      any_recording = true;
      d.time_origin_ns_ = std::min(d.time_origin_ns_, f.index.frames.front().time_ns);
      d.cameras_.push_back(std::move(f));
      continue;
    }
    f.color = list_images(dir / "color", {".png", ".jpg", ".jpeg", ".ppm"});
    f.depth = list_images(dir / "depth", {".png", ".pgm"});
    f.label = list_images(dir / "label", {".png"});
    f.depth_gt = list_images(dir / "depth-gt", {".png"});
    if (f.color.empty()) throw Error((dir / "color").string() + ": no colour images (expected <frame>.png/jpg)");
    f.depth = pair_by_name(f.color, f.depth, "depth");
    f.label = pair_by_name(f.color, f.label, "label");
    f.depth_gt = pair_by_name(f.color, f.depth_gt, "ground-truth depth");
    d.cameras_.push_back(std::move(f));
  }
  if (!any_recording) d.time_origin_ns_ = 0;
  return d;
}

size_t Dataset::frame_count(int camera_id) const {
  const Files& f = camera(camera_id);
  return f.stream.empty() ? f.color.size() : f.index.frames.size();
}

bool Dataset::has_label(int camera_id) const {
  const Files& f = camera(camera_id);
  return f.stream.empty() ? !f.label.empty() : (f.index.flags & kCodedStreamHasLabel) != 0;
}

uint64_t Dataset::frame_time_ns(int camera_id, size_t index) const {
  const Files& f = camera(camera_id);
  if (f.stream.empty() || index >= f.index.frames.size())
    throw Error(folder_ + ": camera " + std::to_string(camera_id) + " has no recorded time for frame " +
                std::to_string(index));
  return f.index.frames[index].time_ns - time_origin_ns_;
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
  if (index >= frame_count(camera_id))
    throw Error(folder_ + ": camera " + std::to_string(camera_id) + " has " + std::to_string(frame_count(camera_id)) +
                " frames, asked for frame " + std::to_string(index));
  RgbdImages out;
  if (!f.stream.empty()) {
    // The frame is checked whole (sizes against the rig camera, every
    // section's checksum) before anything of it is used.
    const std::vector<uint8_t> bytes = read_coded_frame(f.stream, f.index.frames[index]);
    RgbdCodedFrame frame;
    std::string error;
    if (!decode_rgbd_frame(bytes.data(), bytes.size(), c.width, c.height, &frame, &error))
      throw Error(f.stream + ": frame " + std::to_string(index) + ": " + error);
    out.color = frame.color;
    out.depth = frame.depth;
    out.label = frame.label;
    if (has_label(camera_id) && out.label.empty())
      throw Error(f.stream + ": frame " + std::to_string(index) + " has no label plane, as the recording declares");
    return out;
  }
  // The expected size goes to the reader: a PNG declaring another is refused
  // from its header, before decoding allocates for it.
  const cv::Size expected(c.width, c.height);
  const std::string camera_name = "rig camera " + std::to_string(c.id);
  cv::Mat bgr = read_color_image(f.color[index], "colour", expected, camera_name);
  cv::cvtColor(bgr, out.color, cv::COLOR_BGR2RGB);
  if (!f.depth.empty()) out.depth = read_depth_mm(f.depth[index], c.depth_scale, expected, camera_name);
  else out.depth = cv::Mat::zeros(c.height, c.width, CV_16UC1);
  if (!f.label.empty()) out.label = read_image(f.label[index], cv::IMREAD_GRAYSCALE, "label", expected, camera_name);
  if (!f.depth_gt.empty()) {
    out.depth_gt = read_image(f.depth_gt[index], cv::IMREAD_UNCHANGED, "ground-truth depth", expected, camera_name);
    if (out.depth_gt.type() != CV_16UC1)
      throw Error(f.depth_gt[index] + ": ground-truth depth image must be single-channel 16-bit");
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
