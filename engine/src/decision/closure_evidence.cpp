#include "decision/closure_evidence.h"

#include <algorithm>
#include <cmath>

namespace placedb {

bool continuesEvidence(const ClosureEvidence& evidence, std::int64_t frame, std::int64_t session) {
  return evidence.location != 0 && evidence.session == session && frame == evidence.frame + 1;
}

double log10Fisher(double log10_product, int frames) {
  const double minus_ln_c = -log10_product * std::log(10.0);
  double term = 1, sum = 1;
  for (int j = 1; j < frames; ++j) {
    term *= minus_ln_c / j;
    sum += term;
  }
  return log10_product + std::log10(sum);
}

ClosureEvidence addEvidence(const ClosureEvidence& before, LocationId location, std::int64_t frame,
                            std::int64_t session, double frame_log10_nfa, int alternatives) {
  ClosureEvidence next;
  next.location = location;
  next.frame = frame;
  next.session = session;
  next.log10_nfa = frame_log10_nfa;
  // A frame that is no evidence on its own (NFA above 1: as good as chance) ends a run.
  if (frame_log10_nfa > 0) return next;
  next.log10_product = frame_log10_nfa;
  next.frames = 1;
  if (alternatives > 0 && before.frames > 0 && continuesEvidence(before, frame, session)) {
    ClosureEvidence run = next;
    run.log10_product = before.log10_product + next.log10_product;
    run.log10_alternatives = before.log10_alternatives + std::log10(double(alternatives));
    run.frames = before.frames + 1;
    run.log10_nfa = run.log10_alternatives + log10Fisher(run.log10_product, run.frames);
    if (run.log10_nfa < next.log10_nfa) return run;
  }
  return next;
}

}  // namespace placedb
