#pragma once
// Reading the small text files the command line takes (list files, config files) whole.
#include <filesystem>
#include <string>

namespace placedb::cli {

// The file's bytes without a leading UTF-8 byte order mark. Throws placedb::Error(kIo) naming
// the file, with `what` ("list file", "config file"), when it is missing, a folder or unreadable.
std::string readTextFile(const std::filesystem::path& path, const std::string& what);

// Writes `text` to `target` whole or not at all: beside its final name, renamed when complete, so
// a reader (or a full disk) never sees half a file. A target that exists and is not a regular
// file (a FIFO, a device such as /dev/stdout) is written directly, never replaced. Throws
// placedb::Error naming the file: kDiskFull when the disk or a file-size limit is full (ENOSPC,
// EFBIG, EDQUOT), kIo otherwise.
void writeTextFile(const std::filesystem::path& target, const std::string& text);

// `text` without leading and trailing white space.
std::string trim(const std::string& text);

// `content` without a leading UTF-8 byte order mark (some editors write one).
std::string withoutByteOrderMark(std::string content);

}  // namespace placedb::cli
