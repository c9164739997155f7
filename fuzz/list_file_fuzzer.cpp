// libFuzzer target: the command line's list-file parser (tools/src/sources/image_source.cpp,
// placedb::cli::readListFile). The contract: a placedb::Error, or paths that are non-empty,
// free of newlines and never comment lines.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "placedb/error.h"
#include "sources/image_source.h"

namespace {

const std::string& scratchPath() {
  static const std::string path =
      (std::getenv("TMPDIR") ? std::string(std::getenv("TMPDIR")) : std::string("/tmp")) +
      "/placedb-fuzz-list-" + std::to_string(getpid()) + "/frames.txt";
  return path;
}

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool made = [] {
    const std::string dir = scratchPath().substr(0, scratchPath().rfind('/'));
    return std::system(("mkdir -p '" + dir + "'").c_str()) == 0;
  }();
  check(made);
  {
    std::ofstream out(scratchPath(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    for (const auto& path : placedb::cli::readListFile(scratchPath())) {
      check(!path.empty());
      check(path.find('\n') == std::string::npos);
    }
  } catch (const placedb::Error& e) {
    check(std::string(e.what()).find(scratchPath()) != std::string::npos);
  }
  return 0;
}
