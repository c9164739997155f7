#pragma once
// A program run as a child process (no shell) that a test can read, signal, kill and wait for.
// Its stdout is either a pipe the test reads line by line, or a file; its stderr a file or the
// test's own.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace placedb::testing {

struct ChildOutput {
  std::filesystem::path stdout_file;  // empty: a pipe, read with readLine()
  std::filesystem::path stderr_file;  // empty: the test's stderr
  std::string cwd;                    // empty: the test's
};

class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv, const ChildOutput& output = {}) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int fds[2] = {-1, -1};
    const bool piped = output.stdout_file.empty();
    if (piped && pipe(fds) != 0) throw std::runtime_error("pipe failed");
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      if (piped) {
        dup2(fds[1], STDOUT_FILENO);
        close(fds[0]);
        close(fds[1]);
      } else {
        redirect(output.stdout_file, STDOUT_FILENO);
      }
      if (!output.stderr_file.empty()) redirect(output.stderr_file, STDERR_FILENO);
      if (!output.cwd.empty() && chdir(output.cwd.c_str()) != 0) _exit(126);
      execv(args[0], args.data());
      _exit(127);
    }
    if (piped) {
      close(fds[1]);
      out_ = fds[0];
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !reaped_) {
      kill();
      wait();
    }
    if (out_ >= 0) close(out_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The next line of a piped stdout without its newline; nullopt at end of output or after
  // timeout_ms.
  std::optional<std::string> readLine(int timeout_ms = 30000) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      if (auto end = buffer_.find('\n'); end != std::string::npos) {
        std::string line = buffer_.substr(0, end);
        buffer_.erase(0, end + 1);
        return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            deadline - std::chrono::steady_clock::now())
                            .count();
      if (left <= 0 || out_ < 0) return std::nullopt;
      pollfd p{out_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char chunk[512];
      const ssize_t n = read(out_, chunk, sizeof chunk);
      if (n <= 0) return std::nullopt;
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }

  void signal(int sig) { ::kill(pid_, sig); }
  void kill() { signal(SIGKILL); }

  // The raw wait status.
  int wait() {
    if (!reaped_) {
      waitpid(pid_, &status_, 0);
      reaped_ = true;
    }
    return status_;
  }

  // The exit code, or 128 + the signal that ended the child.
  int exitCode() {
    const int status = wait();
    if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  pid_t pid() const { return pid_; }

 private:
  static void redirect(const std::filesystem::path& file, int fd) {
    const int opened = open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (opened < 0) _exit(125);
    dup2(opened, fd);
    close(opened);
  }

  pid_t pid_ = -1;
  int out_ = -1;
  int status_ = 0;
  bool reaped_ = false;
  std::string buffer_;
};

}  // namespace placedb::testing
