// The camera link, old against new (docs/network.md, "The H.264 camera link"): each synthetic camera's
// frames are recorded into memory first, then sent through the old link (rgbdenc: JPEG q90 + lossless
// depth, rtpgstpay) and the new one (x264enc + depth coded across time in SEI, rtph264pay), MTU 1400; the
// camera side and the server side run as separate pipelines so each one's CPU is measured alone. Reports
// Mbit/s on the wire (RTP + 28 bytes of IPv4/UDP headers per packet), CPU ms per frame on each side (the
// process's CPU time over all its threads), colour PSNR against the camera's own image, the depth error
// against the sensor's depth (p99, max, and the pixels beyond the documented bound), and the depth coder
// alone (its thread's CPU time). With --view, the view PSNR loss: the lecturer's view rendered (viewwarp and
// viewfuse's library, no labels, no prior) from the 3 cameras' frames as each link delivers them and from
// the uncoded frames, at poses along a path, each against the classroom rendered exactly from that pose
// (the ground truth); the loss is the drop of that PSNR. With --redwood, the same for the Redwood sequence's
// depth (each frame warped to the next one's pose, against that real frame).
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/video/video.h>
#include <gst/gst.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/image_io.h>
#include <gst/vclassroom/core/image_metrics.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/view_offset.h>
#include <gst/vclassroom/datasets/posed_sequence.h>
#include <gst/vclassroom/net/depth_link.h>
#include <gst/vclassroom/synthetic/classroom.h>
#include <gst/vclassroom/vva/view_fuse.h>
#include <gst/vclassroom/vva/view_warp.h>

#include "camera_link_chain.h"
#include "cpu_clock.h"
#include "tool_options.h"
#include "tool_support.h"

using namespace vclassroom;

namespace {

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double thread_cpu_seconds() { return vclassroom_tools::thread_cpu_ms() * 1e-3; }

// One frame as a link delivers it (empty where it was lost).
struct Delivered {
  cv::Mat color;  // RGB
  cv::Mat depth;  // mm
};

// Pushes `in` (with `caps`) through `chain` into an appsink; returns what came out (nothing unless `keep`) and
// the CPU it took (into `cpu_s` unless null).
std::vector<GstSample*> run_chain(const std::string& chain, GstCaps* caps, const std::vector<GstBuffer*>& in,
                                  double* cpu_s = nullptr, bool keep = true) {
  const std::string desc = "appsrc name=src format=time block=true max-bytes=50000000 ! " + chain +
                           " ! appsink name=out sync=false";
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {
    std::fprintf(stderr, "cannot build '%s': %s\n", desc.c_str(), err ? err->message : "?");
    std::exit(1);
  }
  GstElement* src = gst_bin_get_by_name(GST_BIN(p), "src");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  g_object_set(src, "caps", caps, nullptr);
  std::vector<GstSample*> out;
  const double t0 = cpu_seconds();
  gst_element_set_state(p, GST_STATE_PLAYING);
  size_t next = 0;
  GstBus* bus = gst_element_get_bus(p);
  for (;;) {
    // Feed a few ahead, take what came out, until the end.
    while (next < in.size() && gst_app_src_get_current_level_bytes(GST_APP_SRC(src)) < 20000000) {
      gst_app_src_push_buffer(GST_APP_SRC(src), gst_buffer_ref(in[next++]));
      if (next == in.size()) gst_app_src_end_of_stream(GST_APP_SRC(src));
    }
    if (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 10 * GST_MSECOND)) {
      if (keep)
        out.push_back(s);
      else
        gst_sample_unref(s);
      continue;
    }
    if (gst_app_sink_is_eos(GST_APP_SINK(sink))) break;
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      std::fprintf(stderr, "'%s' failed: %s\n", chain.c_str(), e ? e->message : "?");
      std::exit(1);
    }
  }
  if (cpu_s) *cpu_s = cpu_seconds() - t0;
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(src);
  gst_object_unref(sink);
  gst_object_unref(p);
  return out;
}

