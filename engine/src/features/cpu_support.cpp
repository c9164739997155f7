#include "features/cpu_support.h"

#include <cstdlib>
#include <string>

#include "placedb/error.h"

namespace placedb {

SimdLevel cpuSimdLevel() {
#if defined(__GNUC__) && defined(__x86_64__)
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512vnni"))
    return SimdLevel::kAvx512Vnni;
  if (__builtin_cpu_supports("avx2")) return SimdLevel::kAvx2;
#endif
  return SimdLevel::kPlain;
}

SimdLevel cappedSimdLevel(SimdLevel cpu, const char* value) {
  const std::string asked = value ? value : "";
  SimdLevel cap = SimdLevel::kAvx512Vnni;
  if (asked == "off")
    cap = SimdLevel::kPlain;
  else if (asked == "avx2")
    cap = SimdLevel::kAvx2;
  else if (!asked.empty() && asked != "best")
    throw Error(ErrorCode::kInvalidArgument, "environment variable PLACEDB_SIMD is \"" + asked +
                                                 "\": expected best, avx2 or off");
  return static_cast<int>(cap) < static_cast<int>(cpu) ? cap : cpu;
}

SimdLevel simdLevel() {
  static const SimdLevel level = cappedSimdLevel(cpuSimdLevel(), std::getenv("PLACEDB_SIMD"));
  return level;
}

}  // namespace placedb
