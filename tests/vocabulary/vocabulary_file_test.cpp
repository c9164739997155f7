// The vocabulary file: round trip, byte-identical rewrites, and every refusal as a typed error.
#include <gtest/gtest.h>

#include <boost/crc.hpp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>

#include "error_code.h"
#include "file_bytes.h"
#include "placedb/error.h"
#include "rtabmap_dictionary_loader.h"
#include "test_paths.h"
#include "vocabulary/vocabulary_file.h"

namespace placedb::vocab {
namespace {

namespace fs = std::filesystem;

using placedb::testing::codeOf;
using placedb::testing::readBytes;
using placedb::testing::writeBytes;

// A small vocabulary grown by quantisation, so ids, frames and settings are all non-trivial.
VocabularyData sampleData(int dim = 8) {
  VocabularyOptions o;
  o.t_nd2 = 0.02f;
  Vocabulary v(o, dim, "surf-test-v1");
  std::mt19937 rng(3);
  std::normal_distribution<float> gauss(0.f, 1.f);
  for (int frame = 0; frame < 4; ++frame) {
    cv::Mat image(30, dim, CV_32F);
    for (int i = 0; i < image.rows; ++i) {
      for (int d = 0; d < dim; ++d) image.at<float>(i, d) = gauss(rng);
      cv::normalize(image.row(i), image.row(i));
    }
    v.quantize(image, 100 + frame);
  }
  v.erase({1, 2});
  return snapshotOf(v);
}

void expectSameData(const VocabularyData& a, const VocabularyData& b) {
  EXPECT_EQ(a.extractor, b.extractor);
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.dim, b.dim);
  EXPECT_EQ(a.unit, b.unit);
  EXPECT_EQ(a.settings, b.settings);
  EXPECT_EQ(a.ids, b.ids);
  EXPECT_EQ(a.created_frames, b.created_frames);
  ASSERT_EQ(a.descriptors.size(), b.descriptors.size());
  EXPECT_EQ(std::memcmp(a.descriptors.data, b.descriptors.data, a.descriptors.total() * 4), 0);
}

class VocabularyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::scratchDir("vocabulary_file");
    data_ = sampleData();
    path_ = dir_ / "words.pvoc";
    writeVocabularyFile(path_, data_);
    bytes_ = readBytes(path_);
  }
  // Writes `bytes` to a new file and returns the refusal message (fails if not refused).
  std::string refusal(const std::string& bytes, VocabularyExpectation expect = {}) {
    const fs::path damaged = dir_ / "damaged.pvoc";
    writeBytes(damaged, bytes);
    std::string message;
    EXPECT_EQ(codeOf([&] { readVocabularyFile(damaged, expect); }, &message),
              ErrorCode::kVocabularyRefused)
        << "size " << bytes.size();
    EXPECT_NE(message.find(damaged.string()), std::string::npos) << message;
    return message;
  }
  fs::path dir_, path_;
  VocabularyData data_;
  std::string bytes_;
};

TEST_F(VocabularyFile, RoundTripIsExactAndRewritesAreByteIdentical) {
  ASSERT_GT(data_.ids.size(), 50u);
  EXPECT_EQ(data_.settings.at("rule"), "greedy");
  EXPECT_EQ(data_.created_frames.front(), 100);
  const VocabularyData back = readVocabularyFile(path_, {"surf-test-v1", 8});
  expectSameData(data_, back);
  writeVocabularyFile(dir_ / "again.pvoc", back);
  EXPECT_EQ(readBytes(dir_ / "again.pvoc"), bytes_);
  writeVocabularyFile(dir_ / "twice.pvoc", data_);
  EXPECT_EQ(readBytes(dir_ / "twice.pvoc"), bytes_);
}

TEST_F(VocabularyFile, EmptyVocabularyRoundTrips) {
  VocabularyData empty;
  empty.extractor = "surf";
  empty.dim = 64;
  writeVocabularyFile(dir_ / "empty.pvoc", empty);
  const VocabularyData back = readVocabularyFile(dir_ / "empty.pvoc", {"surf", 64});
  EXPECT_TRUE(back.ids.empty());
  EXPECT_EQ(back.dim, 64);
}

