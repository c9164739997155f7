// Writes the vocabulary fuzzer's seed corpus: tiny valid binary and text vocabulary files, each
// prefixed with the byte that selects the reader (see vocabulary_file_fuzzer.cpp).
//   fuzz_seed_writer fuzz/corpus/vocabulary_file
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "vocabulary/vocabulary_file.h"

namespace fs = std::filesystem;

namespace {

void writeSeed(const fs::path& dir, const std::string& name, char mode, const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir / name, std::ios::binary) << mode << bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const fs::path dir = argv[1];
  fs::create_directories(dir);
  placedb::vocab::VocabularyData data;
  data.extractor = "surf-seed";
  data.dim = 4;
  data.settings = {{"kd_trees", "4"}};
  data.ids = {1, 5, 9};
  data.created_frames = {0, 0, 3};
  data.descriptors =
      (cv::Mat_<float>(3, 4) << 0.5f, 0.5f, 0.5f, 0.5f, 1, 0, 0, 0, 0, 0.6f, 0.8f, 0);
  const fs::path scratch = fs::temp_directory_path() / "placedb-seed.pvoc";
  placedb::vocab::writeVocabularyFile(scratch, data);
  writeSeed(dir, "binary_raw", '\0', scratch);
  writeSeed(dir, "binary_fixed_crc", '\1', scratch);
  placedb::vocab::writeVocabularyText(scratch, data);
  writeSeed(dir, "text", '\2', scratch);
  placedb::vocab::VocabularyData empty = data;
  empty.ids.clear();
  empty.created_frames.clear();
  empty.descriptors = cv::Mat(0, 4, CV_32F);
  placedb::vocab::writeVocabularyFile(scratch, empty);
  writeSeed(dir, "binary_empty", '\1', scratch);
  fs::remove(scratch);
  return 0;
}