// The CPU per run of `chain` in service: its output is dropped as it comes. A run whose output is kept
// allocates fresh memory for every buffer, and the kernel's zeroing of those pages is charged to the chain (over
// 240 frames it doubled the server's figure), where a camera or server in service hands each buffer on and its
// memory is reused.
double chain_cpu_seconds(const std::string& chain, GstCaps* caps, const std::vector<GstBuffer*>& in) {
  double cpu_s = 0;
  run_chain(chain, caps, in, &cpu_s, false);
  return cpu_s;
}

struct LinkResult {
  double mbit = 0, enc_ms = 0, dec_ms = 0, psnr = 0, p99 = 0, max_err = 0;
  size_t frames = 0, beyond_bound = 0, holes_changed = 0;
};

double percentile(std::vector<uint16_t>* v, double q) {
  if (v->empty()) return 0;
  const size_t k = std::min(v->size() - 1, size_t(q * double(v->size())));
  std::nth_element(v->begin(), v->begin() + long(k), v->end());
  return (*v)[k];
}

LinkResult measure(const vclassroom_tools::Recording& rec, const std::string& camera_chain,
                   const std::string& server_chain, uint16_t tolerance, int fps, std::vector<Delivered>* delivered) {
  delivered->assign(rec.frames.size(), Delivered());
  LinkResult r;
  const double enc_s = chain_cpu_seconds(camera_chain, rec.caps, rec.frames);
  std::vector<GstSample*> rtp = run_chain(camera_chain, rec.caps, rec.frames);
  std::vector<GstBuffer*> packets;
  double wire_bytes = 0;
  for (GstSample* s : rtp) {
    packets.push_back(gst_sample_get_buffer(s));
    wire_bytes += double(gst_buffer_get_size(gst_sample_get_buffer(s)) + 28);
  }
  GstCaps* rtp_caps = gst_sample_get_caps(rtp.front());
  const double dec_s = chain_cpu_seconds(server_chain, rtp_caps, packets);
  std::vector<GstSample*> out = run_chain(server_chain, rtp_caps, packets);
  const double n = double(rec.frames.size());
  r.mbit = wire_bytes * 8 / (n / fps) / 1e6;
  r.enc_ms = 1000 * enc_s / n;
  r.dec_ms = 1000 * dec_s / n;
  r.frames = out.size();
  RgbdInfo ti;
  std::string err;
  rgbd_info_from_caps(rec.caps, &ti, &err);
  std::vector<uint16_t> errors;
  double psnr_sum = 0;
  size_t next = 0;  // outputs come in order; a dropped frame is skipped
  for (GstSample* s : out) {
    GstBuffer* b = gst_sample_get_buffer(s);
    RgbdInfo oi;
    rgbd_info_from_caps(gst_sample_get_caps(s), &oi, &err);
    RgbdFrame o, t;
    if (!o.map(b, oi, GST_MAP_READ, &err)) continue;
    // The frame it came from: of the next three not yet matched, the one whose depth it is nearest to (the
    // sensor's noise is drawn anew for every frame, so another frame's depth is far off).
    size_t i = next;
    double best = 1e300;
    for (size_t c = next; c < std::min(next + 3, rec.frames.size()); ++c) {
      RgbdFrame tc;
      if (!tc.map(rec.frames[c], ti, GST_MAP_READ, &err)) continue;
      const double d = cv::norm(tc.depth(), o.depth(), cv::NORM_L1);
      if (d < best) {
        best = d;
        i = c;
      }
    }
    next = i + 1;
    if (i >= rec.frames.size() || !t.map(rec.frames[i], ti, GST_MAP_READ, &err)) continue;
    psnr_sum += cv::PSNR(t.color(), o.color(), 255.0);
    (*delivered)[i] = Delivered{o.color().clone(), o.depth().clone()};
    const cv::Mat td = t.depth(), od = o.depth();
    for (int y = 0; y < td.rows; ++y)
      for (int x = 0; x < td.cols; ++x) {
        const uint16_t z = td.at<uint16_t>(y, x), c = od.at<uint16_t>(y, x);
        if ((z == 0) != (c == 0)) {
          ++r.holes_changed;
          continue;
        }
        if (!z) continue;
        const auto e = uint16_t(std::abs(int(z) - int(c)));
        errors.push_back(e);
        if (e > depth_error_bound(z, tolerance)) ++r.beyond_bound;
      }
  }
  r.psnr = out.empty() ? 0 : psnr_sum / double(out.size());
  r.max_err = errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end());
  r.p99 = percentile(&errors, 0.99);
  for (GstSample* s : rtp) gst_sample_unref(s);
  for (GstSample* s : out) gst_sample_unref(s);
  return r;
}