TEST_F(VocabularyFile, RefusesWrongMagic) {
  std::string bytes = bytes_;
  bytes[0] = 'X';
  EXPECT_NE(refusal(bytes).find("magic"), std::string::npos);
  EXPECT_NE(refusal("garbage that is not a vocabulary at all").find("magic"), std::string::npos);
}

TEST_F(VocabularyFile, RefusesUnsupportedVersion) {
  std::string bytes = bytes_;
  const std::uint32_t future = 2;
  std::memcpy(&bytes[8], &future, 4);
  EXPECT_NE(refusal(bytes).find("version 2"), std::string::npos);
}

TEST_F(VocabularyFile, RefusesWrongDimensionAndExtractor) {
  EXPECT_NE(refusal(bytes_, {"", 64}).find("dimension 8, map uses 64"), std::string::npos);
  EXPECT_NE(refusal(bytes_, {"orb", 0}).find("extractor surf-test-v1, map uses orb"),
            std::string::npos);
}

TEST_F(VocabularyFile, RefusesBitFlipsAnywhere) {
  // Two header bytes, a descriptor byte, the last byte.
  for (std::size_t at : {std::size_t(25), std::size_t(40), bytes_.size() / 2, bytes_.size() - 1}) {
    std::string bytes = bytes_;
    bytes[at] ^= 0x10;
    const std::string message = refusal(bytes);
    EXPECT_NE(message.find("checksum"), std::string::npos) << "byte " << at << ": " << message;
  }
}

// The header alone (what `vocab import` reads to pick the map's extractor) is checked in full
// but leaves the payload unread: payload damage shows only in a full read.
TEST_F(VocabularyFile, HeaderOnlyReadChecksTheHeaderNotThePayload) {
  const VocabularyData header = readVocabularyFile(path_, {"", 0, true});
  EXPECT_EQ(header.extractor, "surf-test-v1");
  EXPECT_EQ(header.dim, 8);
  EXPECT_EQ(header.settings, data_.settings);
  EXPECT_TRUE(header.ids.empty());
  std::string payload_flip = bytes_;
  payload_flip[bytes_.size() - 1] ^= 0x10;
  writeBytes(dir_ / "payload_flip.pvoc", payload_flip);
  EXPECT_EQ(readVocabularyFile(dir_ / "payload_flip.pvoc", {"", 0, true}).extractor,
            "surf-test-v1");
  refusal(payload_flip);
  std::string header_flip = bytes_;
  header_flip[25] ^= 0x10;
  EXPECT_NE(refusal(header_flip, {"", 0, true}).find("checksum"), std::string::npos);
}

TEST_F(VocabularyFile, RefusesTruncationAtAnyLength) {
  for (std::size_t length :
       {std::size_t(0), std::size_t(3), std::size_t(8), std::size_t(11), std::size_t(15),
        std::size_t(30), bytes_.size() / 3, bytes_.size() - 4, bytes_.size() - 1}) {
    refusal(bytes_.substr(0, length));
  }
  refusal(bytes_ + "extra");
}

TEST_F(VocabularyFile, RefusesHugeDeclaredSizesWithoutAllocating) {
  // A header claiming 2^60 words, with a valid checksum so that only the size check can stop it.
  std::string bytes = bytes_;
  std::uint32_t header_length = 0;
  std::memcpy(&header_length, &bytes[12], 4);
  std::string header = bytes.substr(20, header_length);
  const std::size_t count_at = 4 + data_.extractor.size() + 1 + 4 + 1;
  const std::uint64_t huge = std::uint64_t(1) << 60;
  std::memcpy(&header[count_at], &huge, 8);
  boost::crc_32_type crc;
  crc.process_bytes(header.data(), header.size());
  const std::uint32_t checksum = crc.checksum();
  bytes.replace(20, header_length, header);
  std::memcpy(&bytes[16], &checksum, 4);
  EXPECT_NE(refusal(bytes).find("does not fit"), std::string::npos);

  std::string long_header = bytes_;
  const std::uint32_t enormous = 0xfffffff0u;
  std::memcpy(&long_header[12], &enormous, 4);
  refusal(long_header);
}

