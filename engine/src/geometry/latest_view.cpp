#include "geometry/latest_view.h"

#include <cstring>
#include <memory>

namespace placedb {

namespace {

constexpr std::size_t kHeaderBytes = sizeof(std::int64_t) + sizeof(std::uint32_t);
constexpr std::size_t kKeypointBytes = 2 * sizeof(float) + sizeof(std::int64_t);

template <typename T>
void append(std::vector<std::uint8_t>& out, T value) {
  const std::size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

template <typename T>
T read(const std::uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}

}  // namespace

std::vector<std::uint8_t> encodeLatestView(std::int64_t frame_id,
                                           const std::vector<cv::Point2f>& points,
                                           const std::vector<std::int64_t>& words,
                                           const std::vector<std::uint8_t>& descriptors) {
  std::vector<std::uint8_t> out;
  out.reserve(kHeaderBytes + points.size() * kKeypointBytes + descriptors.size());
  append(out, frame_id);
  append(out, static_cast<std::uint32_t>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    append(out, points[i].x);
    append(out, points[i].y);
    append(out, i < words.size() ? words[i] : std::int64_t{-1});
  }
  out.insert(out.end(), descriptors.begin(), descriptors.end());
  return out;
}

std::optional<LatestView> decodeLatestView(const std::vector<std::uint8_t>& bytes, int dim) {
  if (bytes.size() < kHeaderBytes) return std::nullopt;
  LatestView view;
  view.frame_id = read<std::int64_t>(bytes.data());
  const std::size_t n = read<std::uint32_t>(bytes.data() + sizeof(std::int64_t));
  if ((bytes.size() - kHeaderBytes) / kKeypointBytes < n) return std::nullopt;
  const std::uint8_t* at = bytes.data() + kHeaderBytes;
  for (std::size_t i = 0; i < n; ++i, at += kKeypointBytes) {
    view.keypoints.points.emplace_back(read<float>(at), read<float>(at + sizeof(float)));
    view.keypoints.words.push_back(read<std::int64_t>(at + 2 * sizeof(float)));
  }
  const std::vector<std::uint8_t> descriptors(at, bytes.data() + bytes.size());
  DescriptorCodes codes = storedDescriptorCodes(descriptors, dim);
  if (n > 0 && codes.rows != static_cast<int>(n)) return std::nullopt;
  if (n > 0) view.keypoints.codes = std::make_shared<const DescriptorCodes>(std::move(codes));
  return view;
}

}  // namespace placedb
