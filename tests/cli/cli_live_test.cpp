// Live sources: a stream served on the loopback address by a process the test starts (a camera
// would need the v4l2loopback kernel module, which a test machine rarely has). Each frame placedb
// takes is the newest; frames that arrive while it is busy are dropped and counted; SIGINT closes
// the session cleanly; a live source always starts a new session.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/resource.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <thread>

#include "child_process.h"
#include "cli_scratch.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// The sequence's images as JPEG files, the stream's frames.
std::vector<std::string> jpegFrames(const fs::path& seq, const fs::path& dir, int count) {
  std::vector<std::string> files;
  for (int i = 0; i < count; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d", i);
    const cv::Mat image = cv::imread((seq / "images" / (std::string(name) + ".png")).string());
    const fs::path jpeg = dir / (std::string(name) + ".jpg");
    cv::imwrite(jpeg.string(), image, {cv::IMWRITE_JPEG_QUALITY, 95});
    files.push_back(jpeg.string());
  }
  return files;
}

// A stream of `fps` frames a second for `seconds` seconds, with the server's `faults`
// (serve_mjpeg.py: --parts, --garbage-at, --huge-at, --stall-after); returns the server and its
// URL.
std::pair<std::unique_ptr<ChildProcess>, std::string> serve(
    const std::vector<std::string>& frames, double fps, double seconds,
    const std::vector<std::string>& faults = {}) {
  std::vector<std::string> args = {"/usr/bin/python3", PLACEDB_MJPEG_SERVER, std::to_string(fps),
                                   std::to_string(seconds)};
  args.insert(args.end(), frames.begin(), frames.end());
  args.insert(args.end(), faults.begin(), faults.end());
  auto server = std::make_unique<ChildProcess>(args);
  const auto port = server->readLine(10000);
  EXPECT_TRUE(port) << "the stream server did not start";
  return {std::move(server), "http://127.0.0.1:" + port.value_or("0") + "/stream.mjpg"};
}

std::int64_t count(const fs::path& map, const std::string& sql) {
  sqlite3* db = nullptr;
  sqlite3_open(map.c_str(), &db);
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr);
  const std::int64_t value = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : -1;
  sqlite3_finalize(s);
  sqlite3_close(db);
  return value;
}

// A stream faster than --fps lets placedb take frames: it takes about fps a second, drops the
// rest and says how many; when the stream ends, the session ends.
TEST(CliLive, StreamFramesAreTheNewestAndTheRestAreCountedAsDropped) {
  auto seq = smallSequence(20);
  auto dir = scratchDir("CliLive_stream");
  auto [server, url] = serve(jpegFrames(seq, dir, 20), /*fps=*/25, /*seconds=*/4);
  const fs::path map = dir / "live.placedb";
  const auto r =
      placedb({"map", map.string(), url, "--fps", "5", "--log", (dir / "live.csv").string()}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(r.err, m, std::regex("(\\d+) frames .*; (\\d+) dropped while busy")))
      << r.err;
  const int processed = std::stoi(m[1]), dropped = std::stoi(m[2]);
  // ~4 s at 5 a second of a 25-a-second stream (the stream's start and end blur the edges).
  EXPECT_GE(processed, 8) << r.err;
  EXPECT_LE(processed, 30) << r.err;
  EXPECT_GE(dropped, processed) << r.err;  // 25 a second offered, at most 5 a second taken
  EXPECT_EQ(count(map, "SELECT count(*) FROM frames"), processed);
  EXPECT_EQ(count(map, "SELECT count(*) FROM frames WHERE outcome = 2"), 0);
  EXPECT_EQ(count(map, "SELECT clean_close FROM sessions"), 1);
  server->exitCode();
}

