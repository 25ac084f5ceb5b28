#include <gst/vclassroom/core/rgbd.h>

#include <cmath>
#include <sstream>

namespace vclassroom {

namespace {

struct PlaneDesc {
  Plane plane;
  const char* name;
  GstVideoFormat format;
  int cv_type;
};

constexpr PlaneDesc kPlanes[] = {
    {Plane::Color, "color", GST_VIDEO_FORMAT_RGB, CV_8UC3},
    {Plane::Depth, "depth", GST_VIDEO_FORMAT_GRAY16_LE, CV_16UC1},
    {Plane::Label, "label", GST_VIDEO_FORMAT_GRAY8, CV_8UC1},
    {Plane::Weight, "weight", GST_VIDEO_FORMAT_GRAY8, CV_8UC1},
    {Plane::DepthGT, "depth-gt", GST_VIDEO_FORMAT_GRAY16_LE, CV_16UC1},
};

const PlaneDesc& desc(Plane p) {
  for (const auto& d : kPlanes)
    if (d.plane == p) return d;
  return kPlanes[0];
}

void set_double_array(GstStructure* s, const char* field, const double* v, int n) {
  GValue arr = G_VALUE_INIT;
  gst_value_array_init(&arr, n);
  for (int i = 0; i < n; ++i) {
    GValue e = G_VALUE_INIT;
    g_value_init(&e, G_TYPE_DOUBLE);
    g_value_set_double(&e, v[i]);
    gst_value_array_append_and_take_value(&arr, &e);
  }
  gst_structure_take_value(s, field, &arr);
}

bool number_value(const GValue* v, double* out) {
  if (G_VALUE_HOLDS_DOUBLE(v)) {
    *out = g_value_get_double(v);
  } else if (G_VALUE_HOLDS_INT(v)) {
    *out = g_value_get_int(v);
  } else {
    return false;
  }
  return std::isfinite(*out);
}

bool get_number(const GstStructure* s, const char* field, double* out, std::string* error) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) {
    *error = std::string("video/x-rgbd caps: field '") + field + "' missing (expected a number)";
    return false;
  }
  if (!number_value(v, out)) {
    *error = std::string("video/x-rgbd caps: field '") + field + "' is not a finite number";
    return false;
  }
  return true;
}

bool get_double_array(const GstStructure* s, const char* field, double* out, guint n, std::string* error) {
  const GValue* v = gst_structure_get_value(s, field);
  std::ostringstream expect;
  expect << "video/x-rgbd caps: field '" << field << "' ";
  if (!v) {
    *error = expect.str() + "missing (expected an array of " + std::to_string(n) + " numbers)";
    return false;
  }
  if (!GST_VALUE_HOLDS_ARRAY(v) || gst_value_array_get_size(v) != n) {
    *error = expect.str() + "expected an array of " + std::to_string(n) + " numbers";
    return false;
  }
  for (guint i = 0; i < n; ++i) {
    if (!number_value(gst_value_array_get_value(v, i), &out[i])) {
      *error = expect.str() + "holds a value that is not a finite number";
      return false;
    }
  }
  return true;
}

gint video_default_stride(GstVideoFormat fmt, int width, int height) {
  GstVideoInfo vi;
  gst_video_info_set_format(&vi, fmt, width, height);
  return GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0);
}

}  // namespace

const char* plane_name(Plane p) { return desc(p).name; }
GstVideoFormat plane_format(Plane p) { return desc(p).format; }
int plane_cv_type(Plane p) { return desc(p).cv_type; }

std::optional<Plane> plane_from_name(const std::string& name) {
  for (const auto& d : kPlanes)
    if (name == d.name) return d.plane;
  return std::nullopt;
}

int RgbdInfo::index_of(Plane p) const {
  for (size_t i = 0; i < planes.size(); ++i)
    if (planes[i] == p) return static_cast<int>(i);
  return -1;
}

gint RgbdInfo::default_stride(size_t i) const {
  return video_default_stride(plane_format(planes[i]), width(), height());
}

