// Regression replay of the fuzzing corpus (tests/fuzz/corpus/<target>/): every
// file of every target's corpus runs through every target, built with this
// build's compiler and flags. A crash or a sanitizer report (in a sanitizer
// build) ends the program; an exception escaping a target fails its test,
// naming the file. The corpus keeps every input that once crashed or hung a
// reader (docs/development.md, "Fuzzing").
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace fs = std::filesystem;

#define VCLASSROOM_FUZZ_TARGETS(X) X(rgbd_frame) X(depth_link) X(pose_wire) X(pose_hdrext) X(rig) X(dataset) X(posed_sequence) X(whep) \
  X(whep_http_head) X(whep_offer)

#define DECLARE_TARGET(name) extern "C" int vclassroom_fuzz_##name(const uint8_t* data, size_t size);
VCLASSROOM_FUZZ_TARGETS(DECLARE_TARGET)

namespace {

fs::path corpus_root() {
  const char* src = std::getenv("VCLASSROOM_SOURCE_DIR");
  return fs::path(src ? src : ".") / "tests" / "fuzz" / "corpus";
}

// Every corpus file, sorted, so failures name the same file each run.
std::vector<fs::path> corpus_files() {
  std::vector<fs::path> files;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(corpus_root(), ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file()) files.push_back(it->path());
  std::sort(files.begin(), files.end());
  return files;
}

void replay(const std::string& target, int (*run)(const uint8_t*, size_t)) {
  const std::vector<fs::path> files = corpus_files();
  ASSERT_GE(files.size(), 20u) << "the fuzzing corpus is missing from " << corpus_root();
  size_t own = 0;
  for (const fs::path& file : files) {
    std::ifstream in(file, std::ios::binary);
    ASSERT_TRUE(in) << file;
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (file.parent_path().filename() == target) ++own;
    try {
      EXPECT_EQ(run(bytes.data(), bytes.size()), 0) << file;
    } catch (const std::exception& e) {
      ADD_FAILURE() << target << ": " << file << ": an exception escaped: " << e.what();
    } catch (...) {
      ADD_FAILURE() << target << ": " << file << ": an unknown exception escaped";
    }
  }
  EXPECT_GE(own, 3u) << "target " << target << " has too few seeds of its own";
  ::testing::Test::RecordProperty("inputs", static_cast<int>(files.size()));
  std::printf("fuzz corpus: %s: %zu inputs (%zu of its own)\n", target.c_str(), files.size(), own);
}

}  // namespace

#define REPLAY_TEST(name) \
  TEST(FuzzCorpus, name) { replay(#name, vclassroom_fuzz_##name); }
VCLASSROOM_FUZZ_TARGETS(REPLAY_TEST)
