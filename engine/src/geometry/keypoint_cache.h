#pragma once
// What the geometric check needs of a working-memory location, kept in RAM: its keypoints'
// positions and words, and their own descriptors as stored (encodeDescriptors). An entry is made
// the first time a location is a candidate and dropped when the location leaves working memory, so
// the check reads SQLite once per location and stay in WM instead of once per frame.
//
// An entry holds the stored descriptor bytes as their codes (storedDescriptorCodes, which
// keeps every byte's value and each row's scale, so nothing is lost), made the same way whether
// they came from the cache or from the file: a resumed run, whose cache starts empty, sees what
// a straight run sees. Codes rather than decoded floats: the matcher decodes only the rows it
// compares in full (descriptor_match.h), and they take half the room of floats.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "geometry/descriptor_match.h"

namespace placedb {

struct CachedKeypoints {
  std::vector<cv::Point2f> points;
  std::vector<std::int64_t> words;  // the word each keypoint was quantised to
  // The location's encodeDescriptors() rows as codes; null when none are stored.
  std::shared_ptr<const DescriptorCodes> codes;
};

class KeypointCache {
 public:
  const CachedKeypoints* find(std::int64_t location) const;
  const CachedKeypoints& insert(std::int64_t location, CachedKeypoints entry);
  // Drops every entry (and every kept position) whose location `keep` refuses (those that left
  // working memory).
  void retainIf(const std::function<bool(std::int64_t)>& keep);
  std::size_t size() const { return entries_.size(); }

  // A place brought back from long-term memory has its references read for its signature, and
  // they hold its keypoints' positions and words: kept here (without descriptors) until the check
  // first loads the place, which then reads only the descriptors. A place brought back by the
  // code search is a loop candidate in that very frame, so each would otherwise be read twice.
  void keepPositions(std::int64_t location, CachedKeypoints positions);
  // The kept positions of `location`, once (they are dropped); nullopt when none are kept.
  std::optional<CachedKeypoints> takePositions(std::int64_t location);
  std::size_t positionsKept() const { return positions_.size(); }

 private:
  std::unordered_map<std::int64_t, CachedKeypoints> entries_;
  std::unordered_map<std::int64_t, CachedKeypoints> positions_;
};

}  // namespace placedb