// The depth coder alone on one camera's frames (a key frame every `key_interval`): Mbit/s at `fps` and each
// side's thread CPU time per frame.
struct DepthAlone {
  double mbit = 0, enc_ms = 0, dec_ms = 0, holes_mbit = 0;
};

DepthAlone depth_alone(const std::vector<cv::Mat>& depths, const std::vector<cv::Mat>& labels, uint16_t tolerance,
                       int key_interval, int fps) {
  DepthLinkEncoder enc;
  DepthLinkDecoder dec;
  DepthAlone r;
  double bytes = 0, enc_s = 0, dec_s = 0;
  for (size_t i = 0; i < depths.size(); ++i) {
    std::vector<uint8_t> wire;
    const double t0 = thread_cpu_seconds();
    enc.encode(depths[i], labels.empty() ? cv::Mat() : labels[i], "", i % size_t(key_interval) == 0, tolerance,
               &wire);
    const double t1 = thread_cpu_seconds();
    DepthLinkFrame f;
    std::string err;
    if (!dec.decode(wire.data(), wire.size(), &f, &err)) std::fprintf(stderr, "depth alone: %s\n", err.c_str());
    dec_s += thread_cpu_seconds() - t1;
    enc_s += t1 - t0;
    bytes += double(wire.size());
  }
  // The holes' share: the same frames with every measured pixel at one depth (its values then cost next to
  // nothing), without labels.
  DepthLinkEncoder holes;
  double hole_bytes = 0;
  for (size_t i = 0; i < depths.size(); ++i) {
    std::vector<uint8_t> wire;
    cv::Mat flat(depths[i].size(), CV_16UC1, cv::Scalar(0));
    flat.setTo(2000, depths[i] != 0);
    holes.encode(flat, cv::Mat(), "", i % size_t(key_interval) == 0, tolerance, &wire);
    hole_bytes += double(wire.size());
  }
  const double n = double(depths.size());
  r.holes_mbit = hole_bytes * 8 * fps / n / 1e6;
  r.mbit = bytes * 8 * fps / n / 1e6;
  r.enc_ms = 1000 * enc_s / n;
  r.dec_ms = 1000 * dec_s / n;
  return r;
}

// The view of `virt` warped from each camera's frame and fused (viewwarp and viewfuse's library, as
// server.sh runs them without a model: no prior; without labels: every pixel in one layer).
cv::Mat render_view(const std::vector<CameraCalib>& cams, const std::vector<const Delivered*>& frames,
                    const CameraCalib& virt, cv::Mat* filled = nullptr) {
  std::vector<WarpedView> warped(cams.size());
  std::vector<const WarpedView*> ptrs;
  ViewWarper warper;
  for (size_t k = 0; k < cams.size(); ++k) {
    if (!frames[k] || frames[k]->color.empty()) continue;
    warper.warp(cams[k], WarpSource{frames[k]->color, frames[k]->depth, cv::Mat(), cv::Mat()}, virt, WarpParams(),
                &warped[k]);
    ptrs.push_back(&warped[k]);
  }
  FusedView fused;
  fuse_views(ptrs, FuseParams(), &fused);
  if (filled) *filled = fused.filled.clone();
  return fused.color;
}

// The view PSNR of each link (index 0: the uncoded frames) against the ground truth, and against the view
// from the uncoded frames, averaged over the poses.
struct ViewScores {
  std::vector<double> truth, direct;
  std::vector<double> seen;  // against the truth over the pixels the cameras saw in the uncoded frames' view
  double seen_share = 0;
  int poses = 0;
};

