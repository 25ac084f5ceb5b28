#include <gst/vclassroom/core/pose_trace.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

std::vector<PoseSample> load_pose_trace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open pose trace (missing or unreadable)");
  std::string line;
  size_t lineno = 0;
  std::map<std::string, size_t> col;
  std::vector<PoseSample> out;
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::string cur;
    std::istringstream is(l);
    while (std::getline(is, cur, ',')) {
      size_t a = cur.find_first_not_of(" \t\r"), b = cur.find_last_not_of(" \t\r");
      f.push_back(a == std::string::npos ? "" : cur.substr(a, b - a + 1));
    }
    return f;
  };
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    std::vector<std::string> f = split(line);
    if (col.empty()) {
      for (size_t i = 0; i < f.size(); ++i) col[f[i]] = i;
      for (const char* req : {"x", "y", "z", "qw", "qx", "qy", "qz"})
        if (!col.count(req))
          throw Error(path + ":" + std::to_string(lineno) + ": header lacks column '" + req +
                      "' (expected t,x,y,z,qw,qx,qy,qz[,fov][,seq])");
      continue;
    }
    if (f.size() != col.size())
      throw Error(path + ":" + std::to_string(lineno) + ": expected " + std::to_string(col.size()) + " columns, got " +
                  std::to_string(f.size()));
    auto num = [&](const std::string& name) {
      const std::string& s = f[col.at(name)];
      char* end = nullptr;
      double v = std::strtod(s.c_str(), &end);
      if (s.empty() || *end != '\0' || !std::isfinite(v))
        throw Error(path + ":" + std::to_string(lineno) + ": column '" + name + "': '" + s + "' is not a number");
      return v;
    };
    PoseSample ps;
    ps.pose.position = {num("x"), num("y"), num("z")};
    ps.pose.orientation = Eigen::Quaterniond(num("qw"), num("qx"), num("qy"), num("qz"));
    if (col.count("t")) {
      ps.t = num("t");
      if (!out.empty() && ps.t < out.back().t)
        throw Error(path + ":" + std::to_string(lineno) + ": column 't': " + std::to_string(ps.t) +
                    " is earlier than the line before (" + std::to_string(out.back().t) + "); times must not decrease");
    }
    if (col.count("fov")) ps.pose.fov_deg = num("fov");
    ps.pose.seq = col.count("seq") ? static_cast<uint64_t>(num("seq")) : out.size();
    try {
      validate_pose(ps.pose);
    } catch (const Error& e) {
      throw Error(path + ":" + std::to_string(lineno) + ": " + e.what());
    }
    ps.pose.orientation.normalize();
    out.push_back(ps);
  }
  if (col.empty()) throw Error(path + ": empty pose trace (expected a header line t,x,y,z,qw,qx,qy,qz)");
  return out;
}

namespace {

std::string trace_header(bool fov) { return std::string("t,x,y,z,qw,qx,qy,qz") + (fov ? ",fov" : "") + ",seq\n"; }

std::string trace_line(const PoseSample& s, bool fov) {
  const Pose& p = s.pose;
  char buf[512];
  int n = std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g",
                        std::isnan(s.t) ? 0.0 : s.t, p.position.x(), p.position.y(), p.position.z(),
                        p.orientation.w(), p.orientation.x(), p.orientation.y(), p.orientation.z());
  if (fov) n += std::snprintf(buf + n, sizeof buf - size_t(n), ",%.17g", p.fov_deg);
  std::snprintf(buf + n, sizeof buf - size_t(n), ",%llu\n", static_cast<unsigned long long>(p.seq));
  return buf;
}

}  // namespace

void save_pose_trace(const std::vector<PoseSample>& trace, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot write pose trace");
  const bool fov = !trace.empty() && trace.front().pose.has_fov();
  out << trace_header(fov);
  for (const auto& s : trace) out << trace_line(s, fov);
}

PoseTraceWriter::PoseTraceWriter(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) throw Error(path + ": cannot write pose trace (" + std::strerror(errno) + ")");
}

PoseTraceWriter::~PoseTraceWriter() {
  if (file_) std::fclose(file_);
}

void PoseTraceWriter::append(const PoseSample& sample) {
  std::string text;
  if (!header_written_) {
    fov_ = sample.pose.has_fov();
    text = trace_header(fov_);
    header_written_ = true;
  }
  text += trace_line(sample, fov_);
  if (std::fwrite(text.data(), 1, text.size(), file_) != text.size() || std::fflush(file_) != 0)
    throw Error(path_ + ": cannot write pose trace (" + std::strerror(errno) + ")");
}

size_t pose_trace_index(const std::vector<PoseSample>& trace, double t, uint64_t frame) {
  if (trace.empty()) return 0;
  if (std::isnan(trace.front().t)) return static_cast<size_t>(std::min<uint64_t>(frame, trace.size() - 1));
  // A frame time a hair under a sample's (rounding of 1/30 s) still shows that sample.
  const double at = t + 1e-6;
  const auto it = std::upper_bound(trace.begin(), trace.end(), at,
                                   [](double v, const PoseSample& s) { return v < s.t; });
  return it == trace.begin() ? 0 : static_cast<size_t>(it - trace.begin()) - 1;
}

}  // namespace vclassroom
