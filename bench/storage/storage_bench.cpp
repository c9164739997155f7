// Map database throughput: bulk words and references in per-frame transactions, then random
// location loads. Prints figures; not a test.
//
//   storage_bench [--scale S] [--path FILE] [--keep]
// Scale 1 is 1,000,000 words of 64 floats and 10,000,000 references (100,000 locations x 100),
// written as 100,000 frame transactions of 10 new words and 100 references each.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "placedb/storage/map_files.h"
#include "placedb/storage/sqlite_map_store.h"

namespace {

using Clock = std::chrono::steady_clock;
using placedb::storage::MapStore;
using placedb::storage::SqliteMapStore;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double percentile(std::vector<double> values, double fraction) {
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(fraction * (values.size() - 1) + 0.5);
  return values[index];
}

}  // namespace

int main(int argc, char** argv) {
  double scale = 1.0;
  std::string path = (std::filesystem::temp_directory_path() / "placedb_storage_bench.db").string();
  bool keep = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--scale" && i + 1 < argc) {
      scale = std::atof(argv[++i]);
    } else if (arg == "--path" && i + 1 < argc) {
      path = argv[++i];
    } else if (arg == "--keep") {
      keep = true;
    } else {
      std::fprintf(stderr, "usage: %s [--scale S] [--path FILE] [--keep]\n", argv[0]);
      return 2;
    }
  }
  constexpr int kDim = 64, kWordsPerFrame = 10, kRefsPerLocation = 100, kLoads = 10000;
  const auto locations = std::max<std::int64_t>(1, static_cast<std::int64_t>(100000 * scale));
  placedb::storage::removeMap(path);

  std::mt19937_64 random(42);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  double words_seconds = 0, refs_seconds = 0, commit_seconds = 0;
  std::int64_t next_word = 1;
  const auto insert_start = Clock::now();
  try {
    SqliteMapStore store(path, placedb::storage::OpenMode::kReadWrite);
    const auto session = store.beginSession("bench", {{"scale", std::to_string(scale)}}, "bench");
    std::vector<float> values(kDim);
    for (std::int64_t frame = 1; frame <= locations; ++frame) {
      placedb::storage::Transaction tx = store.begin();
      placedb::storage::FrameRecord record;
      record.id = frame;
      record.session_id = session;
      record.source_index = frame - 1;
      record.location_id = frame;
      store.insertFrame(record);
      store.insertLocation({frame, session, 0, placedb::storage::Tier::kWm, frame});
      store.addCoveredFrame(frame, frame);

      std::vector<placedb::storage::WordRecord> words;
      words.reserve(kWordsPerFrame);
      for (int w = 0; w < kWordsPerFrame; ++w) {
        for (float& v : values) v = unit(random);
        words.push_back(
            placedb::storage::WordRecord::fromFloats(next_word++, frame, values.data(), kDim));
      }
      auto t = Clock::now();
      store.insertWords(words);
      words_seconds += secondsSince(t);

      // References mostly to words seen so far, like a signature reusing the vocabulary.
      std::uniform_int_distribution<std::int64_t> any_word(1, next_word - 1);
      std::vector<placedb::storage::WordRef> refs(kRefsPerLocation);
      for (auto& ref : refs) {
        ref = {any_word(random),       unit(random) * 640, unit(random) * 480,
               10 + unit(random) * 30, unit(random) * 360, unit(random)};
      }
      t = Clock::now();
      store.insertWordRefs(frame, refs);
      refs_seconds += secondsSince(t);
      t = Clock::now();
      tx.commit();
      commit_seconds += secondsSince(t);
    }
    const double insert_seconds = secondsSince(insert_start);
    const double word_rows = static_cast<double>(next_word - 1);
    const double ref_rows = static_cast<double>(locations) * kRefsPerLocation;
    std::printf("scale %.3g: %lld frames, %.0f words (%d floats), %.0f references\n", scale,
                static_cast<long long>(locations), word_rows, kDim, ref_rows);
    std::printf("insert total      %.1f s (%.0f frames/s, commits included)\n", insert_seconds,
                locations / insert_seconds);
    std::printf("commits           %.1f s, %.3f ms each\n", commit_seconds,
                commit_seconds * 1000 / locations);
    std::printf("words             %.0f rows/s (time inside insertWords)\n",
                word_rows / words_seconds);
    std::printf("references        %.0f rows/s (time inside insertWordRefs)\n",
                ref_rows / refs_seconds);

    std::uniform_int_distribution<std::int64_t> any_location(1, locations);
    std::vector<double> load_ms;
    load_ms.reserve(kLoads);
    std::size_t loaded_words = 0;
    const auto load_start = Clock::now();
    for (int i = 0; i < kLoads; ++i) {
      const std::int64_t id = any_location(random);
      const auto t = Clock::now();
      const auto refs = store.loadWordRefs(id);
      const auto word_ids = store.wordsOfLocations({id});
      const auto words = store.loadWords(word_ids);
      load_ms.push_back(secondsSince(t) * 1000);
      loaded_words += words.size();
      if (refs.size() != static_cast<std::size_t>(kRefsPerLocation)) {
        std::fprintf(stderr, "location %lld has %zu references\n", static_cast<long long>(id),
                     refs.size());
        return 1;
      }
    }
    std::printf("location loads    %d in %.2f s, %.1f distinct words each\n", kLoads,
                secondsSince(load_start), static_cast<double>(loaded_words) / kLoads);
    std::printf("load per location p50 %.3f ms, p99 %.3f ms\n", percentile(load_ms, 0.5),
                percentile(load_ms, 0.99));
  } catch (const placedb::Error& error) {
    std::fprintf(stderr, "storage_bench: %s\n", error.what());
    return 1;
  }
  const auto bytes = std::filesystem::file_size(path);
  std::printf("file size         %.1f MB (%s)\n", bytes / 1e6, path.c_str());
  if (!keep) {
    placedb::storage::removeMap(path);
  }
  return 0;
}
