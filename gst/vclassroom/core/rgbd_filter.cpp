#include "rgbd_filter.h"

#include <algorithm>
#include <optional>
#include <vector>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/warning_limiter.h>

GST_DEBUG_CATEGORY_STATIC(rgbd_filter_debug);
#define GST_CAT_DEFAULT rgbd_filter_debug

using namespace vclassroom;

namespace {

struct FilterState {
  std::mutex lock;  // the subclass's properties (rgbd_filter_lock)

  // Streaming thread only.
  RgbdInfo in_info, out_info;
  bool negotiated = false;
  std::string refused;  // why the stream is refused, "" when served
  int refused_camera = -1;
  std::string told_refusal;  // the refusal refused_warnings counts (it outlives a renegotiation)
  int told_camera = -1;
  // Two kinds of drop, each told at once when it starts: a refused stream, and frames that cannot be mapped.
  WarningLimiter refused_warnings, bad_frame_warnings;
};

}  // namespace

typedef struct {
  FilterState* st;
} GstRgbdFilterPrivate;

G_DEFINE_ABSTRACT_TYPE_WITH_PRIVATE(GstRgbdFilter, gst_rgbd_filter, GST_TYPE_BASE_TRANSFORM)

static FilterState* state(GstRgbdFilter* self) {
  return static_cast<GstRgbdFilterPrivate*>(gst_rgbd_filter_get_instance_private(self))->st;
}

// "the color and depth planes" for the negotiation message.
static std::string planes_phrase(guint bits) {
  std::vector<std::string> names;
  for (Plane p : {Plane::Color, Plane::Depth, Plane::Label, Plane::Weight, Plane::DepthGT})
    if (bits & rgbd_plane_bit(p)) names.push_back(plane_name(p));
  std::string s = "the ";
  for (size_t i = 0; i < names.size(); ++i)
    s += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
  return s + (names.size() == 1 ? " plane" : " planes");
}

// `planes` with `p` inserted where the stored order puts it, unless present.
static std::string planes_with(const std::string& planes, Plane p) {
  std::vector<std::string> names;
  for (size_t at = 0; at <= planes.size();) {
    const size_t comma = std::min(planes.find(',', at), planes.size());
    names.push_back(planes.substr(at, comma - at));
    at = comma + 1;
  }
  size_t insert = names.size();
  for (size_t i = 0; i < names.size(); ++i) {
    const std::optional<Plane> q = plane_from_name(names[i]);
    if (q == p) return planes;
    if (q && *q > p && insert == names.size()) insert = i;
  }
  names.insert(names.begin() + insert, plane_name(p));
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ",") + n;
  return out;
}

// The one place where the library's exceptions become bus errors. `setup`: a step before the frames (start,
// set_info), where what fails is a setting (a file that cannot be read); else a frame the library could not
// process, which ends the stream since the next frame would fail alike.
static void post_library_error(GstRgbdFilter* self, const char* setup, const char* what, bool opencv) {
  const char* name = GST_OBJECT_NAME(self);
  if (setup)
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s: %s", name, what), ("%s of %s", setup, name));
  else if (opencv)
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s: camera %d's frame failed: %s", name,
                                             state(self)->in_info.camera.id, what), (nullptr));
  else
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s: %s", name, what), (nullptr));
}

GstFlowReturn vclassroom::rgbd_filter_guard(GstRgbdFilter* self, const std::function<GstFlowReturn()>& work) {
  try {
    return work();
  } catch (const Error& e) {
    post_library_error(self, nullptr, e.what(), false);
  } catch (const cv::Exception& e) {
    post_library_error(self, nullptr, e.what(), true);
  }
  return GST_FLOW_ERROR;
}

bool vclassroom::rgbd_filter_guard_setup(GstRgbdFilter* self, const char* what, const std::function<bool()>& work) {
  try {
    return work();
  } catch (const Error& e) {
    post_library_error(self, what, e.what(), false);
  } catch (const cv::Exception& e) {
    post_library_error(self, what, e.what(), true);
  }
  return false;
}

static GstFlowReturn drop_with(GstRgbdFilter* self, WarningLimiter* limiter, int camera, const std::string& why) {
  uint64_t count = 0;
  int64_t span = 0;
  if (limiter->note(int64_t(g_get_monotonic_time()) * 1000, &count, &span)) {
    const std::string what = describe_occurrences(count, "a frame", "frames", "camera " + std::to_string(camera), span);
    GST_ELEMENT_WARNING(self, STREAM, WRONG_TYPE, ("%s: dropped %s; %s", GST_OBJECT_NAME(self), what.c_str(), why.c_str()),
                        ("%" G_GUINT64_FORMAT " frames dropped since these caps came", guint64(limiter->total())));
  }
  return GST_BASE_TRANSFORM_FLOW_DROPPED;
}

