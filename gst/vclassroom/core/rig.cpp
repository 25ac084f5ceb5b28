#include <gst/vclassroom/core/rig.h>

#include <gst/vclassroom/core/limits.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <yaml.h>

namespace vclassroom {

namespace {

// ---- A small, bounded YAML tree built from libyaml's events.
// libyaml is fuzzed upstream and parses without recursion; the tree is flat
// (children by index), so neither building nor freeing it recurses either.
// Rig files are a few kilobytes: anything far beyond is refused, not parsed.
constexpr size_t kMaxRigFileBytes = 1 << 20;
constexpr size_t kMaxRigNodes = 65536;
constexpr size_t kMaxRigDepth = 32;

struct YamlNode {
  enum Kind { kScalar, kSequence, kMapping } kind = kScalar;
  int line = 0;             // 1-based
  std::string text;         // scalars
  bool plain = true;        // an unquoted scalar (numbers are only read from these)
  std::vector<size_t> items;                            // sequences
  std::vector<std::pair<std::string, size_t>> entries;  // mappings: key, value node
  std::vector<int> key_lines;
};

struct YamlTree {
  std::vector<YamlNode> nodes;  // nodes[0] is the document's root
};

struct Where {
  std::string file;
  std::string context;  // "camera 1 (id 1)", "camera 1 (id 1): depth_to_color" or ""
  std::string at(int line) const {
    std::string s = file;
    if (line > 0) s += ":" + std::to_string(line);
    if (!context.empty()) s += ": " + context;
    return s;
  }
};

[[noreturn]] void fail_at(const Where& w, int line, const std::string& field, const std::string& what) {
  throw Error(w.at(line) + ": field '" + field + "': " + what);
}

// The parser's own message, made a person's: file:line:column and what it found.
[[noreturn]] void syntax_error(const std::string& file, const yaml_parser_t& p) {
  std::ostringstream os;
  os << file << ":" << p.problem_mark.line + 1 << ":" << p.problem_mark.column + 1
     << ": not a valid rig YAML file (" << (p.problem ? p.problem : "syntax error");
  if (p.context) os << " " << p.context;
  os << ")";
  throw Error(os.str());
}

YamlTree parse_yaml(const std::string& text, const std::string& file) {
  struct Parser {
    yaml_parser_t p;
    Parser() { yaml_parser_initialize(&p); }
    ~Parser() { yaml_parser_delete(&p); }
  } parser;
  struct Event {
    yaml_event_t e;
    bool live = false;
    ~Event() {
      if (live) yaml_event_delete(&e);
    }
  };
  yaml_parser_set_input_string(&parser.p, reinterpret_cast<const unsigned char*>(text.data()), text.size());
  YamlTree tree;
  std::vector<size_t> open;   // the collections being filled, innermost last
  std::string pending_key;    // a mapping's key waiting for its value
  int pending_key_line = 0;
  bool have_key = false, documents = false, done = false;
  auto fail = [&](int line, const std::string& what) -> void {
    throw Error(file + ":" + std::to_string(line) + ": not a valid rig YAML file (" + what + ")");
  };
  while (!done) {
    Event ev;
    if (!yaml_parser_parse(&parser.p, &ev.e)) syntax_error(file, parser.p);
    ev.live = true;
    const int line = static_cast<int>(ev.e.start_mark.line) + 1;
    const yaml_event_type_t type = ev.e.type;
    if (type == YAML_STREAM_END_EVENT) break;
    if (type == YAML_STREAM_START_EVENT || type == YAML_DOCUMENT_END_EVENT) continue;
    if (type == YAML_DOCUMENT_START_EVENT) {
      if (documents) fail(line, "more than one document");
      documents = true;
      continue;
    }
    if (type == YAML_ALIAS_EVENT) fail(line, "aliases (*name) are not supported in rig files");
    const unsigned char* anchor = type == YAML_SCALAR_EVENT           ? ev.e.data.scalar.anchor
                                  : type == YAML_SEQUENCE_START_EVENT ? ev.e.data.sequence_start.anchor
                                  : type == YAML_MAPPING_START_EVENT  ? ev.e.data.mapping_start.anchor
                                                                      : nullptr;
    if (anchor) fail(line, "anchors (&name) are not supported in rig files");
    if (type == YAML_SEQUENCE_END_EVENT || type == YAML_MAPPING_END_EVENT) {
      open.pop_back();  // libyaml pairs start and end events
      continue;
    }
    // A scalar or the start of a collection: a new node, or a mapping's key.
    YamlNode* parent = open.empty() ? nullptr : &tree.nodes[open.back()];
    if (parent && parent->kind == YamlNode::kMapping && !have_key) {
      if (type != YAML_SCALAR_EVENT) fail(line, "a mapping key must be a plain name");
      pending_key.assign(reinterpret_cast<const char*>(ev.e.data.scalar.value), ev.e.data.scalar.length);
      pending_key_line = line;
      for (const auto& e : parent->entries)
        if (e.first == pending_key) fail(line, "key '" + pending_key + "' appears twice");
      have_key = true;
      continue;
    }
    if (tree.nodes.size() >= kMaxRigNodes) fail(line, "more than " + std::to_string(kMaxRigNodes) + " values");
    if (!parent && !tree.nodes.empty()) fail(line, "more than one document");
    YamlNode node;
    node.line = line;
    if (type == YAML_SCALAR_EVENT) {
      node.text.assign(reinterpret_cast<const char*>(ev.e.data.scalar.value), ev.e.data.scalar.length);
      node.plain = ev.e.data.scalar.style == YAML_PLAIN_SCALAR_STYLE;
    } else {
      node.kind = type == YAML_SEQUENCE_START_EVENT ? YamlNode::kSequence : YamlNode::kMapping;
    }
    const size_t index = tree.nodes.size();
    tree.nodes.push_back(std::move(node));
    if (parent) {
      parent = &tree.nodes[open.back()];  // push_back may have moved it
      if (parent->kind == YamlNode::kSequence) {
        parent->items.push_back(index);
      } else {
        parent->entries.emplace_back(std::move(pending_key), index);
        parent->key_lines.push_back(pending_key_line);
        pending_key.clear();
        have_key = false;
      }
    }
    if (type != YAML_SCALAR_EVENT) {
      if (open.size() >= kMaxRigDepth) fail(line, "nested deeper than " + std::to_string(kMaxRigDepth) + " levels");
      open.push_back(index);
    }
  }
  return tree;
}

const YamlNode* child(const YamlTree& t, const YamlNode& map, const std::string& key, int* key_line = nullptr) {
  if (map.kind != YamlNode::kMapping) return nullptr;
  for (size_t i = 0; i < map.entries.size(); ++i)
    if (map.entries[i].first == key) {
      if (key_line) *key_line = map.key_lines[i];
      return &t.nodes[map.entries[i].second];
    }
  return nullptr;
}

// YAML's null: an empty plain scalar, `~` or `null`.
bool is_null(const YamlNode& n) {
  return n.kind == YamlNode::kScalar && n.plain && (n.text.empty() || n.text == "~" || n.text == "null");
}

// A plain scalar as a double, exactly as written (from_chars: no locale, correct
// rounding); `.inf`/`.nan` as YAML spells them. False when it is not a number.
bool scalar_number(const YamlNode& n, double* v) {
  if (n.kind != YamlNode::kScalar || !n.plain || n.text.empty()) return false;
  std::string s = n.text;
  bool negative = false;
  size_t at = 0;
  if (s[0] == '+' || s[0] == '-') {
    negative = s[0] == '-';
    at = 1;
  }
  std::string rest = s.substr(at);
  std::string lower = rest;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == ".inf") {
    *v = negative ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  if (lower == ".nan") {
    *v = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (rest.empty() || !(std::isdigit(static_cast<unsigned char>(rest[0])) || rest[0] == '.')) return false;
  double x = 0;
  const char* first = rest.data();
  const char* last = rest.data() + rest.size();
  auto r = std::from_chars(first, last, x, std::chars_format::general);
  if (r.ptr != last) return false;
  if (r.ec == std::errc::result_out_of_range) x = std::numeric_limits<double>::infinity();  // reported as not finite
  else if (r.ec != std::errc()) return false;
  *v = negative ? -x : x;
  return true;
}

double read_number(const YamlTree& t, const YamlNode& parent, const std::string& field, const Where& w,
                   std::optional<double> fallback = std::nullopt) {
  int line = parent.line;
  const YamlNode* n = child(t, parent, field, &line);
  if (!n || is_null(*n)) {
    if (fallback) return *fallback;
    fail_at(w, line, field, "missing (expected a number)");
  }
  double v = 0;
  if (!scalar_number(*n, &v)) fail_at(w, n->line, field, "expected a number");
  if (!std::isfinite(v)) fail_at(w, n->line, field, "expected a finite number");
  return v;
}

// Decimal integers only, range-checked before conversion: 4294967552 is an
// error, never 256.
int read_int(const YamlTree& t, const YamlNode& parent, const std::string& field, const Where& w) {
  int line = parent.line;
  const YamlNode* n = child(t, parent, field, &line);
  if (!n || is_null(*n)) fail_at(w, line, field, "missing (expected an integer)");
  if (n->kind != YamlNode::kScalar || !n->plain || n->text.empty()) fail_at(w, n->line, field, "expected an integer");
  const std::string& s = n->text;
  const char* first = s.data() + (s[0] == '+' ? 1 : 0);
  const char* last = s.data() + s.size();
  int v = 0;
  auto r = std::from_chars(first, last, v);
  if (r.ptr != last || first == last) fail_at(w, n->line, field, "expected an integer");
  if (r.ec == std::errc::result_out_of_range)
    fail_at(w, n->line, field, "'" + s + "' is out of range (expected an integer from " +
                                   std::to_string(std::numeric_limits<int>::min()) + " to " +
                                   std::to_string(std::numeric_limits<int>::max()) + ")");
  if (r.ec != std::errc()) fail_at(w, n->line, field, "expected an integer");
  return v;
}

std::vector<double> read_numbers(const YamlTree& t, const YamlNode& parent, const std::string& field,
                                 const Where& w, size_t count) {
  int line = parent.line;
  const YamlNode* n = child(t, parent, field, &line);
  std::ostringstream expect;
  expect << "a list of " << count << " numbers";
  if (!n || is_null(*n)) fail_at(w, line, field, "missing (expected " + expect.str() + ")");
  if (n->kind != YamlNode::kSequence || n->items.size() != count) fail_at(w, n->line, field, "expected " + expect.str());
  std::vector<double> out;
  for (size_t i : n->items) {
    double v = 0;
    if (!scalar_number(t.nodes[i], &v)) fail_at(w, t.nodes[i].line, field, "expected " + expect.str());
    if (!std::isfinite(v)) fail_at(w, t.nodes[i].line, field, "expected finite numbers");
    out.push_back(v);
  }
  return out;
}

Eigen::Isometry3d read_transform(const YamlTree& t, const YamlNode& parent, const Where& w) {
  std::vector<double> r = read_numbers(t, parent, "rotation", w, 9);
  std::vector<double> tr = read_numbers(t, parent, "translation", w, 3);
  Eigen::Matrix3d rot;
  rot << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  if (!is_rotation(rot, 1e-4)) {
    std::ostringstream os;
    os << "not a proper rotation (expected an orthonormal 3x3 matrix, row-major, with determinant +1; "
       << "|R^T R - I| = " << (rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm()
       << ", det = " << rot.determinant() << ")";
    int line = parent.line;
    child(t, parent, "rotation", &line);
    fail_at(w, line, "rotation", os.str());
  }
  // Re-orthonormalise a matrix rounded in the file so the error never
  // accumulates downstream; exact ones are kept bit for bit.
  if (!is_rotation(rot, 1e-12)) rot = Eigen::Quaterniond(rot).normalized().toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rot;
  T.translation() = Eigen::Vector3d(tr[0], tr[1], tr[2]);
  return T;
}

// Shortest text that reads back to the same double (to_chars: no locale).
std::string number_text(double v) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// A YAML double-quoted string that reads back as `s`: printable ASCII as it
// is, everything else as a \u or \U escape of its code point (YAML folds raw
// line breaks such as U+0085 or U+2028, so they must not appear unescaped).
// Bytes that are not UTF-8 become U+FFFD: YAML text is Unicode.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  char buf[16];
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      if (c == '"' || c == '\\') out += '\\';
      out += static_cast<char>(c);
      ++i;
      continue;
    }
    // Decode one UTF-8 sequence (shortest form, no surrogates).
    uint32_t cp = 0xFFFD;
    size_t len = 1;
    const size_t need = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 0;
    if (need == 1) {
      cp = c;
    } else if (need && i + need <= s.size()) {
      uint32_t v = c & (0x7f >> need);
      bool ok = true;
      for (size_t k = 1; k < need; ++k) {
        const unsigned char cc = static_cast<unsigned char>(s[i + k]);
        ok = ok && (cc >> 6) == 2;
        v = (v << 6) | (cc & 0x3f);
      }
      static const uint32_t kMin[5] = {0, 0, 0x80, 0x800, 0x10000};
      if (ok && v >= kMin[need] && v <= 0x10FFFF && !(v >= 0xD800 && v <= 0xDFFF)) {
        cp = v;
        len = need;
      }
    }
    if (cp <= 0xFFFF) std::snprintf(buf, sizeof buf, "\\u%04X", static_cast<unsigned>(cp));
    else std::snprintf(buf, sizeof buf, "\\U%08X", static_cast<unsigned>(cp));
    out += buf;
    i += len;
  }
  return out + "\"";
}

void write_transform(std::ostream& os, const Eigen::Isometry3d& T, const std::string& indent) {
  os << indent << "rotation: [";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) os << (r || c ? ", " : "") << number_text(T.linear()(r, c));
  os << "]\n" << indent << "translation: [" << number_text(T.translation().x()) << ", "
     << number_text(T.translation().y()) << ", " << number_text(T.translation().z()) << "]\n";
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

namespace {

std::string pixels_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// Finite and positive is not enough: a focal length of 1e-300 px (a unit
// slip, a corrupted file) passes and then turns every projection into
// infinities far from where the file was read. Real lenses, from a fisheye
// (about 0.15 of the image's side) to a long telephoto, lie well inside
// kMinFocalPerSide..kMaxFocalPerSide times the image's larger side, and the
// principal point lies on the image (docs/rig-format.md).
template <typename Fail>
void check_intrinsics_plausible(const CameraCalib& c, Fail fail) {
  const double side = std::max(c.width, c.height);
  const double lo = kMinFocalPerSide * side, hi = kMaxFocalPerSide * side;
  const std::string range = pixels_text(lo) + ".." + pixels_text(hi) + " pixels (" + pixels_text(kMinFocalPerSide) +
                            " to " + pixels_text(kMaxFocalPerSide) + " times the image's larger side)";
  if (!(c.fx >= lo && c.fx <= hi)) fail("fx", "focal length " + pixels_text(c.fx) + " is implausible: expected " + range);
  if (!(c.fy >= lo && c.fy <= hi)) fail("fy", "focal length " + pixels_text(c.fy) + " is implausible: expected " + range);
  // Pixel centres are at integer coordinates, so the image spans -0.5 .. size - 0.5.
  if (!(c.cx >= -0.5 && c.cx <= c.width - 0.5))
    fail("cx", "principal point " + pixels_text(c.cx) + " lies outside the image (expected -0.5.." +
                   pixels_text(c.width - 0.5) + ")");
  if (!(c.cy >= -0.5 && c.cy <= c.height - 0.5))
    fail("cy", "principal point " + pixels_text(c.cy) + " lies outside the image (expected -0.5.." +
                   pixels_text(c.height - 0.5) + ")");
}

// The checks of validate_camera, each message carrying the line of the field
// when the camera came from a file.
// `plausible`: also the ranges of a real lens (rig files); caps checked alone
// skip them, as a virtual view may be any field of view the lecturer asks for.
template <typename LineOf>
void check_camera(const CameraCalib& c, const Where& w, LineOf line_of, bool plausible = true) {
  auto fail = [&](const char* field, const std::string& what) { fail_at(w, line_of(field), field, what); };
  if (c.id < 0) fail("id", "expected an integer >= 0");
  if (c.width <= 0 || c.width > kMaxImageSide) fail("width", "expected 1.." + std::to_string(kMaxImageSide) + " pixels");
  if (c.height <= 0 || c.height > kMaxImageSide) fail("height", "expected 1.." + std::to_string(kMaxImageSide) + " pixels");
  if (!(std::isfinite(c.fx) && c.fx > 0)) fail("fx", "expected a focal length > 0 (pixels)");
  if (!(std::isfinite(c.fy) && c.fy > 0)) fail("fy", "expected a focal length > 0 (pixels)");
  if (!std::isfinite(c.cx)) fail("cx", "expected a finite principal point (pixels)");
  if (!std::isfinite(c.cy)) fail("cy", "expected a finite principal point (pixels)");
  if (plausible) check_intrinsics_plausible(c, fail);
  for (double d : c.distortion)
    if (!std::isfinite(d)) fail("distortion", "expected finite coefficients");
  if (!(std::isfinite(c.depth_scale) && c.depth_scale > 0)) fail("depth_scale", "expected millimetres per depth unit > 0");
  if (!is_rotation(c.cam_to_rig.linear())) fail("rotation", "not a proper rotation (orthonormal, determinant +1)");
  if (!c.cam_to_rig.translation().allFinite()) fail("translation", "expected finite numbers");
  if (c.depth_to_color && !is_rotation(c.depth_to_color->linear())) {
    Where d = w;
    d.context += d.context.empty() ? "depth_to_color" : ": depth_to_color";
    fail_at(d, line_of("depth_to_color"), "rotation", "not a proper rotation (orthonormal, determinant +1)");
  }
}

std::string camera_context(size_t index, int id) {
  return "camera " + std::to_string(index) + " (id " + std::to_string(id) + ")";
}

}  // namespace

void validate_camera(const CameraCalib& c, const std::string& where) {
  check_camera(c, Where{where, ""}, [](const char*) { return 0; }, false);
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
    const std::string cw = where + ": " + camera_context(i, rig.cameras[i].id);
    check_camera(rig.cameras[i], Where{cw, ""}, [](const char*) { return 0; });
    if (!ids.insert(rig.cameras[i].id).second) fail_at(Where{cw, ""}, 0, "id", "duplicate camera id");
  }
}

