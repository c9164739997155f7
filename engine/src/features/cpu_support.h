#pragma once
// Which hand-vectorised loops this process may run: one home for the CPU's instruction sets, read
// once. Every such loop has a plain one beside it that gives the same results bit for bit, and the
// environment variable PLACEDB_SIMD chooses among them:
//   (unset) or "best"  the widest the CPU has;
//   "avx2"             no AVX-512, even where the CPU has it;
//   "off"              the plain loops only (and SSE2, which every x86-64 CPU has).
// The tests run the kernels' checks under "off" and "avx2" too (tests/CMakeLists.txt,
// placedb_add_simd_runs), so the loops of a machine without AVX2 or AVX-512 are checked on one
// that has them.

namespace placedb {

enum class SimdLevel { kPlain, kAvx2, kAvx512Vnni };

// The CPU's level, whatever PLACEDB_SIMD says.
SimdLevel cpuSimdLevel();

// The level `value` of PLACEDB_SIMD (null when unset) leaves on a CPU of level `cpu`. Throws
// placedb::Error(kInvalidArgument) naming the variable when the value is none of the above.
SimdLevel cappedSimdLevel(SimdLevel cpu, const char* value);

// The level in force: cappedSimdLevel(cpuSimdLevel(), getenv("PLACEDB_SIMD")), read at the first
// call (an invalid value throws there, and again on the next call).
SimdLevel simdLevel();

// True when the loops of `level` may run here.
inline bool simdAllows(SimdLevel level) {
  return static_cast<int>(simdLevel()) >= static_cast<int>(level);
}

}  // namespace placedb