// Ctrl-C while the stream still runs: the frame in flight finishes, the session is closed
// cleanly, exit 0; the next run over the same stream starts a new session.
TEST(CliLive, InterruptClosesTheSessionCleanlyAndTheNextRunIsANewSession) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliLive_interrupt");
  const auto frames = jpegFrames(seq, dir, 10);
  const fs::path map = dir / "live.placedb";
  for (int run = 1; run <= 2; ++run) {
    auto [server, url] = serve(frames, 10, 60);
    Process mapping({PLACEDB_CLI_BINARY, "map", map.string(), url}, dir);
    std::this_thread::sleep_for(std::chrono::seconds(3));
    mapping.signal(SIGINT);
    const auto r = mapping.wait();
    EXPECT_EQ(r.exit_code, 0) << describe(r);
    EXPECT_NE(r.err.find("stopped by SIGINT; the session is closed"), std::string::npos) << r.err;
    EXPECT_EQ(count(map, "SELECT count(*) FROM sessions"), run);
    EXPECT_EQ(count(map, "SELECT min(clean_close) FROM sessions"), 1);
    EXPECT_GT(count(map, "SELECT count(*) FROM frames WHERE session_id = " + std::to_string(run)),
              3);
    server->kill();
    server->exitCode();
  }
}

// The frames and dropped frames of a run's summary line.
std::pair<int, int> takenAndDropped(const std::string& err) {
  std::smatch m;
  if (!std::regex_search(err, m, std::regex("(\\d+) frames .*; (\\d+) dropped while busy")))
    return {-1, -1};
  return {std::stoi(m[1]), std::stoi(m[2])};
}

// A part that is no image is a bad frame, and the stream goes on to its end: every part sent is
// either taken or dropped. (FFmpeg ended the session there, as "end of source".)
TEST(CliLive, APartThatIsNoImageIsABadFrameAndTheStreamGoesOn) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliLive_garbage");
  auto [server, url] =
      serve(jpegFrames(seq, dir, 10), 10, 60, {"--parts", "30", "--garbage-at", "3"});
  const fs::path map = dir / "live.placedb";
  const auto r = placedb({"map", map.string(), url}, dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.err.find("(end of source)"), std::string::npos) << r.err;
  const auto [taken, dropped] = takenAndDropped(r.err);
  EXPECT_EQ(taken + dropped, 30) << r.err;
  EXPECT_EQ(count(map, "SELECT count(*) FROM frames"), taken);
  // Taken, the part is a bad frame with a warning naming it.
  const std::int64_t bad = count(map, "SELECT count(*) FROM frames WHERE outcome = 2");
  EXPECT_LE(bad, 1);
  if (bad == 1) {
    EXPECT_NE(r.err.find("that is no image; recorded as a bad frame"), std::string::npos) << r.err;
  }
  server->exitCode();
}

// A part announcing 200 MB is skipped from its header: it is never held in memory (FFmpeg took
// ~500 MB for it and ended the session), and the stream goes on.
// The bound is against the same stream without that part, run first: a build's own footprint
// (a sanitized one's shadow memory is twice a release build's whole run) is not what is measured.
TEST(CliLive, APartOverTheImageLimitIsSkippedFromItsHeader) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliLive_huge");
  const auto frames = jpegFrames(seq, dir, 10);
  const auto peakOfChildren = [] {
    rusage usage{};
    EXPECT_EQ(getrusage(RUSAGE_CHILDREN, &usage), 0);
    return static_cast<std::int64_t>(usage.ru_maxrss);  // KiB, the largest child reaped so far
  };
  {
    auto [server, url] = serve(frames, 10, 60, {"--parts", "20"});
    const auto r = placedb({"map", (dir / "plain.placedb").string(), url}, dir);
    EXPECT_EQ(r.exit_code, 0) << describe(r);
    server->exitCode();
  }
  const std::int64_t plain_kib = peakOfChildren();
  auto [server, url] = serve(frames, 10, 60, {"--parts", "20", "--huge-at", "2"});
  const fs::path map = dir / "live.placedb";
  const auto r = placedb({"map", map.string(), url}, dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  const auto [taken, dropped] = takenAndDropped(r.err);
  EXPECT_EQ(taken + dropped, 20) << r.err;
  EXPECT_NE(r.err.find("(end of source)"), std::string::npos) << r.err;
  server->exitCode();
  // Holding the part would take its 200 MB: half of it is the margin.
  EXPECT_LT(peakOfChildren(), plain_kib + 100 * 1024)
      << "KiB at most in a child (placedb or the server); without the part: " << plain_kib;
}