GstFlowReturn vclassroom::rgbd_filter_drop_frame(GstRgbdFilter* self, const std::string& why) {
  FilterState* st = state(self);
  return drop_with(self, &st->bad_frame_warnings, st->in_info.camera.id, why);
}

void vclassroom::rgbd_filter_refuse_stream(GstRgbdFilter* self, const std::string& why) {
  FilterState* st = state(self);
  // A new refusal is told at once; the same one again (caps re-sent) stays within the limit.
  if (why != st->told_refusal || st->in_info.camera.id != st->told_camera) st->refused_warnings.reset();
  st->told_refusal = st->refused = why;
  st->told_camera = st->refused_camera = st->in_info.camera.id;
}

const RgbdInfo& vclassroom::rgbd_filter_in_info(GstRgbdFilter* self) { return state(self)->in_info; }
const RgbdInfo& vclassroom::rgbd_filter_out_info(GstRgbdFilter* self) { return state(self)->out_info; }
bool vclassroom::rgbd_filter_negotiated(GstRgbdFilter* self) { return state(self)->negotiated; }
std::unique_lock<std::mutex> vclassroom::rgbd_filter_lock(GstRgbdFilter* self) {
  return std::unique_lock<std::mutex>(state(self)->lock);
}

// video/x-rgbd caps, or video/x-rgbd-coded ones read as the video/x-rgbd they describe.
static bool info_from_caps(GstCaps* caps, RgbdInfo* info, std::string* err) {
  const GstStructure* s = gst_caps_get_size(caps) ? gst_caps_get_structure(caps, 0) : nullptr;
  if (!s || !gst_structure_has_name(s, kRgbdCodedMediaType)) return rgbd_info_from_caps(caps, info, err);
  GstCaps* raw = rgbd_caps_renamed(caps, kRgbdMediaType, false);
  const bool ok = rgbd_info_from_caps(raw, info, err);
  gst_caps_unref(raw);
  return ok;
}

static gboolean gst_rgbd_filter_set_caps(GstBaseTransform* trans, GstCaps* incaps, GstCaps* outcaps) {
  GstRgbdFilter* self = GST_RGBD_FILTER(trans);
  GstRgbdFilterClass* klass = GST_RGBD_FILTER_GET_CLASS(self);
  FilterState* st = state(self);
  RgbdInfo in, out;
  std::string err;
  if (!info_from_caps(incaps, &in, &err) || !info_from_caps(outcaps, &out, &err)) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("%s: %s", GST_OBJECT_NAME(self), err.c_str()), (nullptr));
    return FALSE;
  }
  guint have = 0;
  for (Plane p : in.planes) have |= rgbd_plane_bit(p);
  if ((have & klass->required_planes) != klass->required_planes) {
    GST_ELEMENT_ERROR(self, CORE, NEGOTIATION,
                      ("%s needs %s; the stream has '%s'", GST_OBJECT_NAME(self),
                       planes_phrase(klass->required_planes).c_str(), in.planes_string().c_str()),
                      (nullptr));
    return FALSE;
  }
  st->in_info = in;
  st->out_info = out;
  st->negotiated = false;
  st->refused.clear();
  if (klass->set_info && !rgbd_filter_guard_setup(self, "the settings read at negotiation",
                                                  [&] { return klass->set_info(self, in, out) != FALSE; }))
    return FALSE;
  if (st->refused.empty()) rgbd_filter_refuse_stream(self, "");
  st->negotiated = true;
  GST_INFO_OBJECT(self, "camera %d %dx%d, planes %s -> %s%s%s", in.camera.id, in.width(), in.height(),
                  in.planes_string().c_str(), out.planes_string().c_str(), st->refused.empty() ? "" : ", refused: ",
                  st->refused.c_str());
  return TRUE;
}

// A filter that adds a plane tells upstream it may or may not have it, and downstream that it will.
static GstCaps* gst_rgbd_filter_transform_caps(GstBaseTransform* trans, GstPadDirection direction, GstCaps* caps,
                                               GstCaps* filter) {
  GstRgbdFilterClass* klass = GST_RGBD_FILTER_GET_CLASS(trans);
  const bool adds = klass->transform_plane && !(klass->required_planes & rgbd_plane_bit(klass->new_plane));
  if (!adds)
    return GST_BASE_TRANSFORM_CLASS(gst_rgbd_filter_parent_class)->transform_caps(trans, direction, caps, filter);
  GstCaps* out = gst_caps_copy(caps);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* s = gst_caps_get_structure(out, i);
    const char* planes = gst_structure_get_string(s, "planes");
    if (direction == GST_PAD_SRC)
      gst_structure_remove_field(s, "planes");
    else if (planes)
      gst_structure_set(s, "planes", G_TYPE_STRING, planes_with(planes, klass->new_plane).c_str(), nullptr);
  }
  return caps_narrowed(out, filter);
}

