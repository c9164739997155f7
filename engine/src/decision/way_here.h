#pragma once
// Whether an accepted place is singled out by the frame's agreement, or the agreement is a
// pattern that repeats along the route: doors and lockers every few metres down a corridor, the
// same shop front on every block. Every view of such a route agrees with every other one far
// beyond chance (the pictures are the same), so no test of one frame against one place can tell a
// revisit from the next repetition; the epipolar and scene-share tests both pass.
//
// The frame's own way here tells them apart. A loop closure says the camera left the place and
// came back; under that very claim the places it went through in between are other places, a
// sample of what the frame agrees with where it is not. The way here is the frame's traversal
// back from its own view to the accepted place's surroundings (the place and what one link
// reaches from it in working memory). Along it:
//
//  - The frame's surroundings come first: places it still sees, which agree with it. They end
//    where two places in a row show no agreement beyond chance (no model at NFA 1 or below, each
//    checked alone): one such place is no proof the camera left, since a blurred view or one
//    with few keypoints fails alone. The accepted place's own surroundings (its approach, seen
//    again from the frame) are found the same way from the far end.
//  - Never left: when the way reaches the accepted place without two such places in a row, the
//    frame saw that scene all along (looking down a long corridor, the far end stays in view).
//    That is one visit, not a revisit, and the closure is refused. A frame whose way does not
//    reach the place (another session's, or one beyond the places in memory) is not judged so.
//  - Repeated: between the two surroundings lie places that are not the frame's place, save
//    the ones the map already joins to it (a loop closure from the way to the place's own
//    stretch: an earlier visit of it, passed again on the way here). Up to `count` of them, the
//    most similar to the frame by eq. 5 first (the ones a repeated pattern makes look alike),
//    are compared with it. The j-th compared is weighed 1 / (j (j + 1)): agreeing at NFA m it is
//    a false alarm of j (j + 1) m. The weights sum to less than 1 however many are compared, so
//    a longer list only adds tests and never asks more of the first ones: `count` bounds the
//    cost, not the evidence (with equal weights 1 / count, a longer list let strong impostors
//    through). An impostor refutes the closure when it passes the frame's bar itself
//    (j (j + 1) m <= max_nfa: a place the claim makes another place would be accepted too, so
//    the agreement singles out no place), or when the acceptance's evidence e (its log10 NFA, a
//    run's when it passed as one) does not beat min(1, j (j + 1) m) by the factor the bar asks
//    of chance: e - min(0, log10(j (j + 1) m)) > log10(max_nfa). An impostor at chance level or
//    worse changes nothing.
//
// Only a closure that starts a run is judged: one that continues the run of the previous frames'
// closures leans on a start that was.
//
// Refutations come in runs too. The next frames see nearly the same view and agree with the
// refuted place again, a frame further on, while the way's views stay where their locations were
// stored: the impostor that matched one frame's offset from the pattern can miss the next one's.
// So the impostor found for a refused frame stands for the frames that claim a place within a
// closure run's reach of the refused one (temporal_radius links, up to temporal_max_gap frames
// later): their evidence must beat its level by the bar's factor, or they are refused with it.
// Only a refutation measured on a frame's own way anchors them; carried on from frame to frame,
// one would follow a true revisit along the graph.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "filter/inverted_index.h"
#include "filter/signature.h"
#include "geometry/geometry.h"

namespace placedb {

enum class WayHereVerdict {
  kNeverLeft,  // the frame agrees with its whole way back to the place
  kRepeated,   // a place of the way here agrees about as well as the accepted one
  kContinued,  // the frame claims a place next to one refuted as a pattern just before
};

// The newest place refused as a pattern on its frame's own way (kRepeated) and when.
struct RefutedPlace {
  LocationId location = 0;  // 0 = none
  std::int64_t frame = 0;   // the refusing frame, on the frame clock
  std::int64_t session = 0;
  double impostor = 0;  // the impostor's countedLog10Nfa
};

// Whether a frame of `session` at `frame` is near enough in time to continue `refuted`.
bool withinRefutation(const RefutedPlace& refuted, std::int64_t frame, std::int64_t session,
                      int max_gap);

struct WayHereRefusal {
  WayHereVerdict verdict = WayHereVerdict::kRepeated;
  LocationId location = 0;        // kRepeated: the place of the way here that agrees;
                                  // kContinued: the place refuted before
  GeometricResult result;         // kRepeated: its comparison
  int impostors = 0;              // kRepeated: places of the way here compared
  double counted_log10_nfa = 0;   // kRepeated: its NFA times its tries (countedLog10Nfa)
  double accepted_log10_nfa = 0;  // the evidence the acceptance rested on
  int way = 0;                    // places on the way here
  std::int64_t frames_since = 0;  // kContinued: frames since that place was refused
};

// Is place i of the way (0 = newest) without agreement with the frame beyond chance?
using Unrelated = std::function<bool(std::size_t)>;

// The first index i of a way of `size` places with unrelated(i) and unrelated(i + 1): where the
// frame's surroundings end. `size` when there is none.
std::size_t surroundingsEnd(std::size_t size, const Unrelated& unrelated);

// Walking from the far end of the way down to `end` (from surroundingsEnd), the first index j >
// end + 1 with unrelated(j) and unrelated(j - 1): where the accepted place's surroundings begin.
// end + 1 when there is none.
std::size_t placeSurroundingsBegin(std::size_t size, std::size_t end, const Unrelated& unrelated);

// Of `places`, the `count` with the highest similarity (from `similarities`; a place without one
// has 0), ties by the newer place; most similar first.
std::vector<LocationId> mostSimilar(const std::vector<LocationId>& places,
                                    const std::vector<LocationSimilarity>& similarities, int count);

// The false alarms an impostor at NFA m stands for, as a multiple of m, when it is the `rank`-th
// place compared (1 = the most similar): rank (rank + 1). `uniform` > 0: every one alike, as
// many as were compared (sessions begun before the ranked weights, Options).
double impostorTries(int rank, int uniform);

// log10 of an impostor's NFA (given as log10) times the `tries` it stands for (impostorTries).
double countedLog10Nfa(double log10_nfa, double tries);

// Whether an impostor at `impostor_log10_nfa`, counted as `tries` false alarms (impostorTries),
// refutes an acceptance whose evidence is `accepted_log10_nfa` (see above). `passing_refutes`:
// an impostor that passes the bar itself refutes whatever the acceptance's evidence (false for
// sessions begun before it).
bool refutes(double accepted_log10_nfa, double impostor_log10_nfa, double tries, double max_nfa,
             bool passing_refutes = true);

}  // namespace placedb
