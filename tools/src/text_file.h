#pragma once
// Reading the small text files the command line takes (list files, config files) whole; writing
// is whole_file.h's.
#include <filesystem>
#include <string>

namespace placedb::cli {

// The file's bytes without a leading UTF-8 byte order mark. Throws placedb::Error(kIo) naming
// the file, with `what` ("list file", "config file"), when it is missing, a folder or unreadable.
std::string readTextFile(const std::filesystem::path& path, const std::string& what);

// `text` without leading and trailing white space.
std::string trim(const std::string& text);

// `content` without a leading UTF-8 byte order mark (some editors write one).
std::string withoutByteOrderMark(std::string content);

}  // namespace placedb::cli