Rig parse_rig_text(const std::string& input, const std::string& file) {
  if (input.size() > kMaxRigFileBytes)
    throw Error(file + ": rig file of " + std::to_string(input.size()) + " bytes (expected at most " +
                std::to_string(kMaxRigFileBytes) + ")");
  if (input.find('\0') != std::string::npos) throw Error(file + ": not a valid rig YAML file (a NUL byte: binary data)");
  // Files written by OpenCV's FileStorage (earlier versions of save_rig) start
  // with its "%YAML:1.0" line, which is not YAML 1.1 syntax: skip that line.
  std::string text = input;
  if (text.rfind("%YAML:", 0) == 0) {
    const size_t eol = text.find('\n');
    text = eol == std::string::npos ? std::string() : "\n" + text.substr(eol + 1);  // keeps line numbers
  }
  const YamlTree tree = parse_yaml(text, file);
  Rig rig;
  if (tree.nodes.empty() || tree.nodes[0].kind != YamlNode::kMapping)
    throw Error(file + (tree.nodes.empty() ? "" : ":" + std::to_string(tree.nodes[0].line)) +
                ": expected a mapping with 'name' and 'cameras' at the top level (docs/rig-format.md)");
  const YamlNode& root = tree.nodes[0];
  const Where top{file, ""};
  int line = 0;
  if (const YamlNode* name = child(tree, root, "name", &line)) {
    if (name->kind != YamlNode::kScalar) fail_at(top, name->line, "name", "expected a string");
    if (!is_null(*name)) rig.name = name->text;
  }
  const YamlNode* cams = child(tree, root, "cameras", &line);
  if (!cams || is_null(*cams)) throw Error(file + ": field 'cameras': missing (expected a list of 1 to 8 cameras)");
  if (cams->kind != YamlNode::kSequence) fail_at(top, cams->line, "cameras", "expected a list of cameras");
  if (cams->items.size() > static_cast<size_t>(Rig::kMaxCameras))
    fail_at(top, cams->line, "cameras",
            std::to_string(cams->items.size()) + " cameras (expected 1 to " + std::to_string(Rig::kMaxCameras) + ")");
  size_t index = 0;
  std::set<int> ids;
  for (size_t item : cams->items) {
    const YamlNode& n = tree.nodes[item];
    Where w{file, "camera " + std::to_string(index)};
    if (n.kind != YamlNode::kMapping) throw Error(w.at(n.line) + ": expected a mapping of camera fields");
    CameraCalib c;
    c.id = read_int(tree, n, "id", w);
    w.context = camera_context(index, c.id);
    if (const YamlNode* name = child(tree, n, "name"))
      if (name->kind == YamlNode::kScalar && !is_null(*name)) c.name = name->text;
    c.width = read_int(tree, n, "width", w);
    c.height = read_int(tree, n, "height", w);
    c.fx = read_number(tree, n, "fx", w);
    c.fy = read_number(tree, n, "fy", w);
    c.cx = read_number(tree, n, "cx", w);
    c.cy = read_number(tree, n, "cy", w);
    if (const YamlNode* d = child(tree, n, "distortion"); d && !is_null(*d)) {
      std::vector<double> v = read_numbers(tree, n, "distortion", w, 5);
      std::copy(v.begin(), v.end(), c.distortion.begin());
    }
    c.depth_scale = read_number(tree, n, "depth_scale", w, 1.0);
    c.cam_to_rig = read_transform(tree, n, w);
    if (const YamlNode* d = child(tree, n, "depth_to_color"); d && !is_null(*d)) {
      Where dw = w;
      dw.context += ": depth_to_color";
      if (d->kind != YamlNode::kMapping) throw Error(dw.at(d->line) + ": expected a mapping with rotation and translation");
      c.depth_to_color = read_transform(tree, *d, dw);
      // The depth lens's own intrinsics: all of them, or none (the colour lens's).
      if (const YamlNode* lw = child(tree, *d, "width"); lw && !is_null(*lw)) {
        CameraCalib::DepthLens lens;
        lens.width = read_int(tree, *d, "width", dw);
        lens.height = read_int(tree, *d, "height", dw);
        lens.fx = read_number(tree, *d, "fx", dw);
        lens.fy = read_number(tree, *d, "fy", dw);
        lens.cx = read_number(tree, *d, "cx", dw);
        lens.cy = read_number(tree, *d, "cy", dw);
        c.depth_lens = lens;
        // Checked as the camera it is (the same checks as a colour lens's, naming the depth lens's lines).
        check_camera(depth_sensor_of(c), dw, [&](const char* field) {
          int l = d->line;
          child(tree, *d, field, &l);
          return l;
        });
      }
    }
    check_camera(c, w, [&](const char* field) {
      int l = n.line;
      child(tree, n, field, &l);
      return l;
    });
    if (!ids.insert(c.id).second) {
      int l = n.line;
      child(tree, n, "id", &l);
      fail_at(w, l, "id", "duplicate camera id");
    }
    rig.cameras.push_back(c);
    ++index;
  }
  if (const YamlNode* nav = child(tree, root, "navigation", &line); nav && !is_null(*nav)) {
    const Where w{file, "navigation"};
    if (nav->kind != YamlNode::kMapping)
      throw Error(w.at(nav->line) + ": expected a mapping with reference_camera, coverage, min and max");
    NavigationBounds b;
    b.reference_camera = read_int(tree, *nav, "reference_camera", w);
    b.coverage = read_number(tree, *nav, "coverage", w, 0.9);
    const std::vector<double> lo = read_numbers(tree, *nav, "min", w, 6), hi = read_numbers(tree, *nav, "max", w, 6);
    std::copy(lo.begin(), lo.end(), b.min.begin());
    std::copy(hi.begin(), hi.end(), b.max.begin());
    rig.navigation = b;
    try {
      validate_navigation(rig);
    } catch (const Error& e) {
      throw Error(w.at(nav->line) + ": " + e.what());
    }
  }
  validate_rig(rig, file);
  return rig;
}

