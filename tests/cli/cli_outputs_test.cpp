// Every whole file the command line writes (a vocabulary, a graph export, a report page, a
// figure) goes through one writer: a device or a FIFO at the path is written, never replaced; a
// symbolic link's target is replaced, never the link; a regular file is replaced whole.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <thread>

#include "cli_scratch.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// A map of a short sequence and its run log, shared by the tests of this file.
struct MappedRun {
  fs::path dir, map, log, gt;
};

MappedRun mappedRun(const std::string& name) {
  auto seq = smallSequence(12);
  MappedRun run{scratchDir(name), {}, {}, seq / "gt_pairs.txt"};
  run.map = run.dir / "m.placedb";
  run.log = run.dir / "run.csv";
  const auto r = placedb(
      {"map", run.map.string(), (seq / "frames.txt").string(), "--log", run.log.string(), "-q"},
      run.dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  return run;
}

// Each writer of a whole file, as the arguments that make it write `out` (a file, or for the
// report and the figures a folder's file of that name).
struct Writer {
  std::string name;
  std::vector<std::string> args;
  fs::path output;  // the file the writer writes, where the test puts a link or a device
};

std::vector<Writer> writers(const MappedRun& run, const fs::path& out_dir) {
  const std::string map = run.map.string();
  return {
      {"vocab export",
       {"vocab", "export", map, (out_dir / "words.pvoc").string()},
       out_dir / "words.pvoc"},
      {"vocab export --text",
       {"vocab", "export", map, (out_dir / "words.txt").string(), "--format", "rtabmap"},
       out_dir / "words.txt"},
      {"export g2o", {"export", map, (out_dir / "g.g2o").string()}, out_dir / "g.g2o"},
      {"export graphml", {"export", map, (out_dir / "g.graphml").string()}, out_dir / "g.graphml"},
      {"report",
       {"report", map, run.log.string(), "--out", (out_dir / "report").string()},
       out_dir / "report" / "index.html"},
      {"eval --plots",
       {"eval", run.log.string(), run.gt.string(), "--plots", (out_dir / "plots").string()},
       out_dir / "plots" / "time.png"},
      {"eval loop matrix",
       {"eval", run.log.string(), run.gt.string(), "--plots", (out_dir / "plots").string()},
       out_dir / "plots" / "loop_matrix.png"},
  };
}

TEST(CliOutputs, ASymbolicLinkKeepsBeingALinkAndItsTargetIsWritten) {
  const MappedRun run = mappedRun("CliOutputs_link");
  // What each writer writes to a plain file, to compare with what it writes through a link.
  const fs::path plain = run.dir / "plain";
  fs::create_directories(plain);
  for (const auto& w : writers(run, plain)) {
    const auto r = placedb(w.args, run.dir);
    ASSERT_EQ(r.exit_code, 0) << w.name << ": " << describe(r);
    ASSERT_TRUE(fs::is_regular_file(w.output)) << w.name;
  }
  const fs::path linked = run.dir / "linked", targets = run.dir / "targets";
  for (const auto& w : writers(run, linked)) {
    fs::remove_all(linked);
    fs::remove_all(targets);
    fs::create_directories(w.output.parent_path());
    fs::create_directories(targets);
    const fs::path target = targets / "target";
    std::ofstream(target) << "older contents\n";
    fs::create_symlink(fs::relative(target, w.output.parent_path()), w.output);
    const auto r = placedb(w.args, run.dir);
    ASSERT_EQ(r.exit_code, 0) << w.name << ": " << describe(r);
    EXPECT_TRUE(fs::is_symlink(fs::symlink_status(w.output))) << w.name << " replaced the link";
    const fs::path same = plain / fs::relative(w.output, linked);
    if (w.name.rfind("report", 0) == 0 || w.name.rfind("eval", 0) == 0)
      EXPECT_NE(bytesOf(target), "older contents\n") << w.name;  // a page, a figure: new bytes
    else
      EXPECT_EQ(bytesOf(target), bytesOf(same)) << w.name << " did not write the link's target";
    for (const auto& entry : fs::directory_iterator(targets))
      EXPECT_EQ(entry.path().filename(), "target") << w.name << " left " << entry.path();
  }
}

// A FIFO at the path is written, as a reader on the other end expects; before, vocab export
// renamed a regular file over it.
TEST(CliOutputs, AFifoIsWrittenNotReplaced) {
  const MappedRun run = mappedRun("CliOutputs_fifo");
  ASSERT_EQ(
      placedb({"vocab", "export", run.map.string(), (run.dir / "plain.pvoc").string()}, run.dir)
          .exit_code,
      0);
  ASSERT_EQ(
      placedb({"export", run.map.string(), (run.dir / "plain.g2o").string()}, run.dir).exit_code,
      0);
  for (const std::string name : {"words.pvoc", "graph.g2o"}) {
    const fs::path fifo = run.dir / name;
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
    // The reading end, open before the run (so that the run's open does not wait for one), read
    // until the writer closes it or the run is over, whichever comes first.
    const int fd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    std::atomic<bool> finished{false};
    auto reader = std::async(std::launch::async, [fd, &finished] {
      std::string got;
      char buffer[65536];
      for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n > 0) {
          got.append(buffer, static_cast<std::size_t>(n));
        } else if ((n == 0 && !got.empty()) || finished) {
          break;  // the writer closed its end, or there never was one
        } else {
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      }
      return got;
    });
    const bool vocabulary = name == "words.pvoc";
    const auto r = placedb(
        vocabulary ? std::vector<std::string>{"vocab", "export", run.map.string(), fifo.string()}
                   : std::vector<std::string>{"export", run.map.string(), fifo.string(), "--format",
                                              "g2o"},
        run.dir);
    finished = true;
    const std::string read = reader.get();
    ::close(fd);
    EXPECT_EQ(r.exit_code, 0) << describe(r);
    struct stat st {};
    ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode)) << name << " was replaced";
    EXPECT_EQ(read, bytesOf(run.dir / (vocabulary ? "plain.pvoc" : "plain.g2o"))) << name;
  }
}

// A full device (a node like /dev/full, made in the scratch folder): every export reports the
// full disk, exit 7, and the node stays a device. Before, vocab export replaced it with a
// regular file and said it had written the words.
TEST(CliOutputs, AFullDeviceIsExitSevenAndStaysADevice) {
  const MappedRun run = mappedRun("CliOutputs_device");
  const fs::path full = run.dir / "full";
  if (::mknod(full.c_str(), S_IFCHR | 0666, makedev(1, 7)) != 0)
    GTEST_SKIP() << "cannot make a device node here (needs CAP_MKNOD)";
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"vocab", "export", run.map.string(), full.string()},
           {"vocab", "export", run.map.string(), full.string(), "--text"},
           {"export", run.map.string(), full.string(), "--format", "g2o"}}) {
    const auto r = placedb(args, run.dir);
    expectCleanError(r, 7, full.string());
    struct stat st {};
    ASSERT_EQ(::lstat(full.c_str(), &st), 0);
    EXPECT_TRUE(S_ISCHR(st.st_mode)) << args[0] << " " << args[1] << " replaced the device";
  }
}

}  // namespace
}  // namespace placedb::testing