// `links[l][k][i]`: link l's frame i of camera k. A lecturer walking along a path beside the centre camera
// (sliders [40..60, 50, 55, 50, 50, 50]): pose j of `poses` at frame i_j spread over the sequence, the
// classroom rendered exactly from it at the frame's scene time (i / fps) as the ground truth.
ViewScores view_scores(const std::vector<std::vector<std::vector<Delivered>>>& links,
                       const std::vector<CameraCalib>& cams, int learners, int poses, int fps) {
  ViewScores s;
  s.truth.assign(links.size(), 0);
  s.direct.assign(links.size(), 0);
  s.seen.assign(links.size(), 0);
  const Classroom room(ClassroomConfig{1, learners, 2.0});
  ClassroomRenderer renderer;
  const size_t frames = links[0][0].size();
  for (int j = 0; j < poses; ++j) {
    const size_t i = frames * size_t(2 * j + 1) / size_t(2 * poses);
    Sliders sl = parse_sliders("[50,50,55,50,50,50]");
    sl[0] = 40 + 20.0 * j / std::max(1, poses - 1);
    const CameraCalib virt = virtual_camera(cams[0], sliders_to_pose(sl, cams[0]).cam_to_rig(), NAN);
    RenderOutput truth;
    renderer.render(room, double(i) / fps, virt, &truth);
    cv::Mat reference, seen;
    for (size_t l = 0; l < links.size(); ++l) {
      std::vector<const Delivered*> frame;
      for (const auto& cam : links[l]) frame.push_back(&cam[i]);
      cv::Mat filled;
      const cv::Mat view = render_view(cams, frame, virt, &filled);
      if (l == 0) {
        reference = view;
        seen = filled == 0;
        s.seen_share += double(cv::countNonZero(seen)) / double(seen.total()) / poses;
      }
      s.truth[l] += psnr_rgb(view, truth.color) / poses;
      s.seen[l] += psnr_rgb_masked(view, truth.color, seen) / poses;
      s.direct[l] += (l == 0 ? 99.0 : psnr_rgb(view, reference)) / poses;
    }
  }
  s.poses = poses;
  return s;
}

// The Redwood trajectory.log's camera-to-world poses (the importer's parser); [] when the file is unreadable.
std::vector<Eigen::Isometry3d> read_trajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream text;
  text << in.rdbuf();
  return parse_trajectory_log(text.str(), path);
}

// Redwood: the depth coder alone (lossless and within the bound), and the depth's share of the view PSNR
// loss: each frame warped (with its own colour, uncoded) to the next frame's pose with the coded and with
// the uncoded depth, against that next real frame (the ground truth the sequence has).
void redwood(const std::string& dir, uint16_t tolerance) {
  std::vector<cv::Mat> depths, colors;
  for (int i = 0; i < 5; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%05d", i);
    depths.push_back(read_depth_mm(dir + "/depth/" + name + ".png", 1.0));
    cv::Mat bgr = read_color_image(dir + "/color/" + name + ".jpg", "colour"), rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    colors.push_back(rgb);
  }
  const std::vector<Eigen::Isometry3d> traj = read_trajectory(dir + "/trajectory.log");
  const PosedSequenceIntrinsics k;  // Redwood's, as the importer takes them
  CameraCalib cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = k.fx, cam.fy = k.fy, cam.cx = k.cx, cam.cy = k.cy;
  std::vector<double> view_psnr;
  for (uint16_t tol : {uint16_t(0), tolerance}) {
    DepthLinkEncoder enc;
    DepthLinkDecoder dec;
    size_t bytes = 0, beyond = 0;
    std::vector<uint16_t> errors;
    double psnr = 0;
    for (size_t i = 0; i < depths.size(); ++i) {
      std::vector<uint8_t> wire;
      enc.encode(depths[i], cv::Mat(), "", i == 0, tol, &wire);
      bytes += wire.size();
      DepthLinkFrame f;
      std::string err;
      if (!dec.decode(wire.data(), wire.size(), &f, &err)) std::fprintf(stderr, "redwood: %s\n", err.c_str());
      for (int y = 0; y < f.depth.rows; ++y)
        for (int x = 0; x < f.depth.cols; ++x) {
          const uint16_t z = depths[i].at<uint16_t>(y, x), c = f.depth.at<uint16_t>(y, x);
          if (!z) continue;
          errors.push_back(uint16_t(std::abs(int(z) - int(c))));
          if (errors.back() > depth_error_bound(z, tol)) ++beyond;
        }
      if (i + 1 < depths.size() && traj.size() == depths.size()) {
        CameraCalib from = cam, to = cam;
        from.cam_to_rig = traj[i];
        to.cam_to_rig = traj[i + 1];
        const Delivered d{colors[i], f.depth};
        psnr += psnr_rgb(render_view({from}, {&d}, to), colors[i + 1]) / double(depths.size() - 1);
      }
    }
    view_psnr.push_back(psnr);
    std::printf("redwood depth, tolerance %.2f mm at 1 m: %.1f kB/frame (%.1f Mbit/s at 30 fps), error p99 %.0f mm, "
                "max %d mm, pixels beyond the bound %zu; each frame warped to the next's pose: %.2f dB against it\n",
                tol / 100.0, bytes / 1000.0 / double(depths.size()), bytes * 8.0 * 30 / double(depths.size()) / 1e6,
                percentile(&errors, 0.99), errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end()), beyond,
                psnr);
  }
  if (traj.size() == depths.size())
    std::printf("redwood: view PSNR loss from the depth coding %.2f dB (colour uncoded)\n", view_psnr[0] - view_psnr[1]);
}