void validate_navigation(const Rig& rig) {
  if (!rig.navigation) return;
  const NavigationBounds& b = *rig.navigation;
  if (!rig.find(b.reference_camera))
    throw Error("reference_camera " + std::to_string(b.reference_camera) + " is not a camera of the rig");
  if (!(b.coverage >= 0 && b.coverage <= 1)) throw Error("coverage must be 0 to 1");
  static const char* kNames[6] = {"right", "up", "forward", "yaw", "pitch", "roll"};
  for (int i = 0; i < 6; ++i) {
    const double limit = i < 3 ? 1000.0 : 180.0;  // metres, degrees
    if (!std::isfinite(b.min[i]) || !std::isfinite(b.max[i]) || b.min[i] < -limit || b.max[i] > limit)
      throw Error(std::string(kNames[i]) + " bounds must lie within ±" + number_text(limit));
    // The reference camera's own view is always allowed: clamping must have somewhere to go.
    if (b.min[i] > 0 || b.max[i] < 0)
      throw Error(std::string(kNames[i]) + " bounds [" + number_text(b.min[i]) + ", " + number_text(b.max[i]) +
                  "] must hold 0 (the reference camera's view)");
  }
}

Rig load_rig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open rig file (missing or unreadable)");
  // Read at most one byte more than allowed: a huge file (or /dev/zero) is
  // refused without reading it all.
  std::string text(kMaxRigFileBytes + 1, '\0');
  in.read(&text[0], static_cast<std::streamsize>(text.size()));
  if (in.bad()) throw Error(path + ": cannot read rig file");
  text.resize(static_cast<size_t>(in.gcount()));
  if (text.size() > kMaxRigFileBytes)
    throw Error(path + ": rig file larger than " + std::to_string(kMaxRigFileBytes) + " bytes (not a rig file)");
  return parse_rig_text(text, path);
}

