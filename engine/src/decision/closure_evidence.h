#pragma once
// Evidence that adds up over frames. One frame's check is an a-contrario test (epipolar_fit.h):
// its NFA bounds the chance that unrelated correspondences give a model as good as the best one,
// so min(1, NFA) is a p-value of that frame. When frames in a row match places that follow one
// another along a traversal, their tests are independent under the same null model (each frame
// brings its own features), and the run's evidence is the product c of its k p-values. Under
// the null model a product of k independent uniform p-values falls at or below c with
// probability
//   F_k(c) = c * sum_{j < k} (-ln c)^j / j!          (Fisher's combination),
// and choosing the run costs tests too: after its first frame, each frame could have continued
// to any of the places within reach of the one before (`alternatives`). So
//   NFA(run) = prod_{i > 1} alternatives_i * F_k(prod_i min(1, NFA_i)),
// and a run passes under the threshold one frame passes under: NFA(run) <= geometry_max_nfa. A
// single frame is the run of one, judged exactly as before. Of the runs that end at a frame the
// one with the lowest NFA counts: three frames in a row each just short of the threshold (NFA
// 1e-2 to 1e-3) pass together, while a frame without agreement (NFA above 1, as good as chance)
// ends the run. A frame that passes the inliers rule counts as NFA geometry_max_nfa (its own
// when lower): it met the bar a frame must meet alone.
#include <cstdint>

#include "filter/signature.h"

namespace placedb {

struct ClosureEvidence {
  LocationId location = 0;        // the place the newest frame of the run matched, 0 = none
  std::int64_t frame = 0;         // that frame
  std::int64_t session = 0;       // and its session
  double log10_nfa = 0;           // NFA(run) of the strongest run ending there, log10
  double log10_product = 0;       // its p-values' product, log10
  double log10_alternatives = 0;  // its places' alternatives' product, log10
  int frames = 0;                 // frames in that run
};

// Whether `frame` of `session` comes right after the evidence's frame, so that a place within
// reach of evidence.location continues its run.
bool continuesEvidence(const ClosureEvidence& evidence, std::int64_t frame, std::int64_t session);

// log10 F_k(c) for log10 c (<= 0) and k >= 1 frames.
double log10Fisher(double log10_product, int frames);

// The evidence after `frame` matched `location` with its own log10 NFA `frame_log10_nfa`.
// `alternatives` is the number of places within reach of the run's last place when `location`
// is one of them, 0 when it continues no run.
ClosureEvidence addEvidence(const ClosureEvidence& before, LocationId location, std::int64_t frame,
                            std::int64_t session, double frame_log10_nfa, int alternatives);

}  // namespace placedb
