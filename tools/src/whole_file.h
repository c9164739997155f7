#pragma once
// The one writer of every whole file the command line makes: a graph export, a vocabulary, a
// report page, a figure. All of them treat what is at the path alike:
//  - nothing, or a regular file: the bytes go to PATH.partial-PID beside it, renamed over it
//    once complete, so a reader (or a full disk) never sees half a file and a failed write leaves
//    the older file as it was;
//  - a symbolic link: the file it leads to (followed to the end) is written as above; the link
//    stays a link;
//  - anything else (a device such as /dev/full or /dev/stdout, a FIFO): written directly, never
//    replaced.
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>

namespace placedb::cli {

// `write` puts the file's bytes on the stream it is given (a failed fwrite need not be checked
// there: the stream's error flag is). Throws placedb::Error naming `target`: kDiskFull when the
// disk or a file-size limit is full (ENOSPC, EFBIG, EDQUOT), kIo otherwise; an Error thrown by
// `write` passes unchanged, the partial file removed.
void writeWholeFile(const std::filesystem::path& target,
                    const std::function<void(std::FILE*)>& write);
void writeWholeFile(const std::filesystem::path& target, const std::string& bytes);

}  // namespace placedb::cli
