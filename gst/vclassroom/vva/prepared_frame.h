// A camera frame prepared for warping, once for every view (docs/vva.md,
// viewprep): the background memory's colour and room layer and the warp's
// half that does not depend on the lecturer's pose (ViewWarper::prepare).
// With several lecturers, each view warps the same camera frames for its own
// pose; what does not depend on the pose is then done once per camera, not
// once per view. FramePreparer is GStreamer-free; the meta carries a
// prepared frame from viewprep to every view's viewwarp.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gst/gst.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/rig.h>
#include <gst/vclassroom/vva/background_memory.h>
#include <gst/vclassroom/vva/room_view.h>
#include <gst/vclassroom/vva/view_warp.h>

namespace vclassroom {

struct PreparedFrame {
  PreparedSource source;
  // The colour to warp where the memory shows the room as remembered; empty:
  // the frame's own colour.
  cv::Mat color;
  cv::Mat room_color, room_depth;  // the room behind the learners (WarpSource::room_*); may be empty
  // What it was prepared with: a viewwarp warping with other settings prepares the frame itself.
  bool edge_to_near = true;
  int boundary_px = 0;
  CameraCalib camera;
  // The camera's room as a mesh (room_view.h), shared by every frame of one static depth; null without a
  // static depth or where the camera is not pinhole. With it, `source` holds the learners' depth too
  // (PreparedSource::learner_depth), and a view may draw this frame as room and learners apart.
  std::shared_ptr<const RoomShape> room_shape;
  // The frame's room packed for the lookup, made by the first view that asks (any thread; once per frame).
  // Only with room_shape; `frame_color` is the colour of the frame prepared (as for source_of).
  const RoomTexture& room_texture(const cv::Mat& frame_color) const;

 private:
  friend class FramePreparer;
  mutable std::mutex texture_lock_;
  mutable bool texture_made_ = false;
  mutable RoomTexture texture_;
};

// What viewwarp does to a camera frame before it reads the pose, for one camera.
class FramePreparer {
 public:
  // The static layer's depth (CV_16UC1 mm, the camera's size; empty: none).
  void set_static_depth(const cv::Mat& depth);
  // The background memory's length in frames (0: off) and the empty room it
  // starts from (RGB; empty: it learns the room as it sees it; one of
  // another size than the frames is not used). A change starts the memory
  // again; the same settings again change nothing (call it every frame).
  void set_memory(int frames, const cv::Mat& empty_room);

  // Prepares a frame (RGB colour, depth in mm, labels or empty), its images
  // owned by the result. Throws Error or cv::Exception on images that do not
  // fit the camera.
  std::shared_ptr<PreparedFrame> prepare(const CameraCalib& camera, const cv::Mat& color, const cv::Mat& depth,
                                         const cv::Mat& label, const WarpParams& params);

  // The source to warp a prepared frame from: `frame`'s colour (or its
  // memory's), labels and room layer (views into `prepared` and the frame).
  static WarpSource source_of(const PreparedFrame& prepared, const cv::Mat& color, const cv::Mat& depth,
                              const cv::Mat& label);

 private:
  cv::Mat static_depth_, empty_room_;
  std::shared_ptr<const RoomShape> room_shape_;  // of static_depth_, made at the first frame that fits it
  int memory_frames_ = 0;
  bool memory_fresh_ = true;  // set_memory() since the last frame: the memory starts again
  BackgroundMemory memory_;
  ViewWarper warper_;
  // Up to this many frames are kept for reuse, as many as are in flight: a frame is held from its warp
  // through viewfuse's queues to its drawing, 5 or 6 at once in the pipeline of vclassroom-bench-pipeline. With
  // 4 kept, nearly every frame was made anew, its buffers zeroed again (the room's records alone 4 MB: memset
  // fell from 4.2 to 3.0 % of that pipeline's CPU); the frames alive, and the peak memory in that
  // pipeline, are the same either way (after a burst up to 8 idle frames stay kept, not 4).
  static constexpr size_t kRecentFrames = 8;
  std::vector<std::shared_ptr<PreparedFrame>> recent_;  // reused once nobody else holds them
  size_t next_ = 0;                                      // the one replaced when all are held
};

// The static layer's depth, a 16-bit PNG (mm), and the empty room's colour
// (returned RGB), as learnerseg's, viewwarp's and viewprep's prior-depth and
// empty-room name them (read by read_image). Throw Error when the file cannot
// be read as such.
cv::Mat load_static_depth(const std::string& path);
cv::Mat load_empty_room(const std::string& path);

// The prepared frame as a meta (viewprep adds it): shared by every buffer that copies it; a transform into
// another frame (a scaler, viewwarp's output) drops it.
// Adds (or replaces) the meta on a writable buffer.
void buffer_add_prepared_frame(GstBuffer* buf, std::shared_ptr<const PreparedFrame> frame);
// The buffer's prepared frame, or nullptr.
std::shared_ptr<const PreparedFrame> buffer_get_prepared_frame(GstBuffer* buf);

// What a viewwarp that warped only a camera's learners (WarpParams::learners_only) leaves to viewfuse: the
// camera's prepared frame, whose room viewfuse draws with the other cameras' (room_view.h), and the view it
// was warped for. A meta on the warped frame, as the prepared frame's.
struct RoomViewPart {
  std::shared_ptr<const PreparedFrame> frame;
  const RoomTexture* texture = nullptr;  // frame->room_texture(), made by the viewwarp
  CameraCalib view;
  SampleTiles tiles;  // WarpedView::tiles of the learners' view
  // The ids of the cameras nearer the view that this camera left its learners to (learners_left_to_nearer:
  // its learners' view is empty); empty when it warped them itself. A picture without all of them has
  // nobody's learners there.
  std::vector<int> learners_left_to;
};
void buffer_add_room_view_part(GstBuffer* buf, std::shared_ptr<const RoomViewPart> part);
std::shared_ptr<const RoomViewPart> buffer_get_room_view_part(GstBuffer* buf);

// The cameras a view's warps may leave their learners to (LearnerRounds::steady, room_view.h) as viewfuse
// tells its viewwarps: the "room-cameras" field of its answer to their warp-start query (warp_start.h), so that
// each warp knows before it warps whether a nearer camera takes its learners.
inline constexpr const char* kRoomCamerasField = "room-cameras";
// At most this many cameras go in the field and are read from it; more, and it holds (and gives) none.
inline constexpr size_t kMaxRoomCameras = 64;
// Sets the field: four doubles a camera (id, x, y, z) in a GstValueArray (empty for more than kMaxRoomCameras).
void warp_start_set_room_cameras(GstStructure* s, const std::vector<RoomCameraPlace>& cameras);
// The field as set; none where it is absent or malformed (not doubles in fours, an id that is not a whole
// number of int's range, a centre that is not finite, more than kMaxRoomCameras cameras).
std::vector<RoomCameraPlace> warp_start_room_cameras(const GstStructure* s);

}  // namespace vclassroom
