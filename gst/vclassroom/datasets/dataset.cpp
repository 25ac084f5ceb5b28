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

namespace {

uint32_t be32(const uint8_t* p) { return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | p[3]; }
uint32_t be16(const uint8_t* p) { return uint32_t{p[0]} << 8 | p[1]; }

bool png_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  // The signature, then the IHDR chunk: length, "IHDR", width, height (big-endian).
  if (size < 24 || std::memcmp(data, kSignature, 8) != 0 || std::memcmp(data + 12, "IHDR", 4) != 0) return false;
  *w = be32(data + 16);
  *h = be32(data + 20);
  return true;
}

// Walks the JPEG's marker segments to its frame header (SOFn). Each step moves
// forward by the segment's length, so the walk ends.
bool jpeg_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8) return false;
  size_t at = 2;
  while (at + 4 <= size) {
    if (data[at] != 0xFF) return false;
    const uint8_t marker = data[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const size_t length = be16(data + at + 2);
    if (length < 2) return false;
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (at + 9 > size) return false;
      *h = be16(data + at + 5);
      *w = be16(data + at + 7);
      return true;
    }
    if (marker == 0xD9 || marker == 0xDA) return false;  // end of image or scan data before any frame header
    at += 2 + length;
  }
  return false;
}

// Netpbm (P1..P6): magic, then width and height as decimal text, with
// whitespace and '#' comments between.
bool pnm_header(const uint8_t* data, size_t size, uint32_t* w, uint32_t* h) {
  if (size < 3 || data[0] != 'P' || data[1] < '1' || data[1] > '6') return false;
  size_t at = 2;
  uint32_t values[2];
  for (uint32_t& v : values) {
    for (;;) {  // whitespace and comments
      if (at >= size) return false;
      if (data[at] == '#') {
        while (at < size && data[at] != '\n') ++at;
      } else if (std::isspace(data[at])) {
        ++at;
      } else {
        break;
      }
    }
    if (!std::isdigit(data[at])) return false;
    uint64_t x = 0;
    while (at < size && std::isdigit(data[at])) {
      x = x * 10 + (data[at++] - '0');
      if (x > 0xFFFFFFFFu) return false;  // no side is that large: refused below as unknown
    }
    v = static_cast<uint32_t>(x);
  }
  *w = values[0];
  *h = values[1];
  return true;
}

}  // namespace

bool image_header_size(const uint8_t* data, size_t size, uint32_t* width, uint32_t* height) {
  if (!data) return false;
  return png_header(data, size, width, height) || jpeg_header(data, size, width, height) ||
         pnm_header(data, size, width, height);
}

cv::Mat decode_image(const uint8_t* data, size_t size, int flags, const std::string& what, const std::string& name,
                     cv::Size expected, const std::string& expected_from) {
  auto wrong_size = [&](cv::Size got) {
    return Error(name + ": " + what + " image is " + std::to_string(got.width) + "x" + std::to_string(got.height) +
                 ", but " + (expected_from.empty() ? std::string("the expected size") : expected_from) + " is " +
                 std::to_string(expected.width) + "x" + std::to_string(expected.height));
  };
  if (!data || size == 0) throw Error(name + ": cannot decode " + what + " image (empty file)");
  if (size > kMaxImageFileBytes)
    throw Error(name + ": " + what + " image file of " + std::to_string(size) + " bytes (expected at most " +
                std::to_string(kMaxImageFileBytes) + ")");
  // The size from the header, checked before OpenCV decodes and allocates:
  // a few bytes may declare 30000x30000. Only the formats datasets use are read.
  uint32_t w = 0, h = 0;
  if (!image_header_size(data, size, &w, &h))
    throw Error(name + ": cannot decode " + what + " image (not a PNG, JPEG or PNM image, or a damaged header)");
  if (w < 1 || h < 1 || w > static_cast<uint32_t>(kMaxImageSide) || h > static_cast<uint32_t>(kMaxImageSide))
    throw Error(name + ": " + what + " image declares " + std::to_string(w) + "x" + std::to_string(h) +
                " (expected sides 1.." + std::to_string(kMaxImageSide) + ")");
  if (!expected.empty() && cv::Size(int(w), int(h)) != expected) throw wrong_size(cv::Size(int(w), int(h)));
  cv::Mat m;
  try {
    // imdecode takes a Mat header over the bytes: no copy.
    m = cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<uint8_t*>(data)), flags);
  } catch (const cv::Exception& e) {
    throw Error(name + ": cannot decode " + what + " image (" + e.msg + ")");
  }
  if (m.empty()) throw Error(name + ": cannot decode " + what + " image (corrupt, truncated or not an image)");
  if (!expected.empty() && m.size() != expected) throw wrong_size(m.size());
  return m;
}

cv::Mat read_image(const std::string& path, int flags, const std::string& what, cv::Size expected,
                   const std::string& expected_from) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path + ": " + what + " image file is missing");
  const uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw Error(path + ": cannot read " + what + " image (" + ec.message() + ")");
  if (bytes > kMaxImageFileBytes)
    throw Error(path + ": " + what + " image file of " + std::to_string(bytes) + " bytes (expected at most " +
                std::to_string(kMaxImageFileBytes) + ")");
  std::vector<uint8_t> data(static_cast<size_t>(bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size())))
    throw Error(path + ": cannot read " + what + " image");
  return decode_image(data.data(), data.size(), flags, what, path, expected, expected_from);
}

cv::Mat read_color_image(const std::string& path, const std::string& what, cv::Size expected,
                         const std::string& expected_from) {
  cv::Mat m = read_image(path, cv::IMREAD_UNCHANGED, what, expected, expected_from);
  if (m.type() != CV_8UC3) {
    static const char* const depths[] = {"8-bit", "8-bit signed", "16-bit", "16-bit signed", "32-bit integer",
                                         "32-bit float", "64-bit float", "16-bit float"};
    const int channels = m.channels();
    const std::string kind = channels == 1 ? "grey" : channels == 2 ? "grey with alpha" : channels == 4 ? "RGBA"
                                                                                                        : "colour";
    throw Error(path + ": " + what + " image is " + depths[m.depth() & 7] + " " + kind + " (" +
                std::to_string(channels) + " channel" + (channels == 1 ? "" : "s") +
                "); expected 8-bit RGB (3 channels)");
  }
  return m;
}

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

cv::Mat read_depth_mm(const std::string& path, double depth_scale, cv::Size expected, const std::string& expected_from) {
  cv::Mat raw = read_image(path, cv::IMREAD_UNCHANGED, "depth", expected, expected_from);
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
