#pragma once
// Hash-based randomness for the synthetic world. Everything is a pure function of the seed and
// integer coordinates so any tile or frame can be regenerated alone, in any order, on any
// platform (std:: distributions are implementation-defined, so they are avoided).
#include <cmath>
#include <cstdint>

namespace placedb::synthetic {

// SplitMix64 finaliser: a bijective mix with good avalanche.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

inline std::uint64_t hashOf(std::uint64_t seed, std::uint64_t salt, std::int64_t a = 0,
                            std::int64_t b = 0) {
  std::uint64_t h = mix64(seed ^ mix64(salt));
  h = mix64(h ^ static_cast<std::uint64_t>(a));
  return mix64(h ^ (static_cast<std::uint64_t>(b) * 0xd6e8feb86659fd93ULL));
}

// Uniform in [0, 1) from the top 53 bits.
inline double unitOf(std::uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// A small sequential generator for places where a stream of numbers is easier to read.
class SeededRandom {
 public:
  explicit SeededRandom(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() { return mix64(state_++ * 0x632be59bd9b4e019ULL); }
  double uniform() { return unitOf(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Inclusive range.
  int intIn(int lo, int hi) {
    return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  // Log-uniform: as many small things per octave as large ones.
  double logUniform(double lo, double hi) { return lo * std::pow(hi / lo, uniform()); }

 private:
  std::uint64_t state_;
};

// Smooth 1-D noise in [-1, 1]: hashed values at integer t, blended with a C1 smoothstep.
inline double smoothNoise1d(std::uint64_t seed, std::uint64_t salt, double t) {
  const double cell = std::floor(t);
  const double frac = t - cell;
  const auto k = static_cast<std::int64_t>(cell);
  const double v0 = 2.0 * unitOf(hashOf(seed, salt, k)) - 1.0;
  const double v1 = 2.0 * unitOf(hashOf(seed, salt, k + 1)) - 1.0;
  const double w = frac * frac * (3.0 - 2.0 * frac);
  return v0 + (v1 - v0) * w;
}

}  // namespace placedb::synthetic