std::string rig_to_text(const Rig& rig) {
  std::ostringstream os;
  os << "# gst-vclassroom rig: pinhole cameras; rotation/translation map camera to rig (metres)\n"
     << "rig_version: 1\n"
     << "name: " << quoted(rig.name) << "\n"
     << "cameras:\n";
  for (const auto& c : rig.cameras) {
    os << "  - id: " << c.id << "\n"
       << "    name: " << quoted(c.name) << "\n"
       << "    width: " << c.width << "\n"
       << "    height: " << c.height << "\n"
       << "    fx: " << number_text(c.fx) << "\n"
       << "    fy: " << number_text(c.fy) << "\n"
       << "    cx: " << number_text(c.cx) << "\n"
       << "    cy: " << number_text(c.cy) << "\n"
       << "    distortion: [";
    for (size_t i = 0; i < c.distortion.size(); ++i) os << (i ? ", " : "") << number_text(c.distortion[i]);
    os << "]\n"
       << "    depth_scale: " << number_text(c.depth_scale) << "\n";
    write_transform(os, c.cam_to_rig, "    ");
    if (c.depth_to_color) {
      os << "    depth_to_color:\n";
      write_transform(os, *c.depth_to_color, "      ");
      if (c.depth_lens)
        os << "      width: " << c.depth_lens->width << "\n"
           << "      height: " << c.depth_lens->height << "\n"
           << "      fx: " << number_text(c.depth_lens->fx) << "\n"
           << "      fy: " << number_text(c.depth_lens->fy) << "\n"
           << "      cx: " << number_text(c.depth_lens->cx) << "\n"
           << "      cy: " << number_text(c.depth_lens->cy) << "\n";
    }
  }
  if (rig.navigation) {
    const NavigationBounds& b = *rig.navigation;
    auto list = [](const std::array<double, 6>& v) {
      std::string s = "[";
      for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + number_text(v[i]);
      return s + "]";
    };
    os << "# where a lecturer's view may go: right, up, forward (m), yaw, pitch, roll (deg) from the reference\n"
       << "navigation:\n"
       << "  reference_camera: " << b.reference_camera << "\n"
       << "  coverage: " << number_text(b.coverage) << "\n"
       << "  min: " << list(b.min) << "\n"
       << "  max: " << list(b.max) << "\n";
  }
  return os.str();
}

