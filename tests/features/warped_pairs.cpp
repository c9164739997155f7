#include "warped_pairs.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace placedb::testing {
namespace {

// Distance of each pixel of `mask` (255 = shows the first image) to the nearest pixel that does
// not, counting the outside of the image as such.
cv::Mat insideDistance(const cv::Mat& mask) {
  cv::Mat padded;
  cv::copyMakeBorder(mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat distance;
  cv::distanceTransform(padded, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return distance(cv::Rect(1, 1, mask.cols, mask.rows)).clone();
}

WarpedPair samePlace(const cv::Mat& grey, const std::string& label) {
  WarpedPair pair;
  pair.transform = label;
  pair.to_warped = cv::Matx23d(1, 0, 0, 0, 1, 0);
  pair.inside_distance = insideDistance(cv::Mat(grey.size(), CV_8U, cv::Scalar(255)));
  return pair;
}

cv::Point2d apply(const cv::Matx23d& m, double x, double y) {
  return {m(0, 0) * x + m(0, 1) * y + m(0, 2), m(1, 0) * x + m(1, 1) * y + m(1, 2)};
}

bool supportInside(const cv::Mat& inside_distance, const cv::Point2d& p, double radius) {
  const int x = static_cast<int>(std::lround(p.x));
  const int y = static_cast<int>(std::lround(p.y));
  return x >= 0 && y >= 0 && x < inside_distance.cols && y < inside_distance.rows &&
         inside_distance.at<float>(y, x) >= radius;
}

}  // namespace

WarpedPair rotateAndScale(const cv::Mat& grey, double degrees, double scale,
                          const std::string& label) {
  const cv::Point2f centre((grey.cols - 1) / 2.0f, (grey.rows - 1) / 2.0f);
  cv::Mat m = cv::getRotationMatrix2D(centre, degrees, scale);
  // Move the result so that its bounding box starts at the origin.
  std::vector<cv::Point2d> corners = {
      {0, 0}, {grey.cols - 1.0, 0}, {0, grey.rows - 1.0}, {grey.cols - 1.0, grey.rows - 1.0}};
  cv::Matx23d to_warped(m);
  double min_x = 1e9, min_y = 1e9, max_x = -1e9, max_y = -1e9;
  for (const auto& c : corners) {
    const cv::Point2d p = apply(to_warped, c.x, c.y);
    min_x = std::min(min_x, p.x);
    min_y = std::min(min_y, p.y);
    max_x = std::max(max_x, p.x);
    max_y = std::max(max_y, p.y);
  }
  to_warped(0, 2) -= min_x;
  to_warped(1, 2) -= min_y;
  const cv::Size size(static_cast<int>(std::lround(max_x - min_x)) + 1,
                      static_cast<int>(std::lround(max_y - min_y)) + 1);
  WarpedPair pair;
  pair.transform = label;
  pair.to_warped = to_warped;
  pair.scale = scale;
  cv::warpAffine(grey, pair.warped, cv::Mat(to_warped), size, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                 cv::Scalar(0));
  cv::Mat ones(grey.size(), CV_8U, cv::Scalar(255)), valid;
  cv::warpAffine(ones, valid, cv::Mat(to_warped), size, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                 cv::Scalar(0));
  pair.inside_distance = insideDistance(valid);
  return pair;
}

WarpedPair gaussianBlur(const cv::Mat& grey, double sigma) {
  WarpedPair pair = samePlace(grey, "blur" + std::to_string(static_cast<int>(sigma)));
  cv::GaussianBlur(grey, pair.warped, cv::Size(), sigma);
  return pair;
}

WarpedPair gaussianNoise(const cv::Mat& grey, double sigma, unsigned seed) {
  WarpedPair pair = samePlace(grey, "noise" + std::to_string(static_cast<int>(sigma)));
  cv::Mat noise(grey.size(), CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  cv::Mat noisy;
  grey.convertTo(noisy, CV_32F);
  noisy += noise;
  noisy.convertTo(pair.warped, CV_8U);
  return pair;
}

WarpedPair brightnessShift(const cv::Mat& grey, double offset) {
  WarpedPair pair = samePlace(grey, "bright+" + std::to_string(static_cast<int>(offset)));
  grey.convertTo(pair.warped, CV_8U, 1.0, offset);
  return pair;
}

std::vector<WarpedPair> standardPairs(const cv::Mat& grey) {
  return {rotateAndScale(grey, 30, 1.0, "rot30"),
          rotateAndScale(grey, 90, 1.0, "rot90"),
          rotateAndScale(grey, 0, 0.5, "scale0.5"),
          rotateAndScale(grey, 0, 2.0, "scale2"),
          gaussianBlur(grey, 2.0),
          gaussianNoise(grey, 10.0, 7),
          brightnessShift(grey, 40.0)};
}

PairScore scorePair(const Features& first, const Features& second, const WarpedPair& pair,
                    double tolerance) {
  const double tol = tolerance * std::max(1.0, pair.scale);
  std::vector<int> first_in, second_in;
  std::vector<cv::Point2d> mapped;
  for (int i = 0; i < static_cast<int>(first.size()); ++i) {
    const Keypoint& k = first.keypoints[i];
    const cv::Point2d p = apply(pair.to_warped, k.x, k.y);
    if (supportInside(pair.inside_distance, p, k.size * pair.scale / 2)) {
      first_in.push_back(i);
      mapped.push_back(p);
    }
  }
  for (int j = 0; j < static_cast<int>(second.size()); ++j) {
    const Keypoint& k = second.keypoints[j];
    if (supportInside(pair.inside_distance, {k.x, k.y}, k.size / 2)) second_in.push_back(j);
  }
  PairScore score;
  score.first_in_common = static_cast<int>(first_in.size());
  score.second_in_common = static_cast<int>(second_in.size());
  if (first_in.empty() || second_in.empty()) return score;

  int repeated = 0;
  for (std::size_t a = 0; a < first_in.size(); ++a) {
    const Keypoint& ka = first.keypoints[first_in[a]];
    const double mapped_size = ka.size * pair.scale;
    for (int j : second_in) {
      const Keypoint& kb = second.keypoints[j];
      const double distance = std::hypot(kb.x - mapped[a].x, kb.y - mapped[a].y);
      const double size_ratio = kb.size / mapped_size;
      if (distance <= tol && size_ratio < 1.5 && size_ratio > 1 / 1.5) {
        ++repeated;
        break;
      }
    }
  }
  score.repeatability =
      std::min(1.0, repeated / static_cast<double>(std::min(first_in.size(), second_in.size())));

  const int dim = first.dim;
  for (std::size_t a = 0; a < first_in.size(); ++a) {
    const float* da = first.descriptors.ptr<float>(first_in[a]);
    double best = 1e300;
    int best_j = -1;
    for (int j : second_in) {
      const float* db = second.descriptors.ptr<float>(j);
      double d2 = 0;
      for (int k = 0; k < dim; ++k) d2 += (da[k] - db[k]) * double(da[k] - db[k]);
      if (d2 < best) {
        best = d2;
        best_j = j;
      }
    }
    const Keypoint& kb = second.keypoints[best_j];
    if (std::hypot(kb.x - mapped[a].x, kb.y - mapped[a].y) <= tol) ++score.correct_matches;
  }
  score.precision = score.correct_matches / static_cast<double>(first_in.size());
  return score;
}

}  // namespace placedb::testing
