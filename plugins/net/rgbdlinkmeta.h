// What the camera link's four elements hand each other on a buffer (docs/network.md, "The H.264 camera
// link"): a GstMeta that rides a colour frame through videoconvert and the H.264 encoder or decoder, which
// copy metas without tags to their output frame. On the camera (rgbdlinksplit -> rgbdlinkmux) it holds the
// whole video/x-rgbd frame; on the server (rgbdlinkdemux -> rgbdlinkjoin) the decoded depth (GRAY16_LE,
// stride 2 x width) followed by the labels (GRAY8, stride width) when the caps name them. Either way `caps`
// are that frame's video/x-rgbd caps and `pts` the timestamp of the buffer it was attached to.
#pragma once

#include <gst/gst.h>

struct GstRgbdLinkMeta {
  GstMeta meta;
  GstBuffer* planes;
  GstCaps* caps;
  GstClockTime pts;
};

GType gst_rgbd_link_meta_api_get_type();
// Adds the meta, taking a reference to `planes` and `caps`.
GstRgbdLinkMeta* gst_buffer_add_rgbd_link_meta(GstBuffer* buffer, GstBuffer* planes, GstCaps* caps);
GstRgbdLinkMeta* gst_buffer_get_rgbd_link_meta(GstBuffer* buffer);
