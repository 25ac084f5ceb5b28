// What rgbdenc and rgbddec share; the coded caps themselves are in
// gst/vclassroom/core/rgbd.h (rgbdfilesink records them too).
#pragma once

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>

#include <string>

#include <gst/vclassroom/core/rgbd.h>


// `caps` narrowed to `filter` (when given); takes ownership of `caps`.
GstCaps* caps_filtered(GstCaps* caps, GstCaps* filter);

// Takes the input buffer GstBaseTransform queued for generate_output. False
// when there is none or caps were never set (then *ret says which).
bool take_queued_input(GstBaseTransform* trans, gboolean negotiated, GstBuffer** in, GstFlowReturn* ret);

// What rgbdenc / rgbddec have done, readable as properties and, every
// `interval` frames when that is not 0, posted on the bus as an element
// message "vclassroom-codec-stats" (frames, bytes, frames-dropped and the
// drops by kind): `gst-launch-1.0 -m` prints it, so a deployment can see what
// each camera sent and the server got.
// Why a frame was dropped.
enum class DropKind : int {
  Damaged,       // truncated, checksum, malformed section
  WrongSize,     // its header declares another size than its caps
  RejectedCaps,  // its caps were refused (oversized, unparsable, not the rig's camera)
};
inline constexpr int kDropKinds = 3;
struct CodecStats {
  guint64 frames = 0;   // frames coded or decoded
  guint64 bytes = 0;    // compressed bytes of those frames
  guint64 dropped = 0;  // frames dropped, whatever the kind
  guint interval = 0;
  guint64 dropped_by_kind[kDropKinds] = {0, 0, 0};  // after interval: CodecStats{0, 0, 0, interval} resets
};
enum CodecStatsProp : guint { kPropFrames = 100, kPropBytes, kPropDropped, kPropStatsInterval };
void codec_stats_install_properties(GObjectClass* klass, const char* frames_blurb);
// For the properties above; false when prop_id is not one of them.
bool codec_stats_get_property(GstObject* self, const CodecStats& st, guint prop_id, GValue* value);
bool codec_stats_set_property(GstObject* self, CodecStats* st, guint prop_id, const GValue* value);
// Counts one frame (or a dropped one) and posts the message when due. Takes
// the object lock; returns the counts after this frame.
CodecStats codec_stats_count(GstElement* self, CodecStats* st, guint64 bytes, bool dropped);
// Counts one frame dropped for `kind`, as codec_stats_count.
CodecStats codec_stats_drop(GstElement* self, CodecStats* st, DropKind kind);
// The warning a rate-limited drop posts when its WarningLimiter says one is due: `count` drops of `singular` /
// `plural` (from `source`, "" for none) over `span` ns, the last one's reason, and `dropped` `units` so far
// ("dropped 37 damaged frames from camera 2 in the last 5 s; the last: ...").
void warn_dropped(GstElement* self, uint64_t count, int64_t span, const char* singular, const char* plural,
                  const std::string& source, const std::string& why, guint64 dropped, const char* units);
// Adds the packet counts of the rtpjitterbuffer upstream (packets-received, -lost, -repaired,
// retransmissions-requested) to a stats structure, when there is one.
void add_link_stats(GstElement* self, GstStructure* s);
// Posts the message now (at end of stream, so the last count is exact), when the interval is not 0.
void codec_stats_post(GstElement* self, const CodecStats* st);
// sink_event for rgbdenc / rgbddec: posts the final count at EOS, then chains up.
gboolean codec_stats_sink_event(GstBaseTransform* trans, GstEvent* event, CodecStats* st,
                                gboolean (*parent_sink_event)(GstBaseTransform*, GstEvent*));
