#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_SRTP_FILE_DEC (gst_srtp_file_dec_get_type())
G_DECLARE_FINAL_TYPE(GstSrtpFileDec, gst_srtp_file_dec, GST, SRTP_FILE_DEC, GstBin)

GST_ELEMENT_REGISTER_DECLARE(srtpfiledec);

G_END_DECLS
