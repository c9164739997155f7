#include "whole_file.h"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "placedb/error.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void writeFailed(const fs::path& target, int error) {
  if (error == 0) error = EIO;
  const bool full = error == ENOSPC || error == EFBIG || error == EDQUOT;
  throw Error(full ? ErrorCode::kDiskFull : ErrorCode::kIo,
              fmt::format("cannot write {}: {}", target.string(), std::strerror(error)));
}

// Where a symbolic link leads, followed to the end (a link to nothing leads to the file it
// names, which the write then creates); any other path as it is.
fs::path finalTarget(const fs::path& target) {
  constexpr int kMaxHops = 40;  // as the kernel's ELOOP limit
  fs::path at = target;
  for (int hops = 0;; ++hops) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(at, ec))) return at;
    if (hops == kMaxHops) writeFailed(target, ELOOP);
    const fs::path next = fs::read_symlink(at, ec);
    if (ec) writeFailed(target, ec.value());
    at = next.is_absolute() ? next : at.parent_path() / next;
  }
}

}  // namespace

void writeWholeFile(const fs::path& target, const std::function<void(std::FILE*)>& write) {
  const fs::path file = finalTarget(target);
  struct stat st {};
  const bool special = ::stat(file.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
  const fs::path partial =
      special ? file : fs::path(file.string() + fmt::format(".partial-{}", ::getpid()));
  const auto removePartial = [&] {
    std::error_code ec;
    if (!special) fs::remove(partial, ec);
  };
  std::FILE* out = std::fopen(partial.c_str(), "wb");
  if (!out) writeFailed(target, errno);
  try {
    write(out);
  } catch (...) {
    std::fclose(out);
    removePartial();
    throw;
  }
  // A write that failed in `write` left the stream's error flag and its errno.
  int error = std::ferror(out) ? (errno ? errno : EIO) : 0;
  if (std::fflush(out) != 0 && error == 0) error = errno ? errno : EIO;
  if (std::ferror(out) && error == 0) error = EIO;
  if (std::fclose(out) != 0 && error == 0) error = errno ? errno : EIO;
  if (error == 0 && !special && std::rename(partial.c_str(), file.c_str()) != 0) error = errno;
  if (error != 0) {
    removePartial();
    writeFailed(target, error);
  }
}

void writeWholeFile(const fs::path& target, const std::string& bytes) {
  writeWholeFile(target,
                 [&bytes](std::FILE* out) { std::fwrite(bytes.data(), 1, bytes.size(), out); });
}

}  // namespace placedb::cli