gsize RgbdInfo::default_offset(size_t i) const {
  gsize off = 0;
  for (size_t k = 0; k < i && k < planes.size(); ++k) off += plane_size(k);
  return off;
}

std::string RgbdInfo::planes_string() const {
  std::string s;
  for (size_t i = 0; i < planes.size(); ++i) {
    if (i) s += ',';
    s += plane_name(planes[i]);
  }
  return s;
}

GstClockTime RgbdInfo::frame_duration() const {
  if (fps_n <= 0 || fps_d <= 0) return GST_CLOCK_TIME_NONE;
  return gst_util_uint64_scale_int(GST_SECOND, fps_d, fps_n);
}

void rgbd_structure_set_camera(GstStructure* s, const CameraCalib& c) {
  gst_structure_set(s, "camera-id", G_TYPE_INT, c.id, "fx", G_TYPE_DOUBLE, c.fx, "fy", G_TYPE_DOUBLE, c.fy, "cx",
                    G_TYPE_DOUBLE, c.cx, "cy", G_TYPE_DOUBLE, c.cy, nullptr);
  set_double_array(s, "distortion", c.distortion.data(), 5);
  double r[9];
  for (int i = 0; i < 9; ++i) r[i] = c.cam_to_rig.linear()(i / 3, i % 3);
  set_double_array(s, "rotation", r, 9);
  set_double_array(s, "translation", c.cam_to_rig.translation().data(), 3);
}

GstCaps* rgbd_caps_new(const RgbdInfo& info) {
  GstStructure* s = gst_structure_new(kRgbdMediaType, "width", G_TYPE_INT, info.width(), "height", G_TYPE_INT,
                                      info.height(), "framerate", GST_TYPE_FRACTION, info.fps_n, info.fps_d,
                                      "planes", G_TYPE_STRING, info.planes_string().c_str(), nullptr);
  rgbd_structure_set_camera(s, info.camera);
  GstCaps* caps = gst_caps_new_empty();
  gst_caps_append_structure(caps, s);
  return caps;
}

bool rgbd_info_from_caps(const GstCaps* caps, RgbdInfo* info, std::string* error) {
  std::string dummy;
  if (!error) error = &dummy;
  if (!caps || gst_caps_get_size(caps) != 1 || !gst_caps_is_fixed(caps)) {
    *error = "video/x-rgbd caps: expected fixed caps with one structure";
    return false;
  }
  const GstStructure* s = gst_caps_get_structure(caps, 0);
  if (!gst_structure_has_name(s, kRgbdMediaType)) {
    *error = std::string("expected video/x-rgbd caps, got ") + gst_structure_get_name(s);
    return false;
  }
  RgbdInfo out;
  CameraCalib& c = out.camera;
  if (!gst_structure_get_int(s, "width", &c.width) || c.width <= 0) {
    *error = "video/x-rgbd caps: field 'width' missing or not a positive integer";
    return false;
  }
  if (!gst_structure_get_int(s, "height", &c.height) || c.height <= 0) {
    *error = "video/x-rgbd caps: field 'height' missing or not a positive integer";
    return false;
  }
  if (!gst_structure_get_fraction(s, "framerate", &out.fps_n, &out.fps_d)) {
    *error = "video/x-rgbd caps: field 'framerate' missing or not a fraction";
    return false;
  }
  if (!gst_structure_get_int(s, "camera-id", &c.id)) {
    *error = "video/x-rgbd caps: field 'camera-id' missing or not an integer";
    return false;
  }
  const char* planes = gst_structure_get_string(s, "planes");
  if (!planes) {
    *error = "video/x-rgbd caps: field 'planes' missing (expected e.g. \"color,depth\")";
    return false;
  }
  out.planes.clear();
  gchar** names = g_strsplit(planes, ",", -1);
  for (gchar** n = names; *n; ++n) {
    auto p = plane_from_name(g_strstrip(*n));
    if (!p || out.has(*p)) {
      *error = std::string("video/x-rgbd caps: field 'planes': unknown or repeated plane '") + *n + "'";
      g_strfreev(names);
      return false;
    }
    out.planes.push_back(*p);
  }
  g_strfreev(names);
  if (out.planes.size() < 2 || out.planes[0] != Plane::Color || out.planes[1] != Plane::Depth) {
    *error = std::string("video/x-rgbd caps: field 'planes' must start with \"color,depth\", got \"") + planes + "\"";
    return false;
  }
  if (!get_number(s, "fx", &c.fx, error) || !get_number(s, "fy", &c.fy, error) ||
      !get_number(s, "cx", &c.cx, error) || !get_number(s, "cy", &c.cy, error))
    return false;
  double r[9], t[3];
  if (!get_double_array(s, "distortion", c.distortion.data(), 5, error) ||
      !get_double_array(s, "rotation", r, 9, error) || !get_double_array(s, "translation", t, 3, error))
    return false;
  Eigen::Matrix3d rot;
  rot << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  c.cam_to_rig.linear() = rot;
  c.cam_to_rig.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  try {
    validate_camera(c, "video/x-rgbd caps");
  } catch (const Error& e) {
    *error = e.what();
    return false;
  }
  *info = out;
  return true;
}

