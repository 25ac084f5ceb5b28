#include <gst/vclassroom/core/pose_event.h>

#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

// A field as a number of the wanted kind, accepting the integer types a hand-written structure may carry.
bool get_double(const GstStructure* s, const char* field, double* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_DOUBLE(v)) *out = g_value_get_double(v);
  else if (G_VALUE_HOLDS_FLOAT(v)) *out = g_value_get_float(v);
  else if (G_VALUE_HOLDS_INT(v)) *out = g_value_get_int(v);
  else return false;
  return true;
}

bool get_u64(const GstStructure* s, const char* field, uint64_t* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_UINT64(v)) *out = g_value_get_uint64(v);
  else if (G_VALUE_HOLDS_INT64(v) && g_value_get_int64(v) >= 0) *out = static_cast<uint64_t>(g_value_get_int64(v));
  else if (G_VALUE_HOLDS_UINT(v)) *out = g_value_get_uint(v);
  else if (G_VALUE_HOLDS_INT(v) && g_value_get_int(v) >= 0) *out = static_cast<uint64_t>(g_value_get_int(v));
  else return false;
  return true;
}

bool get_i64(const GstStructure* s, const char* field, int64_t* out) {
  const GValue* v = gst_structure_get_value(s, field);
  if (!v) return false;
  if (G_VALUE_HOLDS_INT64(v)) *out = g_value_get_int64(v);
  else if (G_VALUE_HOLDS_UINT64(v)) *out = static_cast<int64_t>(g_value_get_uint64(v));
  else if (G_VALUE_HOLDS_INT(v)) *out = g_value_get_int(v);
  else return false;
  return true;
}

}  // namespace

GstEvent* pose_event_new(const Pose& p) {
  validate_pose(p);
  const Eigen::Quaterniond q = p.orientation.normalized();
  GstStructure* s = gst_structure_new(kPoseEventName, "x", G_TYPE_DOUBLE, p.position.x(), "y", G_TYPE_DOUBLE,
                                      p.position.y(), "z", G_TYPE_DOUBLE, p.position.z(), "qw", G_TYPE_DOUBLE, q.w(),
                                      "qx", G_TYPE_DOUBLE, q.x(), "qy", G_TYPE_DOUBLE, q.y(), "qz", G_TYPE_DOUBLE,
                                      q.z(), "seq", G_TYPE_UINT64, static_cast<guint64>(p.seq), nullptr);
  if (p.session != 0) gst_structure_set(s, "session", G_TYPE_UINT64, static_cast<guint64>(p.session), nullptr);
  if (p.has_fov()) gst_structure_set(s, "fov", G_TYPE_DOUBLE, p.fov_deg, nullptr);
  if (p.viewer_time_ns >= 0) gst_structure_set(s, "viewer-time", G_TYPE_INT64, static_cast<gint64>(p.viewer_time_ns), nullptr);
  if (p.clamped) gst_structure_set(s, "clamped", G_TYPE_BOOLEAN, TRUE, nullptr);
  return gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s);
}

bool is_pose_event(GstEvent* event) {
  return event && GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
         gst_event_has_name(event, kPoseEventName);
}

bool pose_event_parse(GstEvent* event, Pose* out, std::string* error) {
  std::string dummy;
  if (!error) error = &dummy;
  if (!is_pose_event(event)) {
    *error = "not a vclassroom/pose upstream event";
    return false;
  }
  const GstStructure* s = gst_event_get_structure(event);
  Pose p;
  double v[7];
  const char* fields[7] = {"x", "y", "z", "qw", "qx", "qy", "qz"};
  for (int i = 0; i < 7; ++i) {
    if (!get_double(s, fields[i], &v[i])) {
      *error = std::string("pose event: field '") + fields[i] + "' missing or not a number";
      return false;
    }
  }
  p.position = Eigen::Vector3d(v[0], v[1], v[2]);
  p.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
  if (gst_structure_has_field(s, "fov") && !get_double(s, "fov", &p.fov_deg)) {
    *error = "pose event: field 'fov' is not a number";
    return false;
  }
  if (!get_u64(s, "seq", &p.seq)) {
    *error = "pose event: field 'seq' missing or not an unsigned integer";
    return false;
  }
  if (gst_structure_has_field(s, "session") && !get_u64(s, "session", &p.session)) {
    *error = "pose event: field 'session' is not an unsigned integer";
    return false;
  }
  if (gst_structure_has_field(s, "viewer-time") && !get_i64(s, "viewer-time", &p.viewer_time_ns)) {
    *error = "pose event: field 'viewer-time' is not an integer (ns)";
    return false;
  }
  gboolean clamped = FALSE;
  if (gst_structure_has_field(s, "clamped") && !gst_structure_get_boolean(s, "clamped", &clamped)) {
    *error = "pose event: field 'clamped' is not a boolean";
    return false;
  }
  p.clamped = clamped;
  try {
    validate_pose(p);
  } catch (const Error& e) {
    *error = e.what();
    return false;
  }
  p.orientation.normalize();
  *out = p;
  return true;
}

}  // namespace vclassroom
