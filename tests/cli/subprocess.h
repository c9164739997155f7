#pragma once
// Runs a program with arguments (no shell), capturing stdout, stderr and the exit status.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace placedb::testing {

struct ProcessResult {
  int exit_code = -1;  // 128 + signal when killed by a signal
  std::string out, err;
};

class Process {
 public:
  // Starts `argv[0]` with `argv`; stdout and stderr go to files under `scratch`.
  Process(const std::vector<std::string>& argv, const std::filesystem::path& scratch,
          const std::string& cwd = "") {
    static int counter = 0;
    ++counter;
    out_path_ = scratch / ("stdout_" + std::to_string(counter) + ".txt");
    err_path_ = scratch / ("stderr_" + std::to_string(counter) + ".txt");
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_ = fork();
    if (pid_ == 0) {
      int out = open(out_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      int err = open(err_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(out, STDOUT_FILENO);
      dup2(err, STDERR_FILENO);
      if (!cwd.empty() && chdir(cwd.c_str()) != 0) _exit(126);
      execv(args[0], args.data());
      _exit(127);
    }
  }

  void signal(int sig) { kill(pid_, sig); }

  ProcessResult wait() {
    ProcessResult result;
    int status = 0;
    waitpid(pid_, &status, 0);
    if (WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) result.exit_code = 128 + WTERMSIG(status);
    result.out = slurp(out_path_);
    result.err = slurp(err_path_);
    return result;
  }

  static std::string slurp(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

 private:
  pid_t pid_ = -1;
  std::filesystem::path out_path_, err_path_;
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