// A stream that stops sending without ending is its own end: a warning, the session closed with
// every frame, exit 14. (It read as "end of source", exit 0.)
TEST(CliLive, AStalledStreamEndsWithAWarningAndExit14) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliLive_stall");
  auto [server, url] = serve(jpegFrames(seq, dir, 10), 10, 60, {"--stall-after", "4"});
  const fs::path map = dir / "live.placedb";
  const auto r = placedb({"map", map.string(), url}, dir);
  EXPECT_EQ(r.exit_code, 14) << describe(r);
  EXPECT_NE(r.err.find("placedb: warning: live source " + url + " sent nothing for 5 s"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(stalled: the stream sent nothing)"), std::string::npos) << r.err;
  const auto [taken, dropped] = takenAndDropped(r.err);
  EXPECT_EQ(taken + dropped, 4) << r.err;
  EXPECT_EQ(count(map, "SELECT clean_close FROM sessions"), 1);
  server->kill();
  server->exitCode();
}

// Ctrl-C while `map` waits for the stream's next frame says it stopped, not that the source
// ended. The stream sends one frame and then nothing: once that frame is in the map, map waits.
TEST(CliLive, InterruptWhileWaitingForAFrameSaysStopped) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliLive_interrupt_waiting");
  auto [server, url] = serve(jpegFrames(seq, dir, 10), 10, 60, {"--stall-after", "1"});
  const fs::path map = dir / "live.placedb";
  Process mapping({PLACEDB_CLI_BINARY, "map", map.string(), url}, dir);
  for (int tries = 0;
       tries < 400 && !(fs::exists(map) && count(map, "SELECT count(*) FROM frames") == 1); ++tries)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  mapping.signal(SIGINT);
  const auto r = mapping.wait();
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.err.find("(stopped by SIGINT; the session is closed)"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("end of source"), std::string::npos) << r.err;
  EXPECT_EQ(count(map, "SELECT clean_close FROM sessions"), 1);
  server->kill();
  server->exitCode();
}

TEST(CliLive, UnreachableStreamAndMisplacedOptionsAreOneLine) {
  auto seq = smallSequence(3);
  auto dir = scratchDir("CliLive_refused");
  const auto map = (dir / "m.placedb").string();
  // An HTTP stream is placedb's own MJPEG reader's, which names the socket's error; any other
  // goes to FFmpeg, whose failure is named with what it may mean.
  const auto stream = placedb({"map", map, "http://127.0.0.1:9/none.mjpg"}, dir);
  expectCleanError(stream, 3, "http://127.0.0.1:9/none.mjpg: Connection refused");
  const auto rtsp = placedb({"map", map, "rtsp://127.0.0.1:9/none"}, dir);
  expectCleanError(rtsp, 3, "rtsp://127.0.0.1:9/none");
  EXPECT_TRUE(rtsp.err.find("FFmpeg could not open it") != std::string::npos ||
              rtsp.err.find("no FFmpeg backend") != std::string::npos)
      << rtsp.err;
  // A camera that is not there: the device tried, and the cameras there are.
  const auto camera = placedb({"map", map, "camera:99"}, dir);
  expectCleanError(camera, 3, "cannot open live source camera:99: ");
  EXPECT_TRUE(camera.err.find("/dev/video99 does not exist (V4L2 devices here: ") !=
                  std::string::npos ||
              camera.err.find("no V4L2 backend") != std::string::npos)
      << camera.err;
  EXPECT_EQ(lines(camera.err).size(), 1u) << camera.err;
  expectCleanError(placedb({"map", map, (seq / "frames.txt").string(), "--fps", "5"}, dir), 2,
                   "--fps");
  EXPECT_FALSE(fs::exists(map));
}

}  // namespace
}  // namespace placedb::testing
