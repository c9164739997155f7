// Sessions as `placedb map` tells them to a user (issue #50): an unfinished session that can no
// longer resume is named in one line with the way out, "run again to resume" is printed only
// when the next run will, --quiet keeps the summary, and the lines name frames alike.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>

#include "cli_scratch.h"
#include "file_bytes.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// A list file of the first `count` images of `seq`, in a folder of its own: another source.
std::string listOf(const fs::path& seq, const fs::path& folder, int count) {
  fs::create_directories(folder);
  std::ifstream in(seq / "frames.txt");
  std::ofstream out(folder / "frames.txt");
  std::string line;
  for (int i = 0; i < count && std::getline(in, line); ++i) out << (seq / line).string() << "\n";
  return (folder / "frames.txt").string();
}

// Session 1 over A stops early; session 2 over B comes after it. Mapping A again cannot finish
// session 1 (its memory went on into session 2): one line says which session is unfinished and
// what --new-session does, and nothing is written.
TEST(CliSessions, AnUnfinishedSessionThatCannotResumeIsNamedInOneLine) {
  const auto seq = smallSequence(12);
  const auto dir = scratchDir("CliSessions_unfinished");
  const std::string map = (dir / "m.placedb").string();
  const std::string a = (seq / "frames.txt").string();
  const std::string b = listOf(seq, dir / "b", 4);
  auto first = placedb({"map", map, a, "--stop-after", "5"}, dir);
  ASSERT_EQ(first.exit_code, 0) << describe(first);
  auto second = placedb({"map", map, b, "-q"}, dir);
  ASSERT_EQ(second.exit_code, 0) << describe(second);

  const std::string before = readBytes(map);
  auto again = placedb({"map", map, a, "--log", (dir / "again.csv").string()}, dir);
  expectCleanError(again, 2, "session 1 of " + map);
  EXPECT_EQ(lines(again.err).size(), 1u) << again.err;
  EXPECT_NE(again.err.find("unfinished (5 of 12 frames mapped)"), std::string::npos) << again.err;
  EXPECT_NE(again.err.find("session 2 began after it"), std::string::npos) << again.err;
  EXPECT_NE(again.err.find("--new-session"), std::string::npos) << again.err;
  EXPECT_EQ(readBytes(map), before);
  EXPECT_FALSE(fs::exists(dir / "again.csv"));

  auto fresh = placedb({"map", map, a, "--new-session", "--stop-after", "2"}, dir);
  ASSERT_EQ(fresh.exit_code, 0) << describe(fresh);
  EXPECT_NE(fresh.err.find("starting session 3"), std::string::npos) << fresh.err;
  EXPECT_NE(fresh.err.find("from frame 0"), std::string::npos) << fresh.err;
}

// "run again to resume" only when the next run resumes: --stop-after that ends exactly at the
// source's end finishes the session, and the next run starts a new one, as the summary said.
TEST(CliSessions, TheSummarySaysWhatTheNextRunDoes) {
  const auto seq = smallSequence(8);
  const auto dir = scratchDir("CliSessions_summary");
  const std::string map = (dir / "m.placedb").string();
  const std::string source = (seq / "frames.txt").string();

  auto stopped = placedb({"map", map, source, "--stop-after", "3"}, dir);
  ASSERT_EQ(stopped.exit_code, 0) << describe(stopped);
  EXPECT_NE(stopped.err.find("run the same command again to resume at frame 3"), std::string::npos)
      << stopped.err;
  auto resumed = placedb({"map", map, source, "--stop-after", "5"}, dir);
  ASSERT_EQ(resumed.exit_code, 0) << describe(resumed);
  EXPECT_NE(resumed.err.find("resuming session 1"), std::string::npos) << resumed.err;
  // Frames 3..7 were all that was left: the session is finished, whatever --stop-after says.
  EXPECT_NE(resumed.err.find("(end of source)"), std::string::npos) << resumed.err;
  EXPECT_EQ(resumed.err.find("resume at frame"), std::string::npos) << resumed.err;
  auto next = placedb({"map", map, source, "--stop-after", "1"}, dir);
  ASSERT_EQ(next.exit_code, 0) << describe(next);
  EXPECT_NE(next.err.find("starting session 2"), std::string::npos) << next.err;
}

// --quiet drops the progress, the start line and the closure lines, and keeps the one-line
// summary; the progress line counts the locations this run added and says so.
TEST(CliSessions, QuietKeepsTheSummaryAndProgressSaysNewLocations) {
  const auto seq = smallSequence(6);
  const auto dir = scratchDir("CliSessions_quiet");
  const std::string source = (seq / "frames.txt").string();
  auto quiet = placedb({"map", (dir / "q.placedb").string(), source, "-q"}, dir);
  ASSERT_EQ(quiet.exit_code, 0) << describe(quiet);
  ASSERT_EQ(lines(quiet.err).size(), 1u) << quiet.err;
  EXPECT_EQ(quiet.err.rfind("placedb: session 1: 6 frames", 0), 0u) << quiet.err;
  EXPECT_NE(quiet.err.find("(end of source)"), std::string::npos) << quiet.err;

  auto loud = placedb({"map", (dir / "l.placedb").string(), source}, dir);
  ASSERT_EQ(loud.exit_code, 0) << describe(loud);
  EXPECT_TRUE(std::regex_search(loud.err, std::regex("  new locations [0-9]+  WM "))) << loud.err;
}

// Every frame a closure line names is SESSION:INDEX, this session's as another's: a second
// session over the same images closes loops onto the first.
TEST(CliSessions, ClosureLinesNameEveryFrameAsSessionColonIndex) {
  const auto seq = smallSequence(30);
  const auto dir = scratchDir("CliSessions_closures");
  const std::string map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  auto second = placedb({"map", map, listOf(seq, dir / "again", 30)}, dir);
  ASSERT_EQ(second.exit_code, 0) << describe(second);
  const std::regex closure(
      "placedb: frame 2:[0-9]+ closes a loop on frames? [0-9]+:[0-9]+( [0-9]+:[0-9]+)* "
      "\\(location [0-9]+, score [0-9.]+, [0-9]+ inliers\\)");
  int closures = 0, onto_first = 0;
  for (const auto& line : lines(second.err)) {
    if (line.find("closes a loop") == std::string::npos) continue;
    ++closures;
    EXPECT_TRUE(std::regex_match(line, closure)) << line;
    onto_first += line.find(" on frame 1:") != std::string::npos ||
                  line.find(" on frames 1:") != std::string::npos;
  }
  EXPECT_GT(onto_first, 0) << second.err;
  EXPECT_GT(closures, 0);
}

}  // namespace
}  // namespace placedb::testing
