// Child process of the reliability tests: maps the crash scenario into MAP, resuming the map's
// last session when there is one, and reports on stdout, one flushed line each:
//   ready <first source index>
//   frame <source index> <frame id>
//   tx                                     (--slow-transactions: a write transaction started)
//   commit                                 (--slow-transactions: its COMMIT is under way)
//   done
//   error <ErrorCode number> <message>     (then exit status 3)
// Options: --frames N (sequence length), --stop-after K (frames this run), --hold-ms X (pause
// after each frame, so a test can act while the map is open), --uid U (drop root, for read-only
// files), --fsize-limit BYTES (RLIMIT_FSIZE: a disk that fills up), --slow-transactions 1 (SQLite
// hooks stretch every write transaction and say when one is open, so that a kill lands inside
// transactions often and the test knows when it did).
#include <sqlite3.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <string>
#include <thread>

#include "crash_scenario.h"
#include "placedb/map.h"

namespace {

// SQLite hooks on every connection the engine opens. The update hook runs once per changed row,
// inside the transaction; the commit hook runs when COMMIT starts, before it is durable.
bool in_transaction = false;

void say(const char* line) {
  std::printf("%s\n", line);
  std::fflush(stdout);
}

void onRowChange(void*, int, const char*, const char*, sqlite3_int64) {
  if (!in_transaction) say("tx");
  in_transaction = true;
  std::this_thread::sleep_for(std::chrono::microseconds(60));
}

int onCommit(void*) {
  say("commit");
  in_transaction = false;
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  return 0;  // go ahead
}

void onRollback(void*) { in_transaction = false; }

int installHooks(sqlite3* db, const char**, const sqlite3_api_routines*) {
  sqlite3_update_hook(db, onRowChange, nullptr);
  sqlite3_commit_hook(db, onCommit, nullptr);
  sqlite3_rollback_hook(db, onRollback, nullptr);
  return SQLITE_OK;
}

int fail(int code, const std::string& message) {
  std::printf("error %d %s\n", code, message.c_str());
  std::fflush(stdout);
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return fail(2, "usage: crash_mapper MAP [--frames N] [--stop-after K] ...");
  const std::string map_path = argv[1];
  int frames = 100, stop_after = -1, hold_ms = 0;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const long long value = std::stoll(argv[i + 1]);
    if (flag == "--frames") {
      frames = static_cast<int>(value);
    } else if (flag == "--stop-after") {
      stop_after = static_cast<int>(value);
    } else if (flag == "--slow-transactions") {
      if (value) sqlite3_auto_extension(reinterpret_cast<void (*)()>(installHooks));
    } else if (flag == "--hold-ms") {
      hold_ms = static_cast<int>(value);
    } else if (flag == "--uid") {
      if (setgid(static_cast<gid_t>(value)) != 0 || setuid(static_cast<uid_t>(value)) != 0)
        return fail(10, "cannot drop privileges");
    } else if (flag == "--fsize-limit") {
      std::signal(SIGXFSZ, SIG_IGN);  // a write past the limit then fails with EFBIG instead
      rlimit limit{static_cast<rlim_t>(value), static_cast<rlim_t>(value)};
      if (setrlimit(RLIMIT_FSIZE, &limit) != 0) return fail(10, "cannot set RLIMIT_FSIZE");
    } else {
      return fail(2, "unknown flag " + flag);
    }
  }
  try {
    placedb::synthetic::SyntheticSequence sequence(placedb::testing::crashSequenceOptions(frames));
    auto map = placedb::Map::open(map_path, placedb::testing::crashMapOptions());
    int first = 0;
    if (auto last = map->lastSession()) {
      map->resumeSession(last->id);
      first = last->last_source_index ? static_cast<int>(*last->last_source_index) + 1 : 0;
    } else {
      map->beginSession("crash scenario");
    }
    std::printf("ready %d\n", first);
    std::fflush(stdout);
    int done = 0;
    for (int i = first; i < sequence.size() && done != stop_after; ++i, ++done) {
      auto result = map->process(sequence.render(i), i, "frame " + std::to_string(i));
      std::printf("frame %d %lld\n", i, static_cast<long long>(result.frame_id));
      std::fflush(stdout);
      if (hold_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(hold_ms));
    }
    map->close();
    std::printf("done\n");
    std::fflush(stdout);
    return 0;
  } catch (const placedb::Error& e) {
    return fail(static_cast<int>(e.code()), e.what());
  } catch (const std::exception& e) {
    return fail(static_cast<int>(placedb::ErrorCode::kInternal), e.what());
  }
}
