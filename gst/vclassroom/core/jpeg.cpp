#include <gst/vclassroom/core/jpeg.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

#include <jpeglib.h>

namespace vclassroom {

namespace {

// libjpeg reports errors through a callback that must not return.
struct JpegError {
  jpeg_error_mgr mgr;
  jmp_buf jump;
  int warnings = 0;
  char message[JMSG_LENGTH_MAX] = {0};
};

void jpeg_fail(j_common_ptr cinfo) {
  auto* err = reinterpret_cast<JpegError*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, err->message);
  longjmp(err->jump, 1);
}

void jpeg_note(j_common_ptr cinfo, int level) {
  auto* err = reinterpret_cast<JpegError*>(cinfo->err);
  if (level < 0) {  // corrupt-data warnings
    if (!err->warnings) (*cinfo->err->format_message)(cinfo, err->message);
    err->warnings++;
  }
}

}  // namespace

void encode_jpeg(const cv::Mat& rgb, int quality, std::vector<uint8_t>* out, JpegChroma chroma) {
  CV_Assert(rgb.type() == CV_8UC3);
  jpeg_compress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpeg_fail;
  unsigned char* mem = nullptr;
  unsigned long mem_size = 0;
  if (setjmp(err.jump)) {
    jpeg_destroy_compress(&cinfo);
    free(mem);
    throw std::runtime_error(std::string("JPEG encoder: ") + err.message);
  }
  jpeg_create_compress(&cinfo);
  jpeg_mem_dest(&cinfo, &mem, &mem_size);
  cinfo.image_width = static_cast<JDIMENSION>(rgb.cols);
  cinfo.image_height = static_cast<JDIMENSION>(rgb.rows);
  cinfo.input_components = 3;
  cinfo.in_color_space = JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  // At high quality, halving the chroma costs more than the bits it saves:
  // the classroom's textures and the view synthesis downstream need the colour edges.
  if (chroma == JpegChroma::kUvc422) {
    cinfo.comp_info[0].h_samp_factor = 2;
    cinfo.comp_info[0].v_samp_factor = 1;
    for (int c = 1; c < 3; ++c) cinfo.comp_info[c].h_samp_factor = cinfo.comp_info[c].v_samp_factor = 1;
  } else if (quality >= 90) {
    for (int c = 0; c < 3; ++c) cinfo.comp_info[c].h_samp_factor = cinfo.comp_info[c].v_samp_factor = 1;
  }
  cinfo.dct_method = JDCT_ISLOW;
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(rgb.ptr<uint8_t>(static_cast<int>(cinfo.next_scanline)));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  out->assign(mem, mem + mem_size);
  free(mem);
}

bool decode_jpeg(const uint8_t* data, size_t size, int width, int height, cv::Mat* rgb, std::string* error) {
  jpeg_decompress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpeg_fail;
  err.mgr.emit_message = jpeg_note;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&cinfo);
    if (error) *error = std::string("JPEG: ") + err.message;
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, data, static_cast<unsigned long>(size));
  if (jpeg_read_header(&cinfo, TRUE) != JPEG_HEADER_OK) {
    jpeg_destroy_decompress(&cinfo);
    if (error) *error = "JPEG: no image in the colour section";
    return false;
  }
  // Checked before jpeg_start_decompress, which allocates for the declared
  // size: a few bytes may declare 65535x65535. Only what encode_jpeg writes is
  // accepted (3 components, sequential): a progressive stream could make the
  // decoder spend seconds on a thousand scans.
  if (cinfo.image_width != static_cast<JDIMENSION>(width) || cinfo.image_height != static_cast<JDIMENSION>(height)) {
    jpeg_destroy_decompress(&cinfo);
    if (error)
      *error = "JPEG: image is " + std::to_string(cinfo.image_width) + "x" + std::to_string(cinfo.image_height) +
               ", the stream's " + std::to_string(width) + "x" + std::to_string(height);
    return false;
  }
  if (cinfo.num_components != 3 || cinfo.progressive_mode || cinfo.arith_code) {
    jpeg_destroy_decompress(&cinfo);
    if (error) *error = "JPEG: not a 3-component sequential Huffman JPEG (as rgbdenc writes)";
    return false;
  }
  cinfo.out_color_space = JCS_RGB;
  cinfo.dct_method = JDCT_ISLOW;
  jpeg_start_decompress(&cinfo);
  if (static_cast<int>(cinfo.output_width) != width || static_cast<int>(cinfo.output_height) != height ||
      cinfo.output_components != 3) {
    jpeg_destroy_decompress(&cinfo);
    if (error) *error = "JPEG: image size differs from the stream's";
    return false;
  }
  rgb->create(height, width, CV_8UC3);
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = rgb->ptr<uint8_t>(static_cast<int>(cinfo.output_scanline));
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  if (err.warnings) {
    if (error) *error = std::string("JPEG: corrupt data (") + err.message + ")";
    return false;
  }
  return true;
}

}  // namespace vclassroom
