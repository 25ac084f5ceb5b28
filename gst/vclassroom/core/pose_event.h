// The `vclassroom/pose` upstream event: how a pose travels from the lecturer's side of a pipeline to the
// renderers (docs/pose.md, "The event").
#pragma once

#include <string>

#include <gst/gst.h>

#include <gst/vclassroom/core/pose.h>

namespace vclassroom {

inline constexpr const char* kPoseEventName = "vclassroom/pose";

// A GST_EVENT_CUSTOM_UPSTREAM event carrying the pose. Validates first; throws Error.
GstEvent* pose_event_new(const Pose& pose);
// True when `event` is a pose event (whether or not it is valid).
bool is_pose_event(GstEvent* event);
// Parses and validates; false with a message on a malformed or invalid pose.
bool pose_event_parse(GstEvent* event, Pose* pose, std::string* error);

}  // namespace vclassroom
