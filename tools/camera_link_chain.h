// The H.264 camera link's coding as pipelines/classroom.sh runs it (LINK=h264, docs/network.md), for the
// programs and tests that run it in-process instead of through the script: one description, so that they
// measure and test what a camera sends.
#pragma once

#include <string>

namespace vclassroom_tools {

struct CameraLinkCoding {
  int key_interval = 60;        // classroom.sh's KEY_INTERVAL: x264enc's key-int-max and rgbdlinkmux's key-interval
  int bitrate_kbps = 4000;      // BITRATE
  std::string tolerance = "2.8";  // DEPTH_TOLERANCE, mm at 1 m
  std::string format = "I420";    // the colour: I420 (classroom.sh's) or Y444 (high-4:4:4)
};

// From the camera's video/x-rgbd frames to the H.264 access units with their depth (before the payloader).
inline std::string camera_link_coder(const CameraLinkCoding& c = {}) {
  const bool y444 = c.format == "Y444";
  return std::string("rgbdlinksplit") + (y444 ? " format=RGB" : "") + " ! videoconvert ! video/x-raw,format=" +
         c.format + " ! x264enc tune=zerolatency speed-preset=ultrafast threads=1 key-int-max=" +
         std::to_string(c.key_interval) + " bitrate=" + std::to_string(c.bitrate_kbps) +
         " ! video/x-h264,profile=" + (y444 ? "high-4:4:4" : "constrained-baseline") +
         " ! rgbdlinkmux depth-tolerance=" + c.tolerance + " key-interval=" + std::to_string(c.key_interval);
}

// What a replayed camera of the link `link` (classroom.sh's LINK: h264 or vcrd1) sends, up to its payloader, as
// classroom.sh runs it with its defaults (the H.264 link's key frames every 60 frames, so a recording of 60 frames
// loops from a key frame), and its payloader (without mtu).
inline std::string camera_link_replay_coder(const std::string& link) {
  return link == "h264" ? camera_link_coder() : "rgbdenc quality=90";
}
inline std::string camera_link_replay_payloader(const std::string& link) {
  return link == "h264" ? "rtph264pay" : "rtpgstpay config-interval=1";
}

// pipelines/server.sh's decoding of those access units (after rtph264depay) back to video/x-rgbd frames, without
// its leaky queue.
inline std::string camera_link_decoder() {
  return "rgbdlinkdemux ! avdec_h264 max-threads=1 ! videoconvert ! rgbdlinkjoin";
}

}  // namespace vclassroom_tools