CameraCalib scale_camera(const CameraCalib& cam, int width, int height) {
  CameraCalib c = cam;
  const double sx = double(width) / cam.width, sy = double(height) / cam.height;
  c.width = width;
  c.height = height;
  c.fx = cam.fx * sx;
  c.fy = cam.fy * sy;
  // Pixel centres at integers: the image edge -0.5 maps to -0.5.
  c.cx = (cam.cx + 0.5) * sx - 0.5;
  c.cy = (cam.cy + 0.5) * sy - 0.5;
  return c;
}

CameraCalib depth_sensor_of(const CameraCalib& camera) {
  if (!camera.depth_to_color) return camera;
  CameraCalib d = camera;
  if (camera.depth_lens) {
    d.width = camera.depth_lens->width;
    d.height = camera.depth_lens->height;
    d.fx = camera.depth_lens->fx;
    d.fy = camera.depth_lens->fy;
    d.cx = camera.depth_lens->cx;
    d.cy = camera.depth_lens->cy;
  }
  d.distortion = {0, 0, 0, 0, 0};
  // p_rig = cam_to_rig * p_colour = cam_to_rig * depth_to_color * p_depth.
  d.cam_to_rig = camera.cam_to_rig * *camera.depth_to_color;
  d.depth_to_color.reset();
  d.depth_lens.reset();
  return d;
}

void save_rig(const Rig& rig, const std::string& path) {
  validate_rig(rig, path);
  validate_navigation(rig);
  const std::string text = rig_to_text(rig);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(path + ": cannot write rig file");
  out << text;
  out.flush();
  if (!out) throw Error(path + ": cannot write rig file (disk full?)");
}

}  // namespace vclassroom
