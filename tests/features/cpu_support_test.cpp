// PLACEDB_SIMD: what each value leaves of the CPU's loops, and a clear error for any other.
#include "features/cpu_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "placedb/error.h"

namespace placedb {
namespace {

TEST(CpuSupport, UnsetOrBestLeavesTheCpusLevel) {
  for (SimdLevel cpu : {SimdLevel::kPlain, SimdLevel::kAvx2, SimdLevel::kAvx512Vnni}) {
    EXPECT_EQ(cappedSimdLevel(cpu, nullptr), cpu);
    EXPECT_EQ(cappedSimdLevel(cpu, ""), cpu);
    EXPECT_EQ(cappedSimdLevel(cpu, "best"), cpu);
  }
}

TEST(CpuSupport, OffAndAvx2CapTheLevelButNeverRaiseIt) {
  EXPECT_EQ(cappedSimdLevel(SimdLevel::kAvx512Vnni, "off"), SimdLevel::kPlain);
  EXPECT_EQ(cappedSimdLevel(SimdLevel::kAvx512Vnni, "avx2"), SimdLevel::kAvx2);
  EXPECT_EQ(cappedSimdLevel(SimdLevel::kAvx2, "avx2"), SimdLevel::kAvx2);
  EXPECT_EQ(cappedSimdLevel(SimdLevel::kPlain, "avx2"), SimdLevel::kPlain);
}

TEST(CpuSupport, AnyOtherValueIsAnErrorNamingTheVariableAndTheChoices) {
  try {
    cappedSimdLevel(SimdLevel::kAvx2, "AVX512");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    const std::string what = e.what();
    EXPECT_NE(what.find("PLACEDB_SIMD"), std::string::npos) << what;
    EXPECT_NE(what.find("\"AVX512\""), std::string::npos) << what;
    EXPECT_NE(what.find("best, avx2 or off"), std::string::npos) << what;
  }
}

TEST(CpuSupport, TheLevelInForceIsTheEnvironmentsCapOnTheCpu) {
  const char* asked = std::getenv("PLACEDB_SIMD");
  EXPECT_EQ(simdLevel(), cappedSimdLevel(cpuSimdLevel(), asked));
}

}  // namespace
}  // namespace placedb