// The camera and server chains of each link, and the tolerance the new one codes depth with.
struct Chains {
  std::string old_cam, old_srv, new_cam, new_srv;
  uint16_t tolerance;
};
// Each link's figures and the depth coder's alone, summed over the cameras as means.
struct Totals {
  LinkResult old_link, new_link;
  DepthAlone depth;
};

// Camera k recorded (`frames` frames, `learners` learners), its depth coder alone, both links measured; its
// delivered frames into delivered[link][k], its calibration into `calibs`. False when the recording failed.
bool measure_camera(int k, int cameras, int frames, int learners, const Chains& chains,
                    std::vector<std::vector<std::vector<Delivered>>>& delivered, std::vector<CameraCalib>* calibs,
                    Totals* totals) {
  const std::string &old_cam = chains.old_cam, &old_srv = chains.old_srv, &new_cam = chains.new_cam,
                    &new_srv = chains.new_srv;
  const uint16_t tol = chains.tolerance;
  LinkResult &sum_old = totals->old_link, &sum_new = totals->new_link;
  DepthAlone& depth_sum = totals->depth;
  vclassroom_tools::Recording rec;
  if (!vclassroom_tools::record_stream("rgbdtestsrc camera-id=" + std::to_string(k) + " seed=1 ground-truth=false "
                                       "learners=" + std::to_string(learners) + " num-buffers=" +
                                       std::to_string(frames), frames, &rec))
    return false;
  RgbdInfo info;
  std::string err;
  rgbd_info_from_caps(rec.caps, &info, &err);
  calibs->push_back(info.camera);
  std::vector<cv::Mat> depths, labels;
  for (GstBuffer* b : rec.frames) {
    RgbdFrame f;
    if (!f.map(b, info, GST_MAP_READ, &err)) return false;
    delivered[0][size_t(k)].push_back(Delivered{f.color().clone(), f.depth().clone()});
    depths.push_back(f.depth().clone());
    if (info.has(Plane::Label)) labels.push_back(f.label().clone());
  }
  if (k == 0) {  // the camera side's colour part alone: the same chain without rgbdlinkmux
    const std::string colour_only = new_cam.substr(0, new_cam.find(" ! rgbdlinkmux"));
    const double colour_s = chain_cpu_seconds(colour_only, rec.caps, rec.frames);
    std::printf("camera 0, the new link's colour alone (split, videoconvert, x264enc): %.1f ms per frame\n",
                1000 * colour_s / double(rec.frames.size()));
  }
  const DepthAlone d = depth_alone(depths, labels, tol, 60, 30);
  std::printf("camera %d, the depth coder alone (labels included): %.1f Mbit/s (the holes alone %.1f), encode %.1f "
              "ms, decode %.1f ms per frame (thread CPU)\n", k, d.mbit, d.holes_mbit, d.enc_ms, d.dec_ms);
  depth_sum.holes_mbit += d.holes_mbit / cameras;
  depth_sum.mbit += d.mbit / cameras;
  depth_sum.enc_ms += d.enc_ms / cameras;
  depth_sum.dec_ms += d.dec_ms / cameras;
  for (int link = 0; link < 2; ++link) {
    const LinkResult r = link == 0 ? measure(rec, old_cam, old_srv, 0, 30, &delivered[1][size_t(k)])
                                   : measure(rec, new_cam, new_srv, tol, 30, &delivered[2][size_t(k)]);
    std::printf("camera %d, %s: %zu/%d frames, %.1f Mbit/s, camera CPU %.1f ms/frame, server CPU %.1f ms/frame, "
                "colour PSNR %.2f dB, depth error p99 %.0f mm, max %.0f mm, beyond the bound %zu, holes changed %zu\n",
                k, link == 0 ? "old link (rgbdenc, rtpgstpay)" : "new link (H.264 + depth SEI, rtph264pay)",
                r.frames, frames, r.mbit, r.enc_ms, r.dec_ms, r.psnr, r.p99, r.max_err, r.beyond_bound,
                r.holes_changed);
    LinkResult& s = link == 0 ? sum_old : sum_new;
    s.mbit += r.mbit / cameras;
    s.enc_ms += r.enc_ms / cameras;
    s.dec_ms += r.dec_ms / cameras;
    s.psnr += r.psnr / cameras;
    s.p99 = std::max(s.p99, r.p99);
    s.beyond_bound += r.beyond_bound + r.holes_changed;
  }
  return true;
}
}  // namespace

