#include <gst/vclassroom/vva/prepared_frame.h>

#include <atomic>
#include <climits>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/image_io.h>

namespace vclassroom {

cv::Mat load_static_depth(const std::string& path) {
  const cv::Mat depth = read_image(path, cv::IMREAD_ANYDEPTH, "prior depth");
  if (depth.type() != CV_16UC1) throw Error("prior-depth " + path + ": cannot read it as a 16-bit depth image (mm)");
  return depth;
}

cv::Mat load_empty_room(const std::string& path) {
  cv::Mat rgb;
  cv::cvtColor(read_color_image(path, "empty-room colour"), rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

namespace {

// Whether a room mesh made for camera `a` stands where it stands for `b`.
bool same_place(const CameraCalib& a, const CameraCalib& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.cam_to_rig.matrix() == b.cam_to_rig.matrix();
}

}  // namespace

const RoomTexture& PreparedFrame::room_texture(const cv::Mat& frame_color) const {
  std::lock_guard<std::mutex> g(texture_lock_);
  if (!texture_made_) {
    if (!room_shape) throw Error("camera " + std::to_string(camera.id) + "'s frame has no room to pack");
    // The room at the depth its mesh has (the static depth, not the warp's prepared layer, whose edges are
    // moved) where no learner is, the background memory's room layer where one hides it.
    const cv::Mat& room = room_shape->static_depth();
    CV_Assert(room.isContinuous());
    pack_room_records(camera, room.ptr<uint16_t>(), source.label.data(), color.empty() ? frame_color : color,
                      room_depth, room_color, &texture_);
    texture_.steady = !color.empty();  // the background memory's colour
    texture_made_ = true;
  }
  return texture_;
}

void FramePreparer::set_static_depth(const cv::Mat& depth) {
  if (depth.data != static_depth_.data) room_shape_.reset();
  static_depth_ = depth;
}

void FramePreparer::set_memory(int frames, const cv::Mat& empty_room) {
  if (frames == memory_frames_ && empty_room.data == empty_room_.data) return;  // the same: the memory goes on
  memory_frames_ = frames;
  empty_room_ = empty_room;
  memory_fresh_ = true;
}

std::shared_ptr<PreparedFrame> FramePreparer::prepare(const CameraCalib& camera, const cv::Mat& color,
                                                      const cv::Mat& depth, const cv::Mat& label,
                                                      const WarpParams& params) {
  // A recent frame's images are reused when nobody holds that frame any more (the room view's warped frames
  // hold theirs until viewfuse has drawn them: a few frames). use_count() is a relaxed read: the fence orders
  // the last holder's reads (another thread's) before the writes below.
  std::shared_ptr<PreparedFrame>* free_frame = nullptr;
  for (auto& f : recent_)
    if (f.use_count() == 1) free_frame = &f;
  if (!free_frame) {
    if (recent_.size() < kRecentFrames) recent_.emplace_back();
    free_frame = &recent_[next_++ % recent_.size()];
    *free_frame = std::make_shared<PreparedFrame>();
  }
  std::atomic_thread_fence(std::memory_order_acquire);
  std::shared_ptr<PreparedFrame> out = *free_frame;
  WarpSource src;
  src.color = color;
  src.depth = depth;
  src.label = label;
  src.static_depth = static_depth_;
  if (memory_frames_ > 0) {
    if (memory_fresh_) {
      BackgroundMemoryParams mp;
      mp.frames = memory_frames_;
      memory_ = BackgroundMemory(mp);
      if (!empty_room_.empty() && empty_room_.size() == color.size()) memory_.seed(empty_room_);
      memory_fresh_ = false;
    }
    // Written straight into the prepared frame's images, which outlive the memory's next frame.
    memory_.apply(&src, &out->color, &out->room_color, &out->room_depth);
    // No room layer this frame (no static depth or labels): nor a depth left from the frame this one reuses.
    // (The remembered room stays in room_color, its buffer kept for the next frame; nothing draws it.)
    if (src.room_depth.empty()) out->room_depth.release();
  } else {
    out->color.release();
    out->room_color.release();
    out->room_depth.release();
  }
  const bool room = !static_depth_.empty() && static_depth_.size() == color.size() && room_view_fits(camera);
  if (!room) {
    room_shape_.reset();
  } else if (!room_shape_ || !same_place(room_shape_->camera(), camera)) {
    room_shape_ = std::make_shared<RoomShape>(camera, static_depth_);
  }
  WarpParams prepared_params = params;
  prepared_params.learners_only = room;  // the learners' depth too, for a view that draws the room apart
  warper_.prepare(camera, src, prepared_params, &out->source);
  out->edge_to_near = params.edge_to_near;
  out->boundary_px = params.boundary_px;
  out->camera = camera;
  out->room_shape = room_shape_;
  out->texture_made_ = false;
  return out;
}

WarpSource FramePreparer::source_of(const PreparedFrame& prepared, const cv::Mat& color, const cv::Mat& depth,
                                    const cv::Mat& label) {
  WarpSource src;
  src.color = prepared.color.empty() ? color : prepared.color;
  src.depth = depth;
  src.label = label;
  src.room_color = prepared.room_color;
  src.room_depth = prepared.room_depth;
  return src;
}

namespace {

// A meta that holds a std::shared_ptr<const T>, shared by every copy of its buffer: the prepared frame and
// the room view's part.
template <typename T>
struct SharedPtrMeta {
  GstMeta meta;
  std::shared_ptr<const T>* value;  // owned by the meta
};

// Each kind's registered names.
template <typename T>
struct MetaNames;
template <>
struct MetaNames<PreparedFrame> {
  static constexpr const char* api = "VClassroomPreparedFrameMetaAPI";
  static constexpr const char* impl = "VClassroomPreparedFrameMeta";
};
template <>
struct MetaNames<RoomViewPart> {
  static constexpr const char* api = "VClassroomRoomViewPartMetaAPI";
  static constexpr const char* impl = "VClassroomRoomViewPartMeta";
};

template <typename T>
gboolean shared_meta_init(GstMeta* meta, gpointer, GstBuffer*) {
  reinterpret_cast<SharedPtrMeta<T>*>(meta)->value = nullptr;
  return TRUE;
}

template <typename T>
void shared_meta_free(GstMeta* meta, GstBuffer*) {
  auto* m = reinterpret_cast<SharedPtrMeta<T>*>(meta);
  delete m->value;
  m->value = nullptr;
}

template <typename T>
void shared_meta_set(GstBuffer* buf, std::shared_ptr<const T> value);

// A copy of the buffer shares the value; other transforms (a scaled or converted frame) drop it.
template <typename T>
gboolean shared_meta_transform(GstBuffer* dest, GstMeta* meta, GstBuffer*, GQuark type, gpointer data) {
  auto* m = reinterpret_cast<SharedPtrMeta<T>*>(meta);
  if (!GST_META_TRANSFORM_IS_COPY(type) || !m->value) return TRUE;
  const auto* copy = static_cast<const GstMetaTransformCopy*>(data);
  if (copy->region) return TRUE;  // a part of the buffer: not the frame that was prepared
  shared_meta_set<T>(dest, *m->value);
  return TRUE;
}

// A tag of its own: elements that make a new frame out of this one (viewwarp itself, a scaler) do not copy
// it, as GstBaseTransform copies only untagged metas by default.
template <typename T>
GType shared_meta_api() {
  static GType type = 0;
  if (g_once_init_enter(&type)) {
    static const gchar* tags[] = {"vclassroom-frame-content", nullptr};
    g_once_init_leave(&type, gst_meta_api_type_register(MetaNames<T>::api, tags));
  }
  return type;
}

template <typename T>
const GstMetaInfo* shared_meta_info() {
  static const GstMetaInfo* info = nullptr;
  if (g_once_init_enter(&info)) {
    const GstMetaInfo* mi = gst_meta_register(shared_meta_api<T>(), MetaNames<T>::impl, sizeof(SharedPtrMeta<T>),
                                              shared_meta_init<T>, shared_meta_free<T>, shared_meta_transform<T>);
    g_once_init_leave(&info, mi);
  }
  return info;
}

template <typename T>
void shared_meta_set(GstBuffer* buf, std::shared_ptr<const T> value) {
  auto* m = reinterpret_cast<SharedPtrMeta<T>*>(gst_buffer_get_meta(buf, shared_meta_api<T>()));
  if (!m) m = reinterpret_cast<SharedPtrMeta<T>*>(gst_buffer_add_meta(buf, shared_meta_info<T>(), nullptr));
  if (!m) return;
  delete m->value;
  m->value = new std::shared_ptr<const T>(std::move(value));
}

template <typename T>
std::shared_ptr<const T> shared_meta_get(GstBuffer* buf) {
  auto* m = reinterpret_cast<SharedPtrMeta<T>*>(gst_buffer_get_meta(buf, shared_meta_api<T>()));
  return m && m->value ? *m->value : nullptr;
}

}  // namespace

void buffer_add_prepared_frame(GstBuffer* buf, std::shared_ptr<const PreparedFrame> frame) {
  shared_meta_set<PreparedFrame>(buf, std::move(frame));
}

std::shared_ptr<const PreparedFrame> buffer_get_prepared_frame(GstBuffer* buf) {
  return shared_meta_get<PreparedFrame>(buf);
}

void buffer_add_room_view_part(GstBuffer* buf, std::shared_ptr<const RoomViewPart> part) {
  shared_meta_set<RoomViewPart>(buf, std::move(part));
}

std::shared_ptr<const RoomViewPart> buffer_get_room_view_part(GstBuffer* buf) {
  return shared_meta_get<RoomViewPart>(buf);
}

void warp_start_set_room_cameras(GstStructure* s, const std::vector<RoomCameraPlace>& cameras) {
  GValue array = G_VALUE_INIT, v = G_VALUE_INIT;
  const bool fits = cameras.size() <= kMaxRoomCameras;  // else none: every warp then draws its own learners
  gst_value_array_init(&array, fits ? guint(4 * cameras.size()) : 0);
  g_value_init(&v, G_TYPE_DOUBLE);
  for (size_t i = 0; fits && i < cameras.size(); ++i)
    for (double x : {double(cameras[i].id), cameras[i].centre.x(), cameras[i].centre.y(), cameras[i].centre.z()}) {
      g_value_set_double(&v, x);
      gst_value_array_append_value(&array, &v);
    }
  g_value_unset(&v);
  gst_structure_take_value(s, kRoomCamerasField, &array);
}

std::vector<RoomCameraPlace> warp_start_room_cameras(const GstStructure* s) {
  const GValue* array = gst_structure_get_value(s, kRoomCamerasField);
  if (!array || !GST_VALUE_HOLDS_ARRAY(array)) return {};
  const guint n = gst_value_array_get_size(array);
  if (n % 4 != 0 || n / 4 > kMaxRoomCameras) return {};
  std::vector<RoomCameraPlace> out(n / 4);
  for (guint i = 0; i < n; ++i) {
    const GValue* v = gst_value_array_get_value(array, i);
    if (!G_VALUE_HOLDS_DOUBLE(v) || !std::isfinite(g_value_get_double(v))) return {};
    const double x = g_value_get_double(v);
    RoomCameraPlace& c = out[i / 4];
    if (i % 4 == 0) {
      if (x != std::floor(x) || x < double(INT_MIN) || x > double(INT_MAX)) return {};
      c.id = int(x);
    } else {
      c.centre[int(i % 4) - 1] = x;
    }
  }
  return out;
}

}  // namespace vclassroom
