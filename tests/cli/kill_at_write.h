#pragma once
// Fault injection from outside the program: runs it under ptrace and kills it with SIGKILL at the
// entry of its n-th write(2) to one file, so that exactly what came before that write happened
// (a frame's commit, say) and the write itself never does. No hook in placedb: the test watches
// the system calls every thread of the process makes.
#include <fcntl.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/syscall.h>
#include <sys/user.h>
#include <sys/wait.h>
#include <unistd.h>

#include <climits>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace placedb::testing {

#if defined(__x86_64__)
inline constexpr bool kCanKillAtWrite = true;
#else
inline constexpr bool kCanKillAtWrite = false;  // the registers read below are x86-64's
#endif

// Runs `argv` (argv[0] a path; stdout and stderr discarded) and kills it at the entry of its
// `nth` write(2) (1-based) to `file`. Returns the number of writes to `file` it saw (below
// `nth` when the program ended first) and sets `killed`.
inline int runKilledAtWrite(const std::vector<std::string>& argv, const std::filesystem::path& file,
                            int nth, bool* killed) {
  *killed = false;
#if defined(__x86_64__)
  const std::string watched = std::filesystem::absolute(file).lexically_normal().string();
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t child = fork();
  if (child == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, STDOUT_FILENO);
    dup2(null, STDERR_FILENO);
    ptrace(PTRACE_TRACEME, 0, nullptr, nullptr);
    raise(SIGSTOP);
    execv(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  waitpid(child, &status, 0);  // its SIGSTOP
  ptrace(PTRACE_SETOPTIONS, child, nullptr,
         PTRACE_O_TRACESYSGOOD | PTRACE_O_TRACECLONE | PTRACE_O_TRACEEXEC | PTRACE_O_EXITKILL);
  ptrace(PTRACE_SYSCALL, child, nullptr, nullptr);
  std::set<pid_t> in_call;  // threads stopped inside a system call (the next stop is its exit)
  std::set<pid_t> known = {child};
  int writes = 0;
  for (;;) {
    const pid_t tid = waitpid(-1, &status, __WALL);
    if (tid < 0) break;
    if (WIFEXITED(status) || WIFSIGNALED(status)) {
      if (tid == child) break;
      continue;
    }
    int deliver = 0;
    const int stop = WSTOPSIG(status);
    if (stop == (SIGTRAP | 0x80)) {
      if (in_call.erase(tid) == 0) {
        in_call.insert(tid);
        user_regs_struct regs{};
        ptrace(PTRACE_GETREGS, tid, nullptr, &regs);
        if (regs.orig_rax == SYS_write && !*killed) {
          char target[PATH_MAX] = {};
          const std::string fd = "/proc/" + std::to_string(child) + "/fd/" +
                                 std::to_string(static_cast<int>(regs.rdi));
          const ssize_t n = readlink(fd.c_str(), target, sizeof target - 1);
          if (n > 0 && watched == std::string(target, static_cast<std::size_t>(n)) &&
              ++writes == nth) {
            kill(child, SIGKILL);
            *killed = true;
          }
        }
      }
    } else if (stop == SIGTRAP && (status >> 16) != 0) {
      // A ptrace event (a new thread, the exec): nothing to deliver.
    } else if (stop == SIGSTOP && known.insert(tid).second) {
      // A new thread's first stop.
    } else {
      deliver = stop;
    }
    ptrace(PTRACE_SYSCALL, tid, nullptr, reinterpret_cast<void*>(static_cast<long>(deliver)));
  }
  return writes;
#else
  (void)argv;
  (void)file;
  (void)nth;
  return 0;
#endif
}

}  // namespace placedb::testing