// A poor man's fuzzer: random damage gives a typed refusal (or, for a flip the checksums cannot
// see, a successful read), never a crash or another exception.
TEST_F(VocabularyFile, RandomDamageIsAlwaysATypedRefusal) {
  std::mt19937 rng(17);
  const fs::path damaged = dir_ / "fuzzed.pvoc";
  int refused = 0;
  for (int round = 0; round < 300; ++round) {
    std::string bytes = bytes_;
    std::uniform_int_distribution<std::size_t> anywhere(0, bytes.size() - 1);
    switch (round % 3) {
      case 0:  // a few random bytes
        for (int i = 0; i < 1 + round % 4; ++i) bytes[anywhere(rng)] = char(rng());
        break;
      case 1:  // random length fields near the front
        for (int i = 0; i < 4; ++i) bytes[8 + (rng() % 32)] = char(rng());
        break;
      default:  // truncation plus garbage
        bytes.resize(anywhere(rng));
        bytes += std::string(rng() % 64, char(rng()));
    }
    writeBytes(damaged, bytes);
    const ErrorCode code = codeOf([&] { readVocabularyFile(damaged, {"surf-test-v1", 8}); });
    if (bytes == bytes_) continue;
    EXPECT_EQ(code, ErrorCode::kVocabularyRefused) << "round " << round;
    refused += code == ErrorCode::kVocabularyRefused;
  }
  EXPECT_GT(refused, 250);
}

TEST_F(VocabularyFile, MissingFileIsAnIoError) {
  EXPECT_EQ(codeOf([&] { readVocabularyFile(dir_ / "absent.pvoc"); }), ErrorCode::kIo);
}

TEST_F(VocabularyFile, TextExportRoundTripsBitForBit) {
  const fs::path text = dir_ / "words.txt";
  writeVocabularyText(text, data_);
  const VocabularyData back = readVocabularyText(text, 8);
  EXPECT_EQ(back.ids, data_.ids);
  ASSERT_EQ(back.descriptors.size(), data_.descriptors.size());
  EXPECT_EQ(
      std::memcmp(back.descriptors.data, data_.descriptors.data, data_.descriptors.total() * 4), 0);
  // What RTAB-Map's dictionary loader needs: the dimension at the end of the header line, then
  // lines of an id and exactly that many values.
  std::ifstream lines(text);
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, "WordID Descriptors...8");
  std::size_t words = 0;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    long long id = 0;
    fields >> id;
    EXPECT_EQ(id, data_.ids[words] + 1) << "RTAB-Map's word ids start at 1";
    int values = 0;
    for (std::string value; fields >> value;) ++values;
    EXPECT_EQ(values, 8) << line;
    ++words;
  }
  EXPECT_EQ(words, data_.ids.size());

  writeBytes(dir_ / "bad.txt", "1 1 2 3 4 5 6 7 8\n2 1 2 3\n");
  std::string message;
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "bad.txt"); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("line 2"), std::string::npos) << message;
  writeBytes(dir_ / "bad2.txt", "1 1 x\n");
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "bad2.txt"); }), ErrorCode::kVocabularyRefused);
}

// RTAB-Map writes "%f " after every value (so a trailing space) below its header line.
TEST_F(VocabularyFile, ReadsRtabmapDictionaryAndRefusesWrongHeaders) {
  writeBytes(dir_ / "rtabmap.txt",
             "WordID Descriptors...3\n1 0.500000 -0.250000 0.000000 \n2 1.000000 2.000000 "
             "3.000000 \n");
  const VocabularyData words = readVocabularyText(dir_ / "rtabmap.txt");
  EXPECT_EQ(words.dim, 3);
  EXPECT_EQ(words.ids, (std::vector<std::int64_t>{0, 1})) << "RTAB-Map's word 1 is placedb's 0";
  EXPECT_FLOAT_EQ(words.descriptors.at<float>(0, 1), -0.25f);
  EXPECT_FLOAT_EQ(words.descriptors.at<float>(1, 2), 3.0f);

  std::string message;
  // The header announces 4 values, the words hold 3.
  writeBytes(dir_ / "short.txt", "WordID Descriptors...4\n1 0.5 0.5 0.5 \n");
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "short.txt"); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("line 2: 3 values, expected 4"), std::string::npos) << message;
  // The header and the caller disagree on the dimension.
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "rtabmap.txt", 64); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("line 1: dimension 3, expected 64"), std::string::npos) << message;
  writeBytes(dir_ / "header.txt", "WordID Descriptors...x3\n1 0.5 0.5 0.5\n");
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "header.txt"); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("line 1: bad header"), std::string::npos) << message;
  // An empty RTAB-Map dictionary has a header without a number and no word.
  writeBytes(dir_ / "empty.txt", "WordID Descriptors...\n");
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "empty.txt"); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("no word"), std::string::npos) << message;
}

