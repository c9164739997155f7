#pragma once
// A whole file as bytes, and a file written from bytes (replacing what was there).
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace placedb::testing {

// Empty when the file cannot be read.
inline std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void writeBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace placedb::testing
