// viewwarp's properties (docs/vva.md explains each at length; gst-inspect-1.0 gets one line).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/vclassroom/core/limits.h>

#include "gstviewwarp_state.h"

namespace vclassroom {

namespace {

enum {
  PROP_0,
  PROP_WIDTH,
  PROP_HEIGHT,
  PROP_FOV,
  PROP_PRIOR_DEPTH,
  PROP_BOUNDARY,
  PROP_EDGE_TO_NEAR,
  PROP_RIG,
  PROP_REFERENCE,
  PROP_POSES_RECEIVED,
  PROP_POSE_TRACE,
  PROP_BACKGROUND_MEMORY,
  PROP_EMPTY_ROOM
};

std::string string_of(const GValue* value) { return g_value_get_string(value) ? g_value_get_string(value) : ""; }

}  // namespace

void view_warp_install_properties(GObjectClass* klass) {
  const auto ready = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto playing = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property(
      klass, PROP_WIDTH,
      g_param_spec_int("width", "Virtual width", "Width of the virtual view (0: the camera's); intrinsics scale with it",
                       0, kMaxImageSide, 0, ready));
  g_object_class_install_property(
      klass, PROP_HEIGHT,
      g_param_spec_int("height", "Virtual height", "Height of the virtual view (0: the camera's)", 0, kMaxImageSide, 0,
                       ready));
  g_object_class_install_property(
      klass, PROP_FOV,
      g_param_spec_double("fov", "Field of view",
                          "Horizontal field of view in degrees (0: the camera's); a pose's fov overrides it", 0, 179,
                          0, ready));
  g_object_class_install_property(
      klass, PROP_PRIOR_DEPTH,
      g_param_spec_string("prior-depth", "Prior depth",
                          "16-bit PNG (mm) of this camera's empty room: the static layer's depth (empty: "
                          "the stream's)",
                          "", ready));
  g_object_class_install_property(
      klass, PROP_BOUNDARY,
      g_param_spec_int("boundary", "Edge boundary",
                       "Source pixels dropped on the far side of a depth edge, beyond edge-to-near's one", 0, 8, 0,
                       playing));
  g_object_class_install_property(
      klass, PROP_EDGE_TO_NEAR,
      g_param_spec_boolean("edge-to-near", "Edge pixels to the near side",
                           "The far-side pixel next to a depth edge moves with the nearer surface", TRUE, playing));
  g_object_class_install_property(
      klass, PROP_BACKGROUND_MEMORY,
      g_param_spec_int("background-memory", "Background memory",
                       "Frames of the static room's colour memory, which also draws the room behind learners (0: off)",
                       0, 64, 0, playing));
  g_object_class_install_property(
      klass, PROP_EMPTY_ROOM,
      g_param_spec_string("empty-room", "Empty room",
                          "RGB image of the empty room seen by this camera, the memory's start (empty: learnt as seen)",
                          "", ready));
  g_object_class_install_property(
      klass, PROP_RIG,
      g_param_spec_string("rig", "Rig file",
                          "Rig YAML whose reference camera is shown until the first pose (empty: the caps' camera)",
                          "", ready));
  g_object_class_install_property(
      klass, PROP_REFERENCE,
      g_param_spec_int("reference-camera", "Reference camera",
                       "Id of the rig camera shown until the first pose (with rig only)", 0, G_MAXINT, 0, ready));
  g_object_class_install_property(
      klass, PROP_POSE_TRACE,
      g_param_spec_string("pose-trace", "Pose trace",
                          "CSV pose trace (docs/pose.md) that sets each frame's view, overriding pose events", "",
                          ready));
  g_object_class_install_property(
      klass, PROP_POSES_RECEIVED,
      g_param_spec_uint64("poses-received", "Poses received", "Pose events this element has received", 0,
                          G_MAXUINT64, 0, GParamFlags(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
}

void view_warp_set_property(ViewWarpState* st, GObject* object, guint prop_id, const GValue* value,
                            GParamSpec* pspec) {
  const auto g = st->lock();
  switch (prop_id) {
    case PROP_WIDTH:
      st->width = g_value_get_int(value);
      break;
    case PROP_HEIGHT:
      st->height = g_value_get_int(value);
      break;
    case PROP_FOV:
      st->fov = g_value_get_double(value);
      break;
    case PROP_PRIOR_DEPTH:
      st->prior_path = string_of(value);
      break;
    case PROP_BOUNDARY:
      st->boundary_px = g_value_get_int(value);
      break;
    case PROP_EDGE_TO_NEAR:
      st->edge_to_near = g_value_get_boolean(value);
      break;
    case PROP_BACKGROUND_MEMORY:
      st->memory_frames = g_value_get_int(value);
      break;
    case PROP_EMPTY_ROOM:
      st->empty_room_path = string_of(value);
      break;
    case PROP_RIG:
      st->rig_path = string_of(value);
      break;
    case PROP_REFERENCE:
      st->reference_id = g_value_get_int(value);
      break;
    case PROP_POSE_TRACE:
      st->trace_path = string_of(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

void view_warp_get_property(ViewWarpState* st, GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  const auto g = st->lock();
  switch (prop_id) {
    case PROP_WIDTH:
      g_value_set_int(value, st->width);
      break;
    case PROP_HEIGHT:
      g_value_set_int(value, st->height);
      break;
    case PROP_FOV:
      g_value_set_double(value, st->fov);
      break;
    case PROP_PRIOR_DEPTH:
      g_value_set_string(value, st->prior_path.c_str());
      break;
    case PROP_BOUNDARY:
      g_value_set_int(value, st->boundary_px);
      break;
    case PROP_EDGE_TO_NEAR:
      g_value_set_boolean(value, st->edge_to_near);
      break;
    case PROP_BACKGROUND_MEMORY:
      g_value_set_int(value, st->memory_frames);
      break;
    case PROP_EMPTY_ROOM:
      g_value_set_string(value, st->empty_room_path.c_str());
      break;
    case PROP_RIG:
      g_value_set_string(value, st->rig_path.c_str());
      break;
    case PROP_REFERENCE:
      g_value_set_int(value, st->reference_id);
      break;
    case PROP_POSE_TRACE:
      g_value_set_string(value, st->trace_path.c_str());
      break;
    case PROP_POSES_RECEIVED:
      g_value_set_uint64(value, st->poses_received);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, prop_id, pspec);
  }
}

}  // namespace vclassroom
