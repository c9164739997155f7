// Faults around a running or finished mapper: a second writer, readers during mapping, a disk
// that fills up, a map file that cannot be written.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/stat.h>

#include <cstdio>
#include <memory>

#include "crash_scenario.h"
#include "placedb/map.h"
#include "reliability_support.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// Lines until one starting with `prefix` (returned), or nullopt at the end of output.
std::optional<std::string> readUntil(ChildProcess& child, const std::string& prefix) {
  while (auto line = child.readLine(60000))
    if (line->rfind(prefix, 0) == 0) return line;
  return std::nullopt;
}

std::string shellOutput(const std::string& command, int& status) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) {
    status = -1;
    return out;
  }
  char buffer[256];
  while (fgets(buffer, sizeof buffer, pipe)) out += buffer;
  status = pclose(pipe);
  return out;
}

TEST(Concurrency, SecondWriterIsRefusedWhileReadersWorkOnBothSides) {
  const auto dir = scratchDir("ConcurrencyEngine");
  const auto map = dir / "busy.placedb";
  ChildProcess writer(mapperArgs(map, {"--frames", "30", "--hold-ms", "40"}));
  ASSERT_TRUE(readUntil(writer, "frame ")) << "the mapper never committed a frame";

  // A second mapper, in this process and in another one.
  try {
    Map::open(map.string(), crashMapOptions());
    ADD_FAILURE() << "a second writer was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kMapBusy) << e.what();
    EXPECT_NE(std::string(e.what()).find(map.string()), std::string::npos) << e.what();
  }
  {
    ChildProcess second(mapperArgs(map, {"--frames", "30"}));
    auto line = readUntil(second, "error ");
    ASSERT_TRUE(line) << "the second mapper was not refused";
    EXPECT_EQ(line->rfind("error 5 ", 0), 0u) << *line;
    EXPECT_NE(line->find(map.string()), std::string::npos) << *line;
    EXPECT_EQ(WEXITSTATUS(second.wait()), 3);
  }

  // Readers while the writer commits: the sqlite3 shell, and a localisation map.
  std::int64_t seen = 0;
  int reads = 0;
  while (reads < 8) {
    int status = 0;
    const std::string out =
        shellOutput(std::string("sqlite3 ") + (reads % 2 ? "-readonly " : "") + "'" + map.string() +
                        "' 'select count(*) from frames' 2>&1",
                    status);
    ASSERT_EQ(status, 0) << out;
    const std::int64_t count = std::stoll(out);
    EXPECT_GE(count, seen) << "a reader saw committed frames disappear";
    seen = count;
    ++reads;
  }
  auto reader = Map::open(map.string(), crashMapOptions(), Map::Mode::kLocalisation);
  EXPECT_GE(reader->lastSession()->frames, seen);
  synthetic::SyntheticSequence sequence(crashSequenceOptions(30));
  const QueryResult found = reader->query(sequence.render(0), 3);
  ASSERT_FALSE(found.matches.empty()) << "localisation beside a running writer";
  reader.reset();

  auto done = readUntil(writer, "done");
  ASSERT_TRUE(done) << "the writer did not finish while readers were reading";
  EXPECT_EQ(WEXITSTATUS(writer.wait()), 0);
  EXPECT_EQ(integrityCheck(map), "ok");
  EXPECT_EQ(storedFrames(map).size(), 30u);
}

// Maps until the disk fills; returns the error line and sets `committed` to the frames reported.
std::optional<std::string> mapUntilFull(const fs::path& map, std::vector<std::string> args,
                                        std::int64_t& committed) {
  ChildProcess child(mapperArgs(map, std::move(args)));
  std::optional<std::string> error;
  while (auto line = child.readLine(60000)) {
    if (line->rfind("frame ", 0) == 0) committed = std::stoll(line->substr(6)) + 1;
    if (line->rfind("error ", 0) == 0) error = line;
  }
  child.wait();
  return error;
}