static gboolean gst_rgbd_filter_get_unit_size(GstBaseTransform*, GstCaps* caps, gsize* size) {
  RgbdInfo info;
  std::string err;
  if (!info_from_caps(caps, &info, &err)) return FALSE;
  *size = info.default_total_size();
  return TRUE;
}

// transform_plane: the output is made here, the input's planes shared; transform() has nothing left to do.
static GstFlowReturn gst_rgbd_filter_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* in, GstBuffer** out) {
  GstRgbdFilter* self = GST_RGBD_FILTER(trans);
  GstRgbdFilterClass* klass = GST_RGBD_FILTER_GET_CLASS(self);
  if (!klass->transform_plane)
    return GST_BASE_TRANSFORM_CLASS(gst_rgbd_filter_parent_class)->prepare_output_buffer(trans, in, out);
  FilterState* st = state(self);
  if (!st->refused.empty()) return drop_with(self, &st->refused_warnings, st->refused_camera, st->refused);
  std::string err;
  RgbdPlaneOutput plane(st->out_info, klass->new_plane);
  if (!plane.mat.empty()) {
    RgbdFrame frame;
    if (!frame.map(in, st->in_info, GST_MAP_READ, &err)) return rgbd_filter_drop_frame(self, err);
    const GstFlowReturn ret = rgbd_filter_guard(self, [&] {
      klass->transform_plane(self, frame, plane.mat);
      return GST_FLOW_OK;
    });
    if (ret != GST_FLOW_OK) return ret;
  }
  *out = plane.finish(in, st->in_info, &err);
  if (!*out) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s: %s", GST_OBJECT_NAME(self), err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  return GST_FLOW_OK;
}

static GstFlowReturn gst_rgbd_filter_transform(GstBaseTransform*, GstBuffer*, GstBuffer*) { return GST_FLOW_OK; }

static GstFlowReturn gst_rgbd_filter_transform_ip(GstBaseTransform* trans, GstBuffer* buf) {
  GstRgbdFilter* self = GST_RGBD_FILTER(trans);
  GstRgbdFilterClass* klass = GST_RGBD_FILTER_GET_CLASS(self);
  FilterState* st = state(self);
  if (!klass->transform_frame_ip) return GST_FLOW_OK;
  if (!st->refused.empty()) return drop_with(self, &st->refused_warnings, st->refused_camera, st->refused);
  RgbdFrame frame;
  std::string err;
  if (!frame.map(buf, st->in_info, GST_MAP_READ, &err)) return rgbd_filter_drop_frame(self, err);
  return rgbd_filter_guard(self, [&] {
    klass->transform_frame_ip(self, buf, frame);
    return GST_FLOW_OK;
  });
}

static gboolean gst_rgbd_filter_stop(GstBaseTransform* trans) {
  FilterState* st = state(GST_RGBD_FILTER(trans));
  st->negotiated = false;
  st->refused.clear();
  st->told_refusal.clear();
  st->refused_warnings.reset();
  st->bad_frame_warnings.reset();
  return TRUE;
}

// After every instance init, when the subclass's methods are known.
static void gst_rgbd_filter_constructed(GObject* object) {
  G_OBJECT_CLASS(gst_rgbd_filter_parent_class)->constructed(object);
  if (GST_RGBD_FILTER_GET_CLASS(object)->transform_frame_ip)
    gst_base_transform_set_in_place(GST_BASE_TRANSFORM(object), TRUE);
}

static void gst_rgbd_filter_finalize(GObject* object) {
  delete state(GST_RGBD_FILTER(object));
  G_OBJECT_CLASS(gst_rgbd_filter_parent_class)->finalize(object);
}

static void gst_rgbd_filter_class_init(GstRgbdFilterClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->constructed = gst_rgbd_filter_constructed;
  gobject_class->finalize = gst_rgbd_filter_finalize;
  bt->set_caps = GST_DEBUG_FUNCPTR(gst_rgbd_filter_set_caps);
  bt->transform_caps = GST_DEBUG_FUNCPTR(gst_rgbd_filter_transform_caps);
  bt->get_unit_size = GST_DEBUG_FUNCPTR(gst_rgbd_filter_get_unit_size);
  bt->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_rgbd_filter_prepare_output_buffer);
  bt->transform = GST_DEBUG_FUNCPTR(gst_rgbd_filter_transform);
  bt->transform_ip = GST_DEBUG_FUNCPTR(gst_rgbd_filter_transform_ip);
  bt->stop = GST_DEBUG_FUNCPTR(gst_rgbd_filter_stop);
  bt->passthrough_on_same_caps = FALSE;
  GST_DEBUG_CATEGORY_INIT(rgbd_filter_debug, "rgbdfilter", 0, "RGB-D filter base class");
}

static void gst_rgbd_filter_init(GstRgbdFilter* self) {
  static_cast<GstRgbdFilterPrivate*>(gst_rgbd_filter_get_instance_private(self))->st = new FilterState();
}