bool rgbd_plane_layout(GstBuffer* buf, const RgbdInfo& info, size_t i, PlaneLayout* out, std::string* error) {
  PlaneLayout l{info.default_offset(i), info.default_stride(i)};
  if (GstVideoMeta* meta = gst_buffer_get_video_meta_id(buf, static_cast<gint>(i))) {
    l.offset = meta->offset[0];
    l.stride = meta->stride[0];
  }
  const int bpp = CV_ELEM_SIZE(plane_cv_type(info.planes[i]));
  const gsize needed = l.offset + static_cast<gsize>(l.stride) * (info.height() - 1) +
                       static_cast<gsize>(bpp) * info.width();
  if (l.stride < bpp * info.width() || gst_buffer_get_size(buf) < needed) {
    if (error) {
      std::ostringstream os;
      os << "video/x-rgbd buffer too small or malformed: plane '" << plane_name(info.planes[i]) << "' needs "
         << needed << " bytes, buffer has " << gst_buffer_get_size(buf);
      *error = os.str();
    }
    return false;
  }
  *out = l;
  return true;
}

PlaneLayout raw_plane_layout(GstBuffer* buf, int width, int height, GstVideoFormat fmt) {
  if (GstVideoMeta* meta = gst_buffer_get_video_meta(buf)) return {meta->offset[0], meta->stride[0]};
  return {0, video_default_stride(fmt, width, height)};
}

GstBuffer* rgbd_buffer_with_planes(const RgbdInfo& info, const std::vector<std::pair<Plane, cv::Mat>>& planes,
                                   std::string* error) {
  GstBuffer* buf = rgbd_buffer_new(info);
  RgbdFrame frame;
  if (!frame.map(buf, info, GST_MAP_WRITE, error)) {
    gst_buffer_unref(buf);
    return nullptr;
  }
  for (const auto& [plane, mat] : planes)
    if (info.has(plane)) mat.copyTo(frame.plane(plane));
  return buf;
}

GstBuffer* rgbd_buffer_new(const RgbdInfo& info) {
  GstBuffer* buf = gst_buffer_new();
  for (size_t i = 0; i < info.planes.size(); ++i)
    gst_buffer_append_memory(buf, gst_allocator_alloc(nullptr, info.plane_size(i), nullptr));
  rgbd_buffer_add_default_metas(buf, info);
  return buf;
}

void rgbd_buffer_add_default_metas(GstBuffer* buf, const RgbdInfo& info) {
  for (size_t i = 0; i < info.planes.size(); ++i) {
    if (gst_buffer_get_video_meta_id(buf, static_cast<gint>(i))) continue;
    gsize offset[GST_VIDEO_MAX_PLANES] = {info.default_offset(i)};
    gint stride[GST_VIDEO_MAX_PLANES] = {info.default_stride(i)};
    GstVideoMeta* m = gst_buffer_add_video_meta_full(buf, GST_VIDEO_FRAME_FLAG_NONE, plane_format(info.planes[i]),
                                                     info.width(), info.height(), 1, offset, stride);
    m->id = static_cast<gint>(i);
  }
}