// A small tmpfs that really fills up (ENOSPC). Needs the right to mount: skipped without it.
class SmallDisk {
 public:
  explicit SmallDisk(const fs::path& where) : where_(where) {
    fs::create_directories(where);
    mounted_ = mount("placedb-test", where.c_str(), "tmpfs", 0, "size=3m") == 0;
  }
  ~SmallDisk() {
    if (mounted_) umount2(where_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  bool grow() {
    return mount("placedb-test", where_.c_str(), "tmpfs", MS_REMOUNT, "size=64m") == 0;
  }

 private:
  fs::path where_;
  bool mounted_ = false;
};

TEST(DiskFull, FullFilesystemFailsTheFrameWithDiskFullAndKeepsCommittedFrames) {
  const auto dir = scratchDir("DiskFullTmpfs");
  SmallDisk disk(dir / "disk");
  if (!disk.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here (needs CAP_SYS_ADMIN)";
  const auto map = dir / "disk" / "full.placedb";
  std::int64_t committed = 0;
  auto error = mapUntilFull(map, {"--frames", "100"}, committed);
  ASSERT_TRUE(error) << "3 MiB never filled up";
  EXPECT_EQ(error->rfind("error 7 ", 0), 0u) << "kDiskFull expected: " << *error;
  EXPECT_NE(error->find(map.string()), std::string::npos) << "name the map: " << *error;
  EXPECT_GT(committed, 0);
  EXPECT_LT(committed, 100);
  ASSERT_EQ(integrityCheck(map), "ok");
  EXPECT_EQ(std::int64_t(storedFrames(map).size()), committed);

  // With room again, the session resumes where the disk filled, and ends complete.
  ASSERT_TRUE(disk.grow());
  auto lines = runMapper(map, {"--frames", "100"});
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.front(), "ready " + std::to_string(committed));
  EXPECT_EQ(storedFrames(map).size(), 100u);
}

// The same with a file size limit (RLIMIT_FSIZE), which needs no privilege. SQLite then sees
// EFBIG, and reports SQLITE_IOERR_WRITE rather than SQLITE_FULL: the data must be just as safe.
std::optional<std::string> fillBySizeLimit(const fs::path& map, std::int64_t& committed) {
  runMapper(map, {"--frames", "40", "--stop-after", "10"});
  EXPECT_FALSE(fs::exists(map.string() + "-wal")) << "a clean close checkpoints the log";
  // The write-ahead log may grow by about 150 kB before the limit stops it.
  const auto limit = fs::file_size(map) + 150 * 1024 + 1234;
  committed = 10;
  return mapUntilFull(map, {"--frames", "40", "--fsize-limit", std::to_string(limit)}, committed);
}

// The limit can stop a checkpoint half-way through a page, leaving the main file ragged beside an
// intact write-ahead log: the map must still open, hold every committed frame and resume.
TEST(DiskFull, FileSizeLimitFailsTheFrameAndKeepsTheMapOpenable) {
  const auto map = scratchDir("DiskFullLimit") / "full.placedb";
  std::int64_t committed = 0;
  auto error = fillBySizeLimit(map, committed);
  ASSERT_TRUE(error) << "the limit was never reached";
  EXPECT_TRUE(error->rfind("error 7 ", 0) == 0 || error->rfind("error 3 ", 0) == 0)
      << "kDiskFull or kIo expected: " << *error;
  EXPECT_NE(error->find(map.string()), std::string::npos) << "name the map: " << *error;
  EXPECT_LT(committed, 40);
  ASSERT_EQ(integrityCheck(map), "ok");
  EXPECT_EQ(std::int64_t(storedFrames(map).size()), committed);
  auto lines = runMapper(map, {"--frames", "40"});
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.front(), "ready " + std::to_string(committed));
  EXPECT_EQ(storedFrames(map).size(), 40u);
}

// SQLite reports a write past RLIMIT_FSIZE as SQLITE_IOERR_WRITE with an unreliable errno: the user
// must still hear "disk full".
TEST(DiskFull, FileSizeLimitIsReportedAsDiskFull) {
  const auto map = scratchDir("DiskFullLimitCode") / "full.placedb";
  std::int64_t committed = 0;
  auto error = fillBySizeLimit(map, committed);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->rfind("error 7 ", 0), 0u) << *error;
}

TEST(ReadOnly, ReadOnlyMapFileIsRefusedForMappingAndLeftAsItWas) {
  const auto dir = scratchDir("ReadOnlyEngine");
  fs::permissions(dir, fs::perms::all);  // only the file is read-only
  const auto map = dir / "ro.placedb";
  runMapper(map, {"--frames", "20", "--stop-after", "5"});
  fs::remove(map.string() + "-lock");
  ASSERT_FALSE(fs::exists(map.string() + "-wal"));
  fs::permissions(map, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  const std::string before = readBytes(map);

  // As an unprivileged user (root writes through file permissions).
  ChildProcess child(mapperArgs(map, {"--uid", "65534", "--frames", "20"}));
  auto line = readUntil(child, "error ");
  child.wait();
  ASSERT_TRUE(line) << "mapping a read-only map was accepted";
  EXPECT_EQ(line->rfind("error 6 ", 0), 0u) << "kReadOnly expected: " << *line;
  EXPECT_NE(line->find(map.string()), std::string::npos) << *line;
  EXPECT_EQ(readBytes(map), before);

  // Localisation only reads: it opens, and still changes nothing.
  {
    auto reader = Map::open(map.string(), crashMapOptions(), Map::Mode::kLocalisation);
    EXPECT_EQ(reader->lastSession()->frames, 5);
    EXPECT_THROW(reader->beginSession("x"), Error);
  }
  EXPECT_EQ(readBytes(map), before);
  fs::permissions(map, fs::perms::owner_write, fs::perm_options::add);
}

}  // namespace
}  // namespace placedb::testing
