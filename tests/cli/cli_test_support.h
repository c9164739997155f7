#pragma once
// Running the built `placedb` binary from the end-to-end tests.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "frame_log.h"
#include "subprocess.h"
#include "test_paths.h"

namespace placedb::testing {

inline ProcessResult placedb(std::vector<std::string> args, const std::filesystem::path& scratch) {
  args.insert(args.begin(), PLACEDB_CLI_BINARY);
  return run(args, scratch);
}

// A failure must be one "placedb: error: ..." line, never a crash or a stack trace.
inline void expectCleanError(const ProcessResult& r, int code, const std::string& mentions = "") {
  EXPECT_EQ(r.exit_code, code) << r.err;
  EXPECT_EQ(r.err.rfind("placedb: error: ", 0), 0u) << r.err;
  EXPECT_EQ(r.err.find("terminate"), std::string::npos) << r.err;
  if (!mentions.empty()) {
    EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
  }
}

inline std::string describe(const ProcessResult& r) {
  return "exit " + std::to_string(r.exit_code) + "\nstdout:\n" + r.out + "\nstderr:\n" + r.err;
}

}  // namespace placedb::testing