GstBuffer* rgbd_buffer_assemble(const RgbdInfo& info, const std::vector<GstBuffer*>& parts,
                                const std::vector<PlaneLayout>& layouts) {
  g_return_val_if_fail(parts.size() == info.planes.size() && layouts.size() == parts.size(), nullptr);
  GstBuffer* out = gst_buffer_new();
  for (size_t i = 0; i < parts.size(); ++i) {
    const gsize avail = gst_buffer_get_size(parts[i]) - layouts[i].offset;
    const gsize size = std::min<gsize>(avail, static_cast<gsize>(layouts[i].stride) * info.height());
    const gsize at = gst_buffer_get_size(out);
    gst_buffer_copy_into(out, parts[i], GST_BUFFER_COPY_MEMORY, layouts[i].offset, size);
    gsize offset[GST_VIDEO_MAX_PLANES] = {at};
    gint stride[GST_VIDEO_MAX_PLANES] = {layouts[i].stride};
    GstVideoMeta* m = gst_buffer_add_video_meta_full(out, GST_VIDEO_FRAME_FLAG_NONE, plane_format(info.planes[i]),
                                                     info.width(), info.height(), 1, offset, stride);
    m->id = static_cast<gint>(i);
  }
  return out;
}

RgbdPlaneOutput::RgbdPlaneOutput(const RgbdInfo& out_info, Plane plane) : out_info_(out_info), plane_(plane) {
  const int i = out_info.index_of(plane);
  g_return_if_fail(i >= 0);
  stride_ = out_info.default_stride(static_cast<size_t>(i));
  buf_ = gst_buffer_new_allocate(nullptr, out_info.plane_size(static_cast<size_t>(i)), nullptr);
  if (buf_ && gst_buffer_map(buf_, &map_, GST_MAP_WRITE)) {
    mapped_ = true;
    mat = cv::Mat(out_info.height(), out_info.width(), plane_cv_type(plane), map_.data, static_cast<size_t>(stride_));
  }
}

RgbdPlaneOutput::~RgbdPlaneOutput() {
  if (mapped_) gst_buffer_unmap(buf_, &map_);
  if (buf_) gst_buffer_unref(buf_);
}

