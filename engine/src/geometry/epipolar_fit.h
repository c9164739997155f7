#pragma once
// A fundamental matrix fitted to point correspondences by RANSAC on 7-point samples, scored
// a contrario (Moisan & Stival's ORSA, AC-RANSAC) instead of by an inlier count at a fixed
// distance.
//
// Null hypothesis: the correspondences are unrelated, each candidate-side point uniform over
// the candidate's image, whatever its query point. A model F drawn from 7 of the n pairs then
// puts each other pair within eps pixels of its epipolar lines with probability at most
//   alpha(eps) = 2 D eps / A        (D the image diagonal, A its area),
// so k - 7 or more of the n - 7 others do so with probability at most
//   C(n - 7, k - 7) alpha(eps)^(k - 7).
// Over every test the fit makes (3 roots x `iterations` samples x the n - 7 choices of k, eps
// being the k-th smallest distance), the number of false alarms
//   NFA = 3 iterations (n - 7) C(n - 7, k - 7) alpha(eps_k)^(k - 7)
// bounds how many models this good unrelated pairs would produce; a fit passes when its NFA
// is at most `max_nfa`. Few matches need nearly all of them to agree, many matches fewer in
// proportion, and a small image (larger alpha at the same distance) more: the chance level
// follows the evidence rather than a count tuned to one resolution.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

struct EpipolarFitSettings {
  int iterations = 400;            // 7-point samples drawn (fewer when a sample passes early)
  double max_nfa = 1.0;            // a fit passes at this many expected false alarms or fewer
  double max_error_px = 8;         // distances above this never count as agreement
  bool stop_when_passed = true;    // stop at the first model that passes (its NFA, not the best)
  int stop_at_inliers = 0;         // also stop once a model has this many pairs within max_error_px
  double stop_at_inliers_nfa = 0;  // ... and the best NFA is at most this (0: whatever the NFA)
  // Also stop once the samples drawn would have drawn, with this probability, one sample of 7
  // pairs all within max_error_px of the best model so far (RANSAC's adaptive count: N draws
  // with log(1 - confidence) / log(1 - w^7), w that model's share of the pairs); 0 = off. For
  // comparing the agreement of several views, where the best model need not be the last word.
  double confidence = 0;
};

struct EpipolarFit {
  int inliers = 0;                  // pairs within the best model's adaptive distance (7 minimum)
  double log10_nfa = 1e9;           // of the best model; log10(max_nfa) or less passes
  double threshold_px = 0;          // that adaptive distance
  cv::Matx33d fundamental;          // query point a, candidate point b: b' F a = 0
  std::vector<int> inlier_pairs;    // indices into the correspondences, ascending
  std::vector<int> agreeing_pairs;  // ... within max_error_px of that model, ascending
  int most_within_max_error = 0;    // the most pairs any model put within max_error_px
  int draws = 0;                    // samples of 7 pairs drawn before the fit stopped
  bool passed = false;
};

// Correspondences a[i] <-> b[i]; `candidate_size` is the candidate image's extent (width,
// height) for alpha. The first pairs are sampled more often early on (PROSAC's idea), so pass
// the most reliable matches first. Deterministic: the same input gives the same fit.
EpipolarFit fitEpipolar(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                        cv::Size2f candidate_size, const EpipolarFitSettings& settings);

// log10 of the NFA above for a model with k of n pairs within eps, as the fit computes it.
double epipolarLog10Nfa(int n, int k, double eps_px, cv::Size2f candidate_size, int iterations);

}  // namespace placedb
