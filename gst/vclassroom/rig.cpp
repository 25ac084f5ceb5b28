#include "rig.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include <opencv2/core.hpp>

namespace vclassroom {

namespace {

std::string camera_where(const std::string& file, int index, const cv::FileNode& node) {
  std::ostringstream os;
  os << file << ": camera " << index;
  if (!node["id"].empty() && node["id"].isInt()) os << " (id " << static_cast<int>(node["id"]) << ")";
  return os.str();
}

[[noreturn]] void fail(const std::string& where, const std::string& field, const std::string& what) {
  throw Error(where + ": field '" + field + "': " + what);
}

double read_number(const cv::FileNode& parent, const std::string& field, const std::string& where,
                   std::optional<double> fallback = std::nullopt) {
  cv::FileNode n = parent[field];
  if (n.empty()) {
    if (fallback) return *fallback;
    fail(where, field, "missing (expected a number)");
  }
  if (!n.isReal() && !n.isInt()) fail(where, field, "expected a number");
  double v = static_cast<double>(n);
  if (!std::isfinite(v)) fail(where, field, "expected a finite number");
  return v;
}

int read_int(const cv::FileNode& parent, const std::string& field, const std::string& where) {
  cv::FileNode n = parent[field];
  if (n.empty()) fail(where, field, "missing (expected an integer)");
  if (!n.isInt()) fail(where, field, "expected an integer");
  return static_cast<int>(n);
}

std::vector<double> read_numbers(const cv::FileNode& parent, const std::string& field,
                                 const std::string& where, size_t count) {
  cv::FileNode n = parent[field];
  std::ostringstream expect;
  expect << "a list of " << count << " numbers";
  if (n.empty()) fail(where, field, "missing (expected " + expect.str() + ")");
  if (!n.isSeq() || n.size() != count) fail(where, field, "expected " + expect.str());
  std::vector<double> out;
  for (const auto& e : n) {
    if (!e.isReal() && !e.isInt()) fail(where, field, "expected " + expect.str());
    double v = static_cast<double>(e);
    if (!std::isfinite(v)) fail(where, field, "expected finite numbers");
    out.push_back(v);
  }
  return out;
}

Eigen::Isometry3d read_transform(const cv::FileNode& parent, const std::string& prefix,
                                 const std::string& where) {
  std::vector<double> r = read_numbers(parent, "rotation", where + (prefix.empty() ? "" : ": " + prefix), 9);
  std::vector<double> t = read_numbers(parent, "translation", where + (prefix.empty() ? "" : ": " + prefix), 3);
  Eigen::Matrix3d rot;
  rot << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  if (!is_rotation(rot, 1e-4)) {
    std::ostringstream os;
    os << "not a proper rotation (expected an orthonormal 3x3 matrix, row-major, with determinant +1; "
       << "|R^T R - I| = " << (rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm()
       << ", det = " << rot.determinant() << ")";
    fail(where + (prefix.empty() ? "" : ": " + prefix), "rotation", os.str());
  }
  // Re-orthonormalise a matrix rounded in the file so the error never
  // accumulates downstream; exact ones are kept bit for bit.
  if (!is_rotation(rot, 1e-12)) rot = Eigen::Quaterniond(rot).normalized().toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rot;
  T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return T;
}

void write_transform(cv::FileStorage& fs, const Eigen::Isometry3d& T) {
  fs << "rotation" << "[:";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) fs << T.linear()(r, c);
  fs << "]";
  fs << "translation" << "[:" << T.translation().x() << T.translation().y() << T.translation().z() << "]";
}

}  // namespace

bool is_rotation(const Eigen::Matrix3d& r, double tol) {
  if (!r.allFinite()) return false;
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < tol && std::abs(r.determinant() - 1.0) < tol;
}

bool CameraCalib::has_distortion() const {
  for (double d : distortion)
    if (d != 0.0) return true;
  return false;
}

Eigen::Matrix3d CameraCalib::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d CameraCalib::normalized(double u, double v) const {
  double x = (u - cx) / fx, y = (v - cy) / fy;
  if (!has_distortion()) return {x, y};
  // Fixed-point inversion of the OpenCV model, as cv::undistortPoints does.
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  const double x0 = x, y0 = y;
  for (int i = 0; i < 20; ++i) {
    double r2 = x * x + y * y;
    double radial = 1 + ((k3 * r2 + k2) * r2 + k1) * r2;
    double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = (x0 - dx) / radial;
    y = (y0 - dy) / radial;
  }
  return {x, y};
}

Eigen::Vector3d CameraCalib::unproject(double u, double v, double z) const {
  Eigen::Vector2d n = normalized(u, v);
  return {n.x() * z, n.y() * z, z};
}

std::optional<Eigen::Vector2d> CameraCalib::project(const Eigen::Vector3d& p) const {
  if (!(p.z() > 0)) return std::nullopt;
  double x = p.x() / p.z(), y = p.y() / p.z();
  if (has_distortion()) {
    const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
                 k3 = distortion[4];
    double r2 = x * x + y * y;
    double radial = 1 + ((k3 * r2 + k2) * r2 + k1) * r2;
    double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = xd;
    y = yd;
  }
  return Eigen::Vector2d(fx * x + cx, fy * y + cy);
}

const CameraCalib* Rig::find(int id) const {
  for (const auto& c : cameras)
    if (c.id == id) return &c;
  return nullptr;
}

const CameraCalib& Rig::camera(int id) const {
  if (const CameraCalib* c = find(id)) return *c;
  std::ostringstream os;
  os << "rig '" << name << "' has no camera with id " << id << " (ids:";
  for (const auto& c : cameras) os << ' ' << c.id;
  os << ")";
  throw Error(os.str());
}

Eigen::Isometry3d Rig::transform(int from, int to) const {
  return camera(to).cam_to_rig.inverse() * camera(from).cam_to_rig;
}

void validate_camera(const CameraCalib& c, const std::string& where) {
  if (c.id < 0) fail(where, "id", "expected an integer >= 0");
  if (c.width <= 0 || c.width > 16384) fail(where, "width", "expected 1..16384 pixels");
  if (c.height <= 0 || c.height > 16384) fail(where, "height", "expected 1..16384 pixels");
  if (!(std::isfinite(c.fx) && c.fx > 0)) fail(where, "fx", "expected a focal length > 0 (pixels)");
  if (!(std::isfinite(c.fy) && c.fy > 0)) fail(where, "fy", "expected a focal length > 0 (pixels)");
  if (!std::isfinite(c.cx)) fail(where, "cx", "expected a finite principal point (pixels)");
  if (!std::isfinite(c.cy)) fail(where, "cy", "expected a finite principal point (pixels)");
  for (double d : c.distortion)
    if (!std::isfinite(d)) fail(where, "distortion", "expected finite coefficients");
  if (!(std::isfinite(c.depth_scale) && c.depth_scale > 0))
    fail(where, "depth_scale", "expected millimetres per depth unit > 0");
  if (!is_rotation(c.cam_to_rig.linear()))
    fail(where, "rotation", "not a proper rotation (orthonormal, determinant +1)");
  if (!c.cam_to_rig.translation().allFinite()) fail(where, "translation", "expected finite numbers");
  if (c.depth_to_color && !is_rotation(c.depth_to_color->linear()))
    fail(where + ": depth_to_color", "rotation", "not a proper rotation (orthonormal, determinant +1)");
}

void validate_rig(const Rig& rig, const std::string& where) {
  if (rig.cameras.empty()) throw Error(where + ": field 'cameras': the rig has no cameras (expected 1 to 8)");
  if (rig.cameras.size() > static_cast<size_t>(Rig::kMaxCameras)) {
    std::ostringstream os;
    os << where << ": field 'cameras': " << rig.cameras.size() << " cameras (expected 1 to " << Rig::kMaxCameras << ")";
    throw Error(os.str());
  }
  std::set<int> ids;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    std::ostringstream cw;
    cw << where << ": camera " << i << " (id " << rig.cameras[i].id << ")";
    validate_camera(rig.cameras[i], cw.str());
    if (!ids.insert(rig.cameras[i].id).second) fail(cw.str(), "id", "duplicate camera id");
  }
}

