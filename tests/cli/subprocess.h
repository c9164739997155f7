#pragma once
// Runs a program with arguments (no shell), capturing stdout, stderr and the exit status.
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.h"
#include "file_bytes.h"

namespace placedb::testing {

struct ProcessResult {
  int exit_code = -1;  // 128 + signal when killed by a signal
  std::string out, err;
};

class Process {
 public:
  // Starts `argv[0]` with `argv`; stdout and stderr go to files under `scratch`.
  Process(const std::vector<std::string>& argv, const std::filesystem::path& scratch,
          const std::string& cwd = "")
      : output_(outputUnder(scratch, cwd)), child_(argv, output_) {}

  void signal(int sig) { child_.signal(sig); }
  pid_t pid() const { return child_.pid(); }

  ProcessResult wait() {
    ProcessResult result;
    result.exit_code = child_.exitCode();
    result.out = readBytes(output_.stdout_file);
    result.err = readBytes(output_.stderr_file);
    return result;
  }

 private:
  static ChildOutput outputUnder(const std::filesystem::path& scratch, const std::string& cwd) {
    static int counter = 0;
    ++counter;
    return {scratch / ("stdout_" + std::to_string(counter) + ".txt"),
            scratch / ("stderr_" + std::to_string(counter) + ".txt"), cwd};
  }

  ChildOutput output_;
  ChildProcess child_;
};

inline ProcessResult run(const std::vector<std::string>& argv,
                         const std::filesystem::path& scratch) {
  return Process(argv, scratch).wait();
}

inline std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> result;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) result.push_back(line);
  return result;
}

}  // namespace placedb::testing
