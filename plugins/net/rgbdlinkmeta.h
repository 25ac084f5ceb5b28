// What the camera link's four elements hand each other on a buffer (docs/network.md, "The H.264 camera
// link"): a GstMeta that rides a colour frame through videoconvert and the H.264 encoder or decoder, which
// copy metas without tags to their output frame. On the camera (rgbdlinksplit -> rgbdlinkmux) it holds the
// whole video/x-rgbd frame in `planes`; on the server (rgbdlinkdemux -> rgbdlinkjoin) the backlog's id of the
// depth frame that came with the picture and the backlog that holds it until rgbdlinkjoin decodes it
// (depth_link_backlog.h says why there). Either way `caps` are that frame's video/x-rgbd caps and `pts` the
// timestamp of the buffer it was attached to.
#pragma once

#include <gst/gst.h>

#include <memory>

#include <gst/vclassroom/net/depth_link_backlog.h>

struct GstRgbdLinkMeta {
  GstMeta meta;
  GstBuffer* planes;  // the camera's side, else nullptr
  std::shared_ptr<vclassroom::DepthLinkBacklog>* backlog;  // the server's side, else nullptr
  guint64 id;  // the depth frame's, in `backlog`
  GstCaps* caps;
  GstClockTime pts;
};

GType gst_rgbd_link_meta_api_get_type();
// Adds the meta, taking a reference to `planes` and `caps`.
GstRgbdLinkMeta* gst_buffer_add_rgbd_link_meta(GstBuffer* buffer, GstBuffer* planes, GstCaps* caps);
// Adds the meta for depth frame `id` in `backlog`, sharing `backlog` and taking a reference to `caps`.
GstRgbdLinkMeta* gst_buffer_add_rgbd_link_backlog_meta(GstBuffer* buffer,
                                                       const std::shared_ptr<vclassroom::DepthLinkBacklog>& backlog,
                                                       guint64 id, GstCaps* caps);
GstRgbdLinkMeta* gst_buffer_get_rgbd_link_meta(GstBuffer* buffer);