int main(int argc, char** argv) {
  int frames = 60, cameras = 3, bitrate = 4000, learners = 3, poses = 8;
  double tolerance = kDefaultDepthTolerance / 100.0;
  gchar* redwood_dir = nullptr;
  gchar* colour = nullptr;
  gboolean view = FALSE;
  const GOptionEntry entries[] = {
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "frames per camera (default 60: 2 s at 30 fps)", "N"},
      {"cameras", 0, 0, G_OPTION_ARG_INT, &cameras, "synthetic cameras 0..N-1 (default 3)", "N"},
      {"learners", 0, 0, G_OPTION_ARG_INT, &learners, "learners in the classroom (default 3, rgbdtestsrc's and so "
       "classroom.sh's)", "N"},
      {"bitrate", 0, 0, G_OPTION_ARG_INT, &bitrate, "x264enc bitrate in kbit/s (default 4000, classroom.sh's)", "K"},
      {"colour", 0, 0, G_OPTION_ARG_STRING, &colour, "the colour's format on the new link: I420 (default, "
       "classroom.sh's) or Y444 (high-4:4:4, which avdec_h264 decodes as it does I420)", "FORMAT"},
      {"tolerance", 0, 0, G_OPTION_ARG_DOUBLE, &tolerance, "depth tolerance, mm at 1 m (default 2.8; 0: lossless)", "T"},
      {"redwood", 0, 0, G_OPTION_ARG_FILENAME, &redwood_dir, "also code the Redwood sequence's depth in DIR", "DIR"},
      {"view", 0, 0, G_OPTION_ARG_NONE, &view, "also render the lecturer's view from the cameras through each link and "
       "from the uncoded frames, against the ground truth (the view PSNR loss)", nullptr},
      {"poses", 0, 0, G_OPTION_ARG_INT, &poses, "poses along the lecturer's path for --view (default 8)", "N"},
      {}};
  vclassroom_tools::parse_command_line(
      &argc, &argv, "",
      "Sends each synthetic camera (960x540 at 30 fps, sensor model on, seed 1) through the old camera link and\n"
      "the new one and prints Mbit/s on the wire, CPU per frame, colour PSNR, depth error and the view PSNR loss.",
      entries, gst_init_get_option_group());
  const std::string format = colour ? colour : "I420";
  if (frames < 2 || cameras < 1 || cameras > 3 || bitrate < 100 || tolerance < 0 || tolerance > 655 ||
      learners < 0 || learners > kClassroomMaxLearners || poses < 1 || poses > frames ||
      (format != "I420" && format != "Y444"))
    vclassroom_tools::usage_error("--frames >= 2, --cameras 1 to 3, --bitrate >= 100, --tolerance 0 to 655, "
                                  "--learners 0 to the classroom's most, --poses 1 to --frames, --colour I420 or Y444");
  const auto tol = uint16_t(std::lround(tolerance * 100));
  char tol_text[32];
  std::snprintf(tol_text, sizeof tol_text, "%.2f", tolerance);
  const std::string old_cam = "rgbdenc quality=90 ! rtpgstpay config-interval=1 mtu=1400 pt=96";
  const std::string old_srv = "rtpgstdepay ! rgbddec";
  vclassroom_tools::CameraLinkCoding coding;
  coding.bitrate_kbps = bitrate;
  coding.tolerance = tol_text;
  coding.format = format;
  const std::string new_cam = vclassroom_tools::camera_link_coder(coding) + " ! rtph264pay mtu=1400 pt=96";
  // The decoder as server.sh runs it (FFmpeg's, one thread; it also decodes the 4:4:4 of --colour Y444).
  const std::string new_srv = "rtph264depay ! " + vclassroom_tools::camera_link_decoder();
  Totals totals;
  // [link: uncoded, old, new][camera][frame]
  std::vector<std::vector<std::vector<Delivered>>> delivered(3, std::vector<std::vector<Delivered>>(size_t(cameras)));
  std::vector<CameraCalib> calibs;
  for (int k = 0; k < cameras; ++k)
    if (!measure_camera(k, cameras, frames, learners, Chains{old_cam, old_srv, new_cam, new_srv, tol}, delivered,
                        &calibs, &totals))
      return 1;
  const LinkResult &sum_old = totals.old_link, &sum_new = totals.new_link;
  const DepthAlone& depth_sum = totals.depth;
  std::printf("depth coder alone: %.1f Mbit/s per camera (the holes alone %.1f), encode %.1f ms, decode %.1f ms per "
              "frame\n", depth_sum.mbit, depth_sum.holes_mbit, depth_sum.enc_ms, depth_sum.dec_ms);
  if (redwood_dir) redwood(redwood_dir, tol);
  std::printf("old link: %.1f Mbit/s per camera, camera %.1f ms, server %.1f ms per frame, colour PSNR %.2f dB\n",
              sum_old.mbit, sum_old.enc_ms, sum_old.dec_ms, sum_old.psnr);
  std::printf("new link: %.1f Mbit/s per camera, camera %.1f ms, server %.1f ms per frame, colour PSNR %.2f dB, "
              "depth error p99 %.0f mm, %zu pixels beyond the bound\n", sum_new.mbit, sum_new.enc_ms, sum_new.dec_ms,
              sum_new.psnr, sum_new.p99, sum_new.beyond_bound);
  if (view) {
    const ViewScores v = view_scores(delivered, calibs, learners, poses, 30);
    std::printf("view, %d poses along the path, PSNR against the ground truth: uncoded frames %.2f dB, old link "
                "%.2f dB, new link %.2f dB; against the view from the uncoded frames: old %.2f dB, new %.2f dB\n",
                v.poses, v.truth[0], v.truth[1], v.truth[2], v.direct[1], v.direct[2]);
    std::printf("view over the %.0f %% of pixels the cameras saw (not hole-filled): uncoded frames %.2f dB, old link %.2f "
                "dB, new link %.2f dB: PSNR loss old %.2f dB, new %.2f dB\n", 100 * v.seen_share, v.seen[0], v.seen[1],
                v.seen[2], v.seen[0] - v.seen[1], v.seen[0] - v.seen[2]);
    std::printf("old link: view PSNR loss %.2f dB\n", v.truth[0] - v.truth[1]);
    std::printf("camera link: %.1f Mbit/s per camera, view PSNR loss %.2f dB, depth error p99 %.0f mm\n", sum_new.mbit,
                v.truth[0] - v.truth[2], sum_new.p99);
  }
  g_free(redwood_dir);
  g_free(colour);
  return sum_new.beyond_bound == 0 ? 0 : 1;
}
