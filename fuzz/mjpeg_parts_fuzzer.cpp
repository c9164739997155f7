// libFuzzer target: the MJPEG stream's part reader (tools/src/sources/mjpeg_stream.h,
// MultipartReader) over bytes a camera could send. The first byte sets how many bytes each read()
// returns (1 to 256, so that a line or a part split across reads is tried too); the rest is the
// body after the answer's header, boundary "frame". The contract: it ends (every call consumes
// input or ends the stream), a part is either bytes or a problem, and never more than the limit is
// held.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "sources/mjpeg_stream.h"

namespace {

constexpr std::size_t kLimit = 4096;  // a small part limit, so that the fuzzer reaches it

class Bytes : public placedb::cli::ByteSource {
 public:
  Bytes(const std::uint8_t* data, std::size_t size, std::size_t step)
      : data_(data), size_(size), step_(step) {}
  long read(char* out, std::size_t size) override {
    const std::size_t n = std::min({size, step_, size_ - at_});
    std::memcpy(out, data_ + at_, n);
    at_ += n;
    return static_cast<long>(n);
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_, step_, at_ = 0;
};

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  Bytes in(data + 1, size - 1, 1 + data[0]);
  placedb::cli::MultipartReader reader(in, "frame", kLimit);
  placedb::cli::StreamPart part;
  // Each part takes at least its delimiter's bytes: more parts than bytes means a loop.
  for (std::size_t parts = 0;; ++parts) {
    check(parts <= size);
    const auto next = reader.next(part);
    if (next != placedb::cli::StreamNext::kPart) {
      check(next == placedb::cli::StreamNext::kEnd);  // this source never stalls
      break;
    }
    check(part.bytes.empty() || part.problem.empty());  // never both
    check(part.bytes.size() <= kLimit);
  }
  return 0;
}
