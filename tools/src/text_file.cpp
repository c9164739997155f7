#include "text_file.h"

#include <fmt/format.h>

#include <cctype>
#include <fstream>
#include <iterator>

#include "placedb/error.h"

namespace placedb::cli {

std::string trim(const std::string& text) {
  std::size_t first = 0, last = text.size();
  while (first < last && std::isspace(static_cast<unsigned char>(text[first]))) ++first;
  while (last > first && std::isspace(static_cast<unsigned char>(text[last - 1]))) --last;
  return text.substr(first, last - first);
}

std::string withoutByteOrderMark(std::string content) {
  if (content.compare(0, 3, "\xEF\xBB\xBF") == 0) content.erase(0, 3);
  return content;
}

std::string readTextFile(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status))
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: no such file", what, path.string()));
  if (!std::filesystem::is_regular_file(status))
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: {}", what, path.string(),
                            std::filesystem::is_directory(status) ? "it is a folder"
                                                                  : "not a regular file"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, fmt::format("cannot read {} {}", what, path.string()));
  std::string content;
  try {
    content.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::ios_base::failure& e) {
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: {}", what, path.string(), e.what()));
  }
  return withoutByteOrderMark(std::move(content));
}

}  // namespace placedb::cli
