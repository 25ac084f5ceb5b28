#include <gst/vclassroom/datasets/coded_stream.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <glib.h>

#include <gst/vclassroom/core/checksum.h>
#include <gst/vclassroom/core/error.h>

namespace vclassroom {

namespace {

constexpr char kMagic[4] = {'V', 'C', 'R', 'S'};

// Fields are copied byte-wise (memcpy), never loaded through a cast pointer:
// record headers sit at any offset.
template <typename T>
T load_le(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return sizeof(T) == 4 ? T(GUINT32_FROM_LE(v)) : T(GUINT64_FROM_LE(v));
}

template <typename T>
void store_le(uint8_t* p, T v) {
  v = sizeof(T) == 4 ? T(GUINT32_TO_LE(v)) : T(GUINT64_TO_LE(v));
  std::memcpy(p, &v, sizeof v);
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

CodedStreamWriter::CodedStreamWriter(const std::string& path, uint32_t flags) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw Error(path + ": cannot create recording (" + errno_text() + ")");
  uint8_t header[kCodedStreamHeaderSize];
  std::memcpy(header, kMagic, 4);
  store_le<uint32_t>(header + 4, kCodedStreamVersion);
  store_le<uint32_t>(header + 8, flags);
  if (std::fwrite(header, 1, sizeof header, file_) != sizeof header) {
    const std::string why = errno_text();
    std::fclose(file_);
    file_ = nullptr;
    throw Error(path + ": cannot write recording (" + why + ")");
  }
}

CodedStreamWriter::~CodedStreamWriter() {
  if (file_) std::fclose(file_);
}

void CodedStreamWriter::write(uint64_t time_ns, const uint8_t* frame, size_t size) {
  if (size == 0 || size > kMaxCodedFrameBytes)
    throw Error(path_ + ": a coded frame of " + std::to_string(size) + " bytes cannot be recorded (1.." +
                std::to_string(kMaxCodedFrameBytes) + ")");
  uint8_t header[kCodedRecordHeaderSize];
  store_le<uint32_t>(header, static_cast<uint32_t>(size));
  store_le<uint64_t>(header + 4, time_ns);
  store_le<uint32_t>(header + 12, crc32(header, 12));
  if (std::fwrite(header, 1, sizeof header, file_) != sizeof header || std::fwrite(frame, 1, size, file_) != size)
    throw Error(path_ + ": cannot write recording (" + errno_text() + ")");
}

void CodedStreamWriter::flush() {
  if (std::fflush(file_) != 0) throw Error(path_ + ": cannot write recording (" + errno_text() + ")");
}

CodedStreamIndex index_coded_stream(const ReadAt& read, uint64_t total, const std::string& name,
                                    size_t max_frames) {
  uint8_t header[kCodedStreamHeaderSize];
  if (total < sizeof header || !read(0, header, sizeof header) || std::memcmp(header, kMagic, 4) != 0)
    throw Error(name + ": not a coded recording (expected the \"VCRS\" header of rgbdfilesink)");
  const uint32_t version = load_le<uint32_t>(header + 4);
  if (version != kCodedStreamVersion)
    throw Error(name + ": coded recording version " + std::to_string(version) + " (this reader knows version " +
                std::to_string(kCodedStreamVersion) + ")");
  CodedStreamIndex index;
  index.flags = load_le<uint32_t>(header + 8);
  uint64_t at = sizeof header;
  while (at < total) {
    const std::string where = "record " + std::to_string(index.frames.size()) + " at byte " + std::to_string(at);
    uint8_t record[kCodedRecordHeaderSize];
    if (total - at < sizeof record || !read(at, record, sizeof record)) {
      index.tail_problem = where + " is cut off";
      break;
    }
    if (load_le<uint32_t>(record + 12) != crc32(record, 12)) {
      index.tail_problem = where + " is damaged (header checksum)";
      break;
    }
    CodedStreamIndex::Frame frame;
    frame.size = load_le<uint32_t>(record);
    frame.time_ns = load_le<uint64_t>(record + 4);
    frame.offset = at + sizeof record;
    if (frame.size == 0 || frame.size > kMaxCodedFrameBytes) {
      index.tail_problem = where + " declares a frame of " + std::to_string(frame.size) + " bytes";
      break;
    }
    if (frame.size > total - frame.offset) {
      index.tail_problem = where + " is cut off";
      break;
    }
    if (!index.frames.empty() && frame.time_ns < index.frames.back().time_ns) {
      index.tail_problem = where + " goes back in time";
      break;
    }
    if (index.frames.size() >= max_frames)
      throw Error(name + ": more than " + std::to_string(max_frames) + " frames");
    index.frames.push_back(frame);
    at = frame.offset + frame.size;
  }
  return index;
}

CodedStreamIndex index_coded_stream_file(const std::string& path, size_t max_frames) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(path + ": cannot open recording (" + errno_text() + ")");
  std::error_code ec;
  const uintmax_t total = std::filesystem::file_size(path, ec);
  auto read = [f](uint64_t offset, uint8_t* out, size_t size) {
    return fseeko(f, static_cast<off_t>(offset), SEEK_SET) == 0 && std::fread(out, 1, size, f) == size;
  };
  try {
    CodedStreamIndex index = index_coded_stream(read, ec ? 0 : total, path, max_frames);
    std::fclose(f);
    return index;
  } catch (...) {
    std::fclose(f);
    throw;
  }
}

std::vector<uint8_t> read_coded_frame(const std::string& path, const CodedStreamIndex::Frame& frame) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(path + ": cannot open recording (" + errno_text() + ")");
  std::vector<uint8_t> data(frame.size);
  const bool ok = fseeko(f, static_cast<off_t>(frame.offset), SEEK_SET) == 0 &&
                  std::fread(data.data(), 1, data.size(), f) == data.size();
  std::fclose(f);
  if (!ok) throw Error(path + ": cannot read the frame at byte " + std::to_string(frame.offset));
  return data;
}

}  // namespace vclassroom