GstBuffer* RgbdPlaneOutput::finish(GstBuffer* in, const RgbdInfo& in_info, std::string* error) {
  if (!mapped_) {
    *error = std::string("cannot allocate the output ") + plane_name(plane_) + " plane";
    return nullptr;
  }
  gst_buffer_unmap(buf_, &map_);
  mapped_ = false;
  mat = cv::Mat();
  std::vector<GstBuffer*> parts;
  std::vector<PlaneLayout> layouts;
  for (Plane p : out_info_.planes) {
    if (p == plane_) {
      parts.push_back(buf_);
      layouts.push_back(PlaneLayout{0, stride_});
      continue;
    }
    const int i = in_info.index_of(p);
    if (i < 0) {
      *error = std::string("the input has no ") + plane_name(p) + " plane to pass on";
      return nullptr;
    }
    PlaneLayout l;
    if (!rgbd_plane_layout(in, in_info, static_cast<size_t>(i), &l, error)) return nullptr;
    parts.push_back(in);
    layouts.push_back(l);
  }
  GstBuffer* out = rgbd_buffer_assemble(out_info_, parts, layouts);
  if (!out) {
    *error = "cannot assemble the output buffer";
    return nullptr;
  }
  gst_buffer_copy_into(out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  return out;
}

GstClockTime aggregator_pad_running_time(GstAggregatorPad* pad, GstBuffer* buf) {
  const GstClockTime ts = GST_BUFFER_PTS_IS_VALID(buf) ? GST_BUFFER_PTS(buf) : GST_BUFFER_DTS(buf);
  if (!GST_CLOCK_TIME_IS_VALID(ts)) return GST_CLOCK_TIME_NONE;
  GST_OBJECT_LOCK(pad);
  const GstClockTime rt = gst_segment_to_running_time(&pad->segment, GST_FORMAT_TIME, ts);
  GST_OBJECT_UNLOCK(pad);
  return rt;
}

bool RgbdFrame::map(GstBuffer* buf, const RgbdInfo& info, GstMapFlags flags, std::string* error) {
  unmap();
  for (size_t i = 0; i < info.planes.size(); ++i) {
    PlaneLayout l;
    if (!rgbd_plane_layout(buf, info, i, &l, error)) {
      unmap();
      return false;
    }
    const int type = plane_cv_type(info.planes[i]);
    const gsize span = static_cast<gsize>(l.stride) * (info.height() - 1) +
                       static_cast<gsize>(CV_ELEM_SIZE(type)) * info.width();
    guint idx = 0, length = 0;
    gsize skip = 0;
    if (!gst_buffer_find_memory(buf, l.offset, span, &idx, &length, &skip)) {
      if (error) *error = std::string("video/x-rgbd buffer: cannot locate plane '") + plane_name(info.planes[i]) + "'";
      unmap();
      return false;
    }
    Mapped m;
    m.plane = info.planes[i];
    bool ok;
    if (length == 1) {
      m.memory = gst_memory_ref(gst_buffer_peek_memory(buf, idx));
      ok = gst_memory_map(m.memory, &m.info, flags);
      if (!ok) gst_memory_unref(m.memory);
    } else {
      m.buffer = gst_buffer_ref(buf);
      ok = gst_buffer_map_range(buf, idx, length, &m.info, flags);
      if (!ok) gst_buffer_unref(m.buffer);
    }
    if (!ok) {
      if (error) *error = std::string("video/x-rgbd buffer: cannot map plane '") + plane_name(info.planes[i]) + "'";
      unmap();
      return false;
    }
    m.mat = cv::Mat(info.height(), info.width(), type, m.info.data + skip, static_cast<size_t>(l.stride));
    maps_.push_back(std::move(m));
  }
  return true;
}

void RgbdFrame::unmap() {
  for (auto& m : maps_) {
    if (m.memory) {
      gst_memory_unmap(m.memory, &m.info);
      gst_memory_unref(m.memory);
    } else if (m.buffer) {
      gst_buffer_unmap(m.buffer, &m.info);
      gst_buffer_unref(m.buffer);
    }
  }
  maps_.clear();
}

cv::Mat RgbdFrame::plane(Plane p) const {
  for (const auto& m : maps_)
    if (m.plane == p) return m.mat;
  return cv::Mat();
}

GstCaps* rgbd_caps_renamed(GstCaps* caps, const char* name, bool coded) {
  GstCaps* out = gst_caps_copy(caps);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    gst_structure_set_name(s, name);
    if (coded) {
      gst_structure_set(s, "codec", G_TYPE_STRING, "vcrd1", nullptr);
      // Only colour, depth and labels are coded; the coded caps say what arrives.
      if (const char* planes = gst_structure_get_string(s, "planes")) {
        std::string kept;
        gchar** names = g_strsplit(planes, ",", -1);
        for (gchar** n = names; *n; ++n) {
          const std::string name = g_strstrip(*n);
          if (name == "color" || name == "depth" || name == "label") kept += (kept.empty() ? "" : ",") + name;
        }
        g_strfreev(names);
        gst_structure_set(s, "planes", G_TYPE_STRING, kept.c_str(), nullptr);
      }
    } else {
      gst_structure_remove_field(s, "codec");
    }
  }
  return out;
}

GstCaps* rgbd_source_caps(GstPad* pad, const RgbdInfo* info, GstCaps* filter) {
  return caps_narrowed(info ? rgbd_caps_new(*info) : gst_pad_get_pad_template_caps(pad), filter);
}

GstCaps* caps_narrowed(GstCaps* caps, GstCaps* filter) {
  if (!filter) return caps;
  GstCaps* narrowed = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
  gst_caps_unref(caps);
  return narrowed;
}

}  // namespace vclassroom
