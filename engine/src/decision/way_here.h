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
//  - Repeated: between the two surroundings lie places that are not the frame's place. The
//    `count` of them most similar to the frame by eq. 5 (the ones a repeated pattern makes look
//    alike) are compared with it; the best of them sets the chance level the accepted place is
//    measured against: an impostor at NFA m, found among k tries, is a false alarm of k m, and
//    the acceptance's evidence e (its log10 NFA, a run's when it passed as one) must beat
//    min(1, k m) by the factor it must beat chance by: e - min(0, log10(k m)) <= log10(max_nfa).
//    An impostor at chance level or worse changes nothing; one as strong as the place refuses it.
//
// Only a closure that starts a run is judged: one that continues the run of the previous frames'
// closures leans on a start that was. `count` bounds the cost of a judgement; the chance level
// counts every place it compares.
#include <cstddef>
#include <functional>
#include <vector>

#include "filter/inverted_index.h"
#include "filter/signature.h"
#include "geometry/geometry.h"

namespace placedb {

enum class WayHereVerdict {
  kNeverLeft,  // the frame agrees with its whole way back to the place
  kRepeated,   // a place of the way here agrees about as well as the accepted one
};

struct WayHereRefusal {
  WayHereVerdict verdict = WayHereVerdict::kRepeated;
  LocationId location = 0;        // kRepeated: the place of the way here that agrees
  GeometricResult result;         // kRepeated: its comparison
  int impostors = 0;              // kRepeated: places of the way here compared
  double accepted_log10_nfa = 0;  // the evidence the acceptance rested on
  int way = 0;                    // places on the way here
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

// Whether an impostor at `impostor_log10_nfa`, the best of `impostors` places compared, refutes
// an acceptance whose evidence is `accepted_log10_nfa` (see above).
bool refutes(double accepted_log10_nfa, double impostor_log10_nfa, int impostors, double max_nfa);

}  // namespace placedb
