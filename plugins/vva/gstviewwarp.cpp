/**
 * SECTION:element-viewwarp
 * @title: viewwarp
 *
 * One camera's video/x-rgbd stream warped to the lecturer's virtual view (V-VA step 2, docs/vva.md): the
 * static layer with the prior depth, the learners with their live depth, as a triangle mesh with depth-edge
 * rejection and bilinear colour. The output is video/x-rgbd of the virtual camera with the planes
 * color,depth,label,weight; camera-id stays the source camera's, virtual-view is true, and each buffer
 * carries the pose meta (seq, viewer time) of the pose it shows.
 *
 * The view follows the latest `vclassroom/pose` event from downstream (within a session the highest seq
 * wins; a new session steers from its first pose); pose events are consumed, not forwarded. Until the
 * first one arrives it shows the rig's `reference-camera` when `rig` is set, and otherwise the camera the
 * caps describe, so the first frames are the source camera's own view (with several cameras in one view,
 * give them one rig so that they all start from the same camera). `pose-trace` sets every frame's view
 * from a trace instead: the pose at the frame's running time against the trace's t column (without either,
 * by frame number), so every camera's frame of one instant is warped for the same pose.
 *
 * `prior-depth` (V-DA's prior, or vclassroom-eval-views --write-priors) gives the static layer its depth;
 * `background-memory` shows the static room through the mean of its last frames, restarted where the colour
 * changes by more than the camera's noise, and with `prior-depth` draws the room behind the learners as last
 * seen; `empty-room` (V-DA's model: prior-color/cam<ID>.png) is where that memory starts (docs/vva.md).
 *
 * With `prior-depth`, feeding a viewfuse whose `room-view` is on (the default), the warp draws only the
 * learners and what the room's mesh does not draw, and each buffer carries the camera's room (a
 * RoomViewPart meta) for viewfuse to draw at the view (docs/vva.md, "How a view is made"). A camera far from
 * the view among the room's cameras (viewfuse names them in its answer to the warp-start query) leaves its
 * learners to the nearer ones: its learners' view is then empty.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc camera-id=1 num-buffers=30 ! learnerseg ! viewwarp width=320 height=180 ! rgbddemux name=d d.color ! videoconvert ! fakesink
 * ]|
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstviewwarp.h"

#include <cmath>
#include <string>

#include <gst/vclassroom/core/limits.h>
#include <gst/vclassroom/core/pose_event.h>
#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/vva/virtual_view.h>

#include "gstviewwarp_state.h"

GST_DEBUG_CATEGORY_STATIC(view_warp_debug);
#define GST_CAT_DEFAULT view_warp_debug

using namespace vclassroom;


struct _GstViewWarp {
  GstRgbdFilter parent;
  ViewWarpState* st;
};

G_DEFINE_TYPE(GstViewWarp, gst_view_warp, GST_TYPE_RGBD_FILTER)
GST_ELEMENT_REGISTER_DEFINE(viewwarp, "viewwarp", GST_RANK_NONE, GST_TYPE_VIEW_WARP)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-rgbd, width = (int) [ 1, " G_STRINGIFY(VCLASSROOM_MAX_IMAGE_SIDE) " ], height = (int) [ 1, " G_STRINGIFY(
                        VCLASSROOM_MAX_IMAGE_SIDE) " ], "
                    "framerate = (fraction) [ 0/1, 2147483647/1 ], planes = (string) \"color,depth,label,weight\""));

static bool output_info(GstViewWarp* self, const RgbdInfo& in, RgbdInfo* out) {
  int w, h;
  double fov;
  Eigen::Isometry3d initial;
  {
    const auto g = self->st->lock();
    w = self->st->width;
    h = self->st->height;
    fov = self->st->fov;
    // Without a rig the view before the first pose is the source camera's own.
    initial = self->st->reference_from_caps && !self->st->have_pose ? in.camera.cam_to_rig
                                                                    : self->st->pose.cam_to_rig();
  }
  *out = in;
  out->camera = virtual_view_base(in.camera, w, h, fov);
  // The caps show the view at negotiation time; each buffer's pose meta says which pose it shows.
  out->camera.cam_to_rig = initial;
  out->planes = {Plane::Color, Plane::Depth, Plane::Label, Plane::Weight};
  return true;
}

// The output is the virtual camera's, not the input's: GstRgbdFilter's caps pass planes through, these
// describe another camera.
static GstCaps* gst_view_warp_transform_caps(GstBaseTransform* trans, GstPadDirection direction, GstCaps* caps,
                                             GstCaps* filter) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  GstCaps* out = nullptr;
  if (direction == GST_PAD_SINK && gst_caps_is_fixed(caps)) {
    RgbdInfo in, o;
    std::string err;
    if (rgbd_info_from_caps(caps, &in, &err) && output_info(self, in, &o)) {
      out = rgbd_caps_new(o);
      gst_caps_set_simple(out, "virtual-view", G_TYPE_BOOLEAN, TRUE, nullptr);
    }
  }
  if (!out) {
    GstPad* other = direction == GST_PAD_SINK ? GST_BASE_TRANSFORM_SRC_PAD(trans) : GST_BASE_TRANSFORM_SINK_PAD(trans);
    out = gst_pad_get_pad_template_caps(other);
  }
  return caps_narrowed(out, filter);
}

static gboolean gst_view_warp_set_info(GstRgbdFilter* filter, const RgbdInfo& in, const RgbdInfo& out) {
  GstViewWarp* self = GST_VIEW_WARP(filter);
  ViewWarpState* st = self->st;
  // A camera may change its size mid-stream (another mode, another sender):
  // it is renegotiated, and warped from its live depth alone while the prior
  // made for the other size does not fit, rather than stopping the server.
  st->use_prior = !st->prior.empty();
  if (st->use_prior && (st->prior.cols != in.width() || st->prior.rows != in.height())) {
    st->use_prior = false;
    GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS,
                        ("prior-depth is %dx%d but camera %d now streams %dx%d: warping it without the prior",
                         st->prior.cols, st->prior.rows, in.camera.id, in.width(), in.height()),
                        (nullptr));
  }
  int memory_frames;
  {
    const auto g = st->lock();
    memory_frames = st->memory_frames;
  }
  view_warp_reference_from_caps(st, in.camera);
  if (memory_frames > 0 && !st->empty_room.empty() &&
      (st->empty_room.cols != in.width() || st->empty_room.rows != in.height()))
    GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                        ("empty-room is %dx%d but camera %d streams %dx%d: the background memory learns the room as "
                         "it sees it",
                         st->empty_room.cols, st->empty_room.rows, in.camera.id, in.width(), in.height()),
                        (nullptr));
  st->preparer.set_static_depth(st->use_prior ? st->prior : cv::Mat());
  GST_INFO_OBJECT(self, "camera %d %dx%d -> virtual view %dx%d (fx %.1f)", in.camera.id, in.width(), in.height(),
                  out.width(), out.height(), out.camera.fx);
  return TRUE;
}

static GstFlowReturn gst_view_warp_prepare_output_buffer(GstBaseTransform* trans, GstBuffer* in, GstBuffer** out) {
  *out = rgbd_buffer_new(rgbd_filter_out_info(GST_RGBD_FILTER(trans)));
  gst_buffer_copy_into(*out, in, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  return GST_FLOW_OK;
}

static gboolean gst_view_warp_start(GstBaseTransform* trans) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  ViewWarpLoadError e;
  if (view_warp_load(self->st, &e)) return TRUE;
  if (e.code == GST_RESOURCE_ERROR_SETTINGS)
    GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("%s", e.message.c_str()),
                      ("property %s of %s", e.property.c_str(), GST_OBJECT_NAME(self)));
  else
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("%s", e.message.c_str()),
                      ("property %s of %s", e.property.c_str(), GST_OBJECT_NAME(self)));
  return FALSE;
}

// The frame's warp half that does not depend on the pose: a viewprep's upstream when it was made with this
// element's settings, else made here (with the background memory).
static std::shared_ptr<const PreparedFrame> prepared_frame(GstViewWarp* self, GstBuffer* inbuf, const RgbdFrame& in,
                                                           const WarpParams& params, int memory_frames) {
  ViewWarpState* st = self->st;
  const RgbdInfo& info = rgbd_filter_in_info(GST_RGBD_FILTER(self));
  std::shared_ptr<const PreparedFrame> prepared = buffer_get_prepared_frame(inbuf);
  if (prepared && (prepared->edge_to_near != params.edge_to_near || prepared->boundary_px != params.boundary_px ||
                   prepared->source.width != info.width() || prepared->source.height != info.height())) {
    if (!st->told_unprepared)
      GST_ELEMENT_WARNING(self, STREAM, FORMAT,
                          ("camera %d's frames were prepared (viewprep) with other edge-to-near, boundary or size "
                           "than this viewwarp's: it prepares them again itself", info.camera.id),
                          (nullptr));
    st->told_unprepared = true;
    prepared = nullptr;
  }
  if (prepared) return prepared;
  // A new seed (start) or length starts the memory again.
  st->preparer.set_memory(memory_frames, st->empty_room);
  return st->preparer.prepare(info.camera, in.color(), in.depth(), in.label(), params);
}

static GstFlowReturn gst_view_warp_transform(GstBaseTransform* trans, GstBuffer* inbuf, GstBuffer* outbuf) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  GstRgbdFilter* filter = GST_RGBD_FILTER(trans);
  ViewWarpState* st = self->st;
  const RgbdInfo& in_info = rgbd_filter_in_info(filter);
  const RgbdInfo& out_info = rgbd_filter_out_info(filter);
  WarpParams params;
  int memory_frames;
  {
    const auto g = st->lock();
    params.boundary_px = st->boundary_px;
    params.edge_to_near = st->edge_to_near;
    memory_frames = st->memory_frames;
  }
  RgbdFrame in, out;
  std::string err;
  if (!in.map(inbuf, in_info, GST_MAP_READ, &err)) return rgbd_filter_drop_frame(filter, err);
  if (!out.map(outbuf, out_info, GST_MAP_WRITE, &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s: %s", GST_OBJECT_NAME(self), err.c_str()), (nullptr));
    return GST_FLOW_ERROR;
  }
  return rgbd_filter_guard(filter, [&] {
    const std::shared_ptr<const PreparedFrame> prepared = prepared_frame(self, inbuf, in, params, memory_frames);
    const WarpSource src = FramePreparer::source_of(*prepared, in.color(), in.depth(), in.label());
    // The room's parts that do not depend on the pose, before it is read (not part of its latency), in this
    // camera's thread: the frame's packed room and, once, the camera's mesh.
    if (prepared->room_shape && st->room_view_last) {
      prepared->room_texture(in.color());
      prepared->room_shape->mesh();
    }
    bool room_view = false;
    std::vector<RoomCameraPlace> room_cameras;
    const Pose pose = view_warp_ask_pose(trans, st, inbuf, &room_view, &room_cameras);
    st->room_view_last = room_view;
    const CameraCalib virt = virtual_camera(out_info.camera, pose.cam_to_rig(), pose.fov_deg);
    // The room drawn by viewfuse from every camera's mesh and packed room; here only the learners.
    params.learners_only = room_view && prepared->room_shape && room_view_fits(virt);
    GST_LOG_OBJECT(self,
                   "pose seq %" G_GUINT64_FORMAT " at (%.3f, %.3f, %.3f); source camera %d at (%.3f, %.3f, %.3f)",
                   pose.seq, pose.position.x(), pose.position.y(), pose.position.z(), in_info.camera.id,
                   in_info.camera.cam_to_rig.translation().x(), in_info.camera.cam_to_rig.translation().y(),
                   in_info.camera.cam_to_rig.translation().z());
    // Warp straight into the output planes.
    st->warped.color = out.color();
    st->warped.depth = out.depth();
    st->warped.label = out.label();
    st->warped.weight = out.plane(Plane::Weight);
    st->warped.tiles = SampleTiles();  // a new buffer: the learners' view clears it all, not only its last tiles
    const std::vector<int> left_to =
        params.learners_only ? cameras_taking_learners(in_info.camera, room_cameras, virt) : std::vector<int>();
    if (left_to.empty()) {
      st->warper.warp_prepared(in_info.camera, src, prepared->source, virt, params, &st->warped);
    } else {
      GST_LOG_OBJECT(self, "far from the view: its learners left to %zu nearer camera(s)", left_to.size());
      st->warper.warp_nothing(virt, &st->warped);
    }
    if (params.learners_only) {
      auto part = std::make_shared<RoomViewPart>();
      part->learners_left_to = left_to;
      part->frame = prepared;
      part->texture = &prepared->room_texture(in.color());
      part->view = virt;
      part->tiles = st->warped.tiles;
      buffer_add_room_view_part(outbuf, std::move(part));
    }
    buffer_add_pose_meta(outbuf, pose.seq, pose.viewer_time_ns, rendered_pose_of(pose), pose.session);
    return GST_FLOW_OK;
  });
}

// Pose events end here: they steer this element and nothing upstream of it.
static gboolean gst_view_warp_src_event(GstBaseTransform* trans, GstEvent* event) {
  GstViewWarp* self = GST_VIEW_WARP(trans);
  if (is_pose_event(event)) {
    Pose pose;
    std::string err;
    if (!pose_event_parse(event, &pose, &err)) {
      GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("ignoring a bad pose event: %s", err.c_str()), (nullptr));
    } else {
      view_warp_take_pose(self->st, pose);
    }
    gst_event_unref(event);
    return TRUE;
  }
  return GST_BASE_TRANSFORM_CLASS(gst_view_warp_parent_class)->src_event(trans, event);
}

static void gst_view_warp_set_property(GObject* object, guint prop_id, const GValue* value, GParamSpec* pspec) {
  view_warp_set_property(GST_VIEW_WARP(object)->st, object, prop_id, value, pspec);
}

static void gst_view_warp_get_property(GObject* object, guint prop_id, GValue* value, GParamSpec* pspec) {
  view_warp_get_property(GST_VIEW_WARP(object)->st, object, prop_id, value, pspec);
}

static void gst_view_warp_finalize(GObject* object) {
  delete GST_VIEW_WARP(object)->st;
  G_OBJECT_CLASS(gst_view_warp_parent_class)->finalize(object);
}

static void gst_view_warp_class_init(GstViewWarpClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_view_warp_set_property;
  gobject_class->get_property = gst_view_warp_get_property;
  gobject_class->finalize = gst_view_warp_finalize;
  view_warp_install_properties(gobject_class);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "View warp", "Filter/Effect/Video",
                                        "Warps one camera's RGB-D stream to the lecturer's virtual view",
                                        "gst-vclassroom developers");
  bt->transform_caps = GST_DEBUG_FUNCPTR(gst_view_warp_transform_caps);
  bt->prepare_output_buffer = GST_DEBUG_FUNCPTR(gst_view_warp_prepare_output_buffer);
  bt->transform = GST_DEBUG_FUNCPTR(gst_view_warp_transform);
  bt->start = GST_DEBUG_FUNCPTR(gst_view_warp_start);
  bt->src_event = GST_DEBUG_FUNCPTR(gst_view_warp_src_event);
  GST_RGBD_FILTER_CLASS(klass)->set_info = GST_DEBUG_FUNCPTR(gst_view_warp_set_info);
  GST_DEBUG_CATEGORY_INIT(view_warp_debug, "viewwarp", 0, "view warp");
}

static void gst_view_warp_init(GstViewWarp* self) { self->st = new ViewWarpState(GST_RGBD_FILTER(self)); }
