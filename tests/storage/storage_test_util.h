#pragma once
// Helpers shared by the storage tests.
#include <sqlite3.h>

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "file_bytes.h"
#include "placedb/storage/sqlite_map_store.h"

namespace placedb::storage::testing {

using placedb::testing::readBytes;
using placedb::testing::writeBytes;

// Raw access for setting up files the way other programs would.
class RawDb {
 public:
  explicit RawDb(const std::string& path) {
    EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
  }
  ~RawDb() { sqlite3_close(db_); }
  void exec(const std::string& sql) {
    char* error = nullptr;
    ASSERT_EQ(sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << (error ? error : "") << " in " << sql;
  }
  std::vector<std::string> rows(const std::string& sql) {
    sqlite3_stmt* stmt = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK) << sql;
    std::vector<std::string> result;
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      std::string row;
      for (int i = 0; i < sqlite3_column_count(stmt); ++i) {
        const auto* text = sqlite3_column_text(stmt, i);
        row += (i ? "|" : "") + std::string(text ? reinterpret_cast<const char*>(text) : "NULL");
      }
      result.push_back(row);
    }
    sqlite3_finalize(stmt);
    return result;
  }

 private:
  sqlite3* db_ = nullptr;
};

// Writes one complete frame (frame row, location, words, references) in one transaction.
inline void writeFrame(MapStore& store, std::int64_t session_id, std::int64_t index,
                       int words_per_frame = 4) {
  Transaction tx = store.begin();
  FrameRecord frame;
  frame.id = index + 1;
  frame.session_id = session_id;
  frame.source_index = index;
  frame.source_path = "img" + std::to_string(index) + ".png";
  frame.location_id = index + 1;
  store.insertFrame(frame);
  store.insertLocation({index + 1, session_id, 1, Tier::kStm, frame.id});
  store.addCoveredFrame(index + 1, frame.id);
  std::vector<WordRecord> words;
  std::vector<WordRef> refs;
  for (int i = 0; i < words_per_frame; ++i) {
    const std::int64_t word_id = index * words_per_frame + i + 1;
    std::vector<float> values(8, static_cast<float>(word_id));
    words.push_back(WordRecord::fromFloats(word_id, frame.id, values.data(), 8));
    refs.push_back({word_id, float(i), float(i), 2, 0, 1});
  }
  store.insertWords(words);
  store.insertWordRefs(index + 1, refs);
  tx.commit();
}

}  // namespace placedb::storage::testing
