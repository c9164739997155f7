#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "placedb/error.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

std::string imageName(int index, int digits) {
  std::string number = std::to_string(index);
  if (static_cast<int>(number.size()) < digits) number.insert(0, digits - number.size(), '0');
  return "images/" + number + ".png";
}

void failIfBad(const std::ofstream& out, const std::filesystem::path& path) {
  if (!out) throw Error(ErrorCode::kIo, "synthetic sequence: cannot write " + path.string());
}

}  // namespace

void writeSequence(const SyntheticSequence& sequence, const std::filesystem::path& dir,
                   const SequenceProgress& progress) {
  std::error_code error;
  std::filesystem::create_directories(dir / "images", error);
  if (error) {
    throw Error(ErrorCode::kIo, "synthetic sequence: cannot create " + (dir / "images").string() +
                                    ": " + error.message());
  }
  const int total = sequence.size();
  const int digits = std::max(6, static_cast<int>(std::to_string(total - 1).size()));

  const auto frames_path = dir / "frames.txt";
  std::ofstream frames(frames_path);
  failIfBad(frames, frames_path);
  for (int i = 0; i < total; ++i) {
    const std::string name = imageName(i, digits);
    if (!cv::imwrite((dir / name).string(), sequence.render(i))) {
      throw Error(ErrorCode::kIo, "synthetic sequence: cannot write " + (dir / name).string());
    }
    frames << name << '\n';
    if (progress) progress(i + 1, total);
  }
  frames.close();
  failIfBad(frames, frames_path);

  const auto pairs_path = dir / "gt_pairs.txt";
  std::ofstream pairs(pairs_path);
  failIfBad(pairs, pairs_path);
  pairs << "# q r : 0-based line indices into frames.txt (q > r): frame q revisits the place of "
           "frame r\n";
  for (const auto& [q, r] : sequence.groundTruth()) pairs << q << ' ' << r << '\n';
  pairs.close();
  failIfBad(pairs, pairs_path);
}

}  // namespace placedb::synthetic