// The export as RTAB-Map's own loader reads it (rtabmap_dictionary_loader.h): every word loads,
// none with RTAB-Map's invalid id 0 (a fixed dictionary asserts its nearest word's id is above
// 0), with exactly placedb's values; and the file still reads back into placedb's ids.
TEST_F(VocabularyFile, TextExportIsWhatRtabmapLoads) {
  ASSERT_EQ(data_.ids.front(), 0) << "the sample holds placedb's word 0";
  const fs::path text = dir_ / "rtabmap_words.txt";
  writeVocabularyText(text, data_);
  const auto rtabmap = testing::loadRtabmapDictionary(text.string());
  ASSERT_FALSE(rtabmap.refused);
  EXPECT_EQ(rtabmap.dimension, data_.dim);
  EXPECT_TRUE(rtabmap.skipped_lines.empty()) << rtabmap.skipped_lines.front();
  EXPECT_EQ(rtabmap.invalid_ids, 0);
  EXPECT_EQ(rtabmap.repeated_ids, 0);
  ASSERT_EQ(rtabmap.words.size(), data_.ids.size());
  for (std::size_t i = 0; i < data_.ids.size(); ++i) {
    const auto word = rtabmap.words.find(static_cast<int>(data_.ids[i] + 1));
    ASSERT_NE(word, rtabmap.words.end()) << "placedb word " << data_.ids[i];
    ASSERT_EQ(word->second.size(), static_cast<std::size_t>(data_.dim));
    EXPECT_EQ(std::memcmp(word->second.data(), data_.descriptors.ptr<float>(int(i)),
                          4 * std::size_t(data_.dim)),
              0)
        << "word " << word->first << " reads back other values in RTAB-Map";
  }
  // ... and placedb reads it back exactly, ids included.
  const VocabularyData back = readVocabularyText(text, data_.dim);
  EXPECT_EQ(back.ids, data_.ids);
  writeVocabularyText(dir_ / "again.txt", back);
  EXPECT_EQ(readBytes(dir_ / "again.txt"), readBytes(text));

  // A word 0 is RTAB-Map's invalid id: refused, saying what to do with an older export.
  writeBytes(dir_ / "zero.txt", "WordID Descriptors...2\n0 0.5 0.5\n1 0.25 0.5\n");
  std::string message;
  EXPECT_EQ(codeOf([&] { readVocabularyText(dir_ / "zero.txt"); }, &message),
            ErrorCode::kVocabularyRefused);
  EXPECT_NE(message.find("line 2: word id 0"), std::string::npos) << message;
  EXPECT_NE(message.find("zero.txt"), std::string::npos) << message;
}

// What RTAB-Map cannot load is refused before a byte is written, naming the file: a path's
// existing file stays as it was, a stream gets nothing, and the message names what the caller
// writes to (the command line passes its output's name).
TEST_F(VocabularyFile, TextExportRefusesWhatRtabmapCannotLoadNamingTheFile) {
  VocabularyData wide;
  wide.dim = 1001;
  wide.ids = {0};
  wide.created_frames = {0};
  wide.descriptors = cv::Mat::zeros(1, wide.dim, CV_32F);
  const fs::path kept = dir_ / "kept.txt";
  writeBytes(kept, "not to be touched\n");
  std::string message;
  EXPECT_EQ(codeOf([&] { writeVocabularyText(kept, wide); }, &message),
            ErrorCode::kInvalidArgument);
  EXPECT_NE(message.find(kept.string() + " as an RTAB-Map dictionary: dimension 1001"),
            std::string::npos)
      << message;
  EXPECT_EQ(readBytes(kept), "not to be touched\n");

  VocabularyData big = data_;
  big.ids.front() = std::numeric_limits<std::int32_t>::max();
  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(codeOf([&] { writeVocabularyText(out, big, "words.txt"); }, &message),
            ErrorCode::kInvalidArgument);
  EXPECT_NE(message.find("cannot write words.txt as an RTAB-Map dictionary: word id"),
            std::string::npos)
      << message;
  EXPECT_EQ(std::ftell(out), 0L);
  std::fclose(out);
}

}  // namespace
}  // namespace placedb::vocab
