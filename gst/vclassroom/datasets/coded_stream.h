// A camera's live recording: <dataset>/cam<ID>/stream.vcrs holds the frames
// exactly as rgbdenc codes them (vcrd1, docs/network.md) with their running
// times, so several cameras are recorded at full rate (the coding is what a
// camera's sender does anyway) and play back at their original timing
// (docs/dataset-format.md, "Live recordings").
//
// File (little-endian): "VCRS", u32 version (1), u32 flags (bit 0: frames
// carry a label plane); then one record per frame: u32 frame length, u64
// running time in ns, u32 CRC-32 of those 12 bytes, then the frame. A
// recording cut short (the recorder was killed) keeps every whole record
// before the cut.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace vclassroom {

inline constexpr const char* kCodedStreamFile = "stream.vcrs";
inline constexpr uint32_t kCodedStreamVersion = 1;
inline constexpr uint32_t kCodedStreamHasLabel = 1u << 0;
inline constexpr size_t kCodedStreamHeaderSize = 12;
inline constexpr size_t kCodedRecordHeaderSize = 16;
// No coded frame of a camera of at most 16384² pixels comes near this; a
// record declaring more is damage.
inline constexpr uint32_t kMaxCodedFrameBytes = 1u << 28;

// Appends records to a new stream file. Throws Error naming the file when it
// cannot be created or written.
class CodedStreamWriter {
 public:
  CodedStreamWriter(const std::string& path, uint32_t flags);
  ~CodedStreamWriter();
  CodedStreamWriter(const CodedStreamWriter&) = delete;
  CodedStreamWriter& operator=(const CodedStreamWriter&) = delete;
  void write(uint64_t time_ns, const uint8_t* frame, size_t size);
  // Hands what is written to the kernel, so a recorder killed later loses nothing before this.
  void flush();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  FILE* file_ = nullptr;
};

struct CodedStreamIndex {
  struct Frame {
    uint64_t offset = 0;  // of the frame's bytes in the file
    uint32_t size = 0;
    uint64_t time_ns = 0;
  };
  uint32_t flags = 0;
  std::vector<Frame> frames;
  // Why the records stopped before the end of the file ("" when they did
  // not): a cut-off or damaged record; what follows it is not played.
  std::string tail_problem;
};

// Reads `size` bytes at `offset`; false when they are not all there.
using ReadAt = std::function<bool(uint64_t offset, uint8_t* out, size_t size)>;

// Indexes a stream of `total` bytes from its record headers alone (frames are
// not read). A wrong file header, a version this reader does not know or more
// than `max_frames` records is an Error naming `name`; a damaged or cut-off
// record ends the index (tail_problem), as does a time running backwards.
CodedStreamIndex index_coded_stream(const ReadAt& read, uint64_t total, const std::string& name,
                                    size_t max_frames);
// The same for a file.
CodedStreamIndex index_coded_stream_file(const std::string& path, size_t max_frames);
// One frame's bytes from the file. Throws Error naming the file.
std::vector<uint8_t> read_coded_frame(const std::string& path, const CodedStreamIndex::Frame& frame);

}  // namespace vclassroom