Rig load_rig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open rig file (missing or unreadable)");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // OpenCV insists on its "%YAML:1.0" directive; hand-written files rarely have it.
  if (text.rfind("%YAML", 0) != 0) text = "%YAML:1.0\n---\n" + text;
  cv::FileStorage fs;
  try {
    if (!fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML))
      throw Error(path + ": not a valid rig YAML file");
  } catch (const cv::Exception& e) {
    throw Error(path + ": not a valid rig YAML file (" + e.err + ")");
  }
  Rig rig;
  cv::FileNode root = fs.root();
  if (!root["name"].empty()) {
    if (!root["name"].isString()) throw Error(path + ": field 'name': expected a string");
    rig.name = static_cast<std::string>(root["name"]);
  }
  cv::FileNode cams = root["cameras"];
  if (cams.empty()) throw Error(path + ": field 'cameras': missing (expected a list of 1 to 8 cameras)");
  if (!cams.isSeq()) throw Error(path + ": field 'cameras': expected a list of cameras");
  int index = 0;
  for (const auto& n : cams) {
    const std::string where = camera_where(path, index, n);
    if (!n.isMap()) throw Error(where + ": expected a mapping of camera fields");
    CameraCalib c;
    c.id = read_int(n, "id", where);
    if (!n["name"].empty() && n["name"].isString()) c.name = static_cast<std::string>(n["name"]);
    c.width = read_int(n, "width", where);
    c.height = read_int(n, "height", where);
    c.fx = read_number(n, "fx", where);
    c.fy = read_number(n, "fy", where);
    c.cx = read_number(n, "cx", where);
    c.cy = read_number(n, "cy", where);
    if (!n["distortion"].empty()) {
      std::vector<double> d = read_numbers(n, "distortion", where, 5);
      std::copy(d.begin(), d.end(), c.distortion.begin());
    }
    c.depth_scale = read_number(n, "depth_scale", where, 1.0);
    c.cam_to_rig = read_transform(n, "", where);
    if (!n["depth_to_color"].empty()) c.depth_to_color = read_transform(n["depth_to_color"], "depth_to_color", where);
    validate_camera(c, where);
    rig.cameras.push_back(c);
    ++index;
  }
  validate_rig(rig, path);
  return rig;
}

void save_rig(const Rig& rig, const std::string& path) {
  validate_rig(rig, path);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML))
      throw Error(path + ": cannot write rig file");
    fs.writeComment("gst-vclassroom rig: pinhole cameras; rotation/translation map camera to rig (metres)");
    fs << "rig_version" << 1;
    fs << "name" << rig.name;
    fs << "cameras" << "[";
    for (const auto& c : rig.cameras) {
      fs << "{";
      fs << "id" << c.id << "name" << c.name << "width" << c.width << "height" << c.height;
      fs << "fx" << c.fx << "fy" << c.fy << "cx" << c.cx << "cy" << c.cy;
      fs << "distortion" << "[:";
      for (double d : c.distortion) fs << d;
      fs << "]";
      fs << "depth_scale" << c.depth_scale;
      write_transform(fs, c.cam_to_rig);
      if (c.depth_to_color) {
        fs << "depth_to_color" << "{";
        write_transform(fs, *c.depth_to_color);
        fs << "}";
      }
      fs << "}";
    }
    fs << "]";
    fs.release();
  } catch (const cv::Exception& e) {
    throw Error(path + ": cannot write rig file: " + e.msg);
  }
}

}  // namespace vclassroom
