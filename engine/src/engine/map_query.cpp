// Localisation: an image against the stored locations, changing nothing in RAM or in the file.
#include <algorithm>
#include <chrono>

#include "engine/map_impl.h"
#include "features/image_conversion.h"

namespace placedb {

QueryResult MapImpl::query(const cv::Mat& image, std::size_t top_k) {
  const auto start = std::chrono::steady_clock::now();
  QueryResult result;
  Features features = extractor_->extract(toGrey8(image));
  result.feature_count = features.size();
  if (features.size() == 0 || vocabulary_->size() == 0) return result;

  // Nearest words only: in localisation mode the vocabulary is fixed, so nothing is created.
  // In mapping mode a copy of the options would be needed; the query runs on a fixed view.
  if (!vocabulary_->options().fixed)
    throw Error(ErrorCode::kInternal, "query() needs a map opened in localisation mode");
  vocab::Quantization q = vocabulary_->quantize(features.descriptors, 0);
  std::vector<WordId> words;
  for (std::int64_t id : q.word_of_feature)
    if (id >= 0) words.push_back(id);
  Signature signature = Signature::fromWords(std::move(words));

  // Every location held in RAM (STM and WM) is a candidate.
  auto sims = index_.similarities(signature);
  std::stable_sort(sims.begin(), sims.end(),
                   [](const auto& a, const auto& b) { return a.similarity > b.similarity; });
  if (sims.size() > top_k) sims.resize(top_k);
  for (const auto& s : sims)
    result.matches.push_back({s.location, s.similarity, framesOf(s.location)});
  result.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace placedb
