/**
 * SECTION:element-rtphdrextvcpose
 * @title: rtphdrextvcpose
 *
 * Carries the seq and viewer time of the lecturer pose a frame was rendered for
 * (urn:gst-vclassroom:rtp-hdrext:pose), for motion-to-photon latency, and that pose as rendered, after the
 * server's navigation bounds; payloaders and depayloaders enable it from an extmap-N caps field.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=300 ! jpegenc ! rtpgstpay ! "application/x-rtp,extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose" ! rtpgstdepay ! jpegdec ! videoconvert ! fakesink
 * ]|
 */
// The wire form is the library's (net/pose_stamp.h): 48 bytes with the pose, 16 without.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrtphdrextvcpose.h"

#include <gst/vclassroom/core/pose_meta.h>
#include <gst/vclassroom/net/pose_stamp.h>

using namespace vclassroom;

struct _GstRTPHeaderExtensionVcPose {
  GstRTPHeaderExtension parent;
};

G_DEFINE_TYPE(GstRTPHeaderExtensionVcPose, gst_rtp_header_extension_vc_pose, GST_TYPE_RTP_HEADER_EXTENSION)
GST_ELEMENT_REGISTER_DEFINE(rtphdrextvcpose, "rtphdrextvcpose", GST_RANK_MARGINAL, GST_TYPE_RTP_HEADER_EXTENSION_VC_POSE)

static GstRTPHeaderExtensionFlags get_supported_flags(GstRTPHeaderExtension*) {
  return GstRTPHeaderExtensionFlags(GST_RTP_HEADER_EXTENSION_ONE_BYTE | GST_RTP_HEADER_EXTENSION_TWO_BYTE);
}

// Over 16 bytes: the payloader then uses RFC 8285's two-byte header.
static gsize get_max_size(GstRTPHeaderExtension*, const GstBuffer*) { return kPoseStampWithPoseSize; }

static gssize write_ext(GstRTPHeaderExtension*, const GstBuffer* input, GstRTPHeaderExtensionFlags, GstBuffer*,
                        guint8* data, gsize size) {
  const PoseMeta* meta = buffer_get_pose_meta(const_cast<GstBuffer*>(input));
  if (!meta) return 0;  // a frame rendered before any pose: nothing to say
  const size_t written = pose_stamp_to_wire(PoseStamp{meta->seq, meta->viewer_time_ns, meta->rendered}, data, size);
  return written ? gssize(written) : -1;
}

static gboolean read_ext(GstRTPHeaderExtension*, GstRTPHeaderExtensionFlags, const guint8* data, gsize size,
                         GstBuffer* buffer) {
  PoseStamp stamp;
  if (!pose_stamp_from_wire(data, size, &stamp)) return FALSE;
  buffer_add_pose_meta(buffer, stamp.seq, stamp.viewer_time_ns, stamp.rendered);
  return TRUE;
}

static void gst_rtp_header_extension_vc_pose_class_init(GstRTPHeaderExtensionVcPoseClass* klass) {
  GstRTPHeaderExtensionClass* ext_class = GST_RTP_HEADER_EXTENSION_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  ext_class->get_supported_flags = get_supported_flags;
  ext_class->get_max_size = get_max_size;
  ext_class->write = write_ext;
  ext_class->read = read_ext;
  gst_element_class_set_static_metadata(element_class, "vclassroom pose RTP header extension", GST_RTP_HDREXT_ELEMENT_CLASS,
      "Carries the pose a video frame was rendered for in an RTP header extension", "gst-vclassroom developers");
  gst_rtp_header_extension_class_set_uri(ext_class, VCLASSROOM_RTP_HDREXT_POSE_URI);
}

static void gst_rtp_header_extension_vc_pose_init(GstRTPHeaderExtensionVcPose*) {}
