#pragma once
// An MJPEG stream over HTTP (multipart/x-mixed-replace: what IP cameras, mjpg-streamer and
// motion serve), read part by part so that each part is judged on its own: a part that is no
// image is a bad frame and the stream goes on, a part larger than the largest image placedb takes
// is skipped from its header without being held in memory, and a stream that sends nothing for
// the read timeout is told apart from one that ended. (FFmpeg, which reads the other streams,
// ends the stream at a bad part, buffers a huge one whole and reports a stall as an end.)
#include <atomic>
#include <cstddef>
#include <memory>
#include <string>

namespace placedb::cli {

// The largest part taken: the raw pixels of the largest image the engine accepts, 3 bytes a
// pixel (features/image_conversion.h). No compressed image of an acceptable size is larger.
std::size_t maxStreamPartBytes();

// One part of the stream: an encoded image, or why there is none.
struct StreamPart {
  std::string bytes;
  std::string problem;  // empty when `bytes` holds the part
};

enum class StreamNext { kPart, kEnd, kStalled };

// Where the bytes come from (a socket; a buffer in the fuzz target).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Up to `size` bytes into `out`: their count, 0 at the end of the stream, -1 when nothing came
  // within the read timeout (a stall).
  virtual long read(char* out, std::size_t size) = 0;
};

// The parts of a multipart body whose delimiter lines are "--BOUNDARY". Every line and header
// block is bounded, so a hostile stream costs at most maxStreamPartBytes() of memory.
class MultipartReader {
 public:
  // `already_read`: bytes of the body read before (with the HTTP answer's header).
  MultipartReader(ByteSource& in, const std::string& boundary, std::size_t max_part_bytes,
                  std::string already_read = {});
  // The next part (kPart, filling `part`), or why there is none: the stream ended (a closing
  // delimiter, or the connection) or stalled. A part cut short by either is not returned.
  StreamNext next(StreamPart& part);

 private:
  enum class Fill { kMore, kEnd, kStalled };
  Fill fill();
  // Where `pattern` starts in the buffer, reading more as needed. With `keep` the buffer grows
  // to `limit` bytes at most (npos, why = kMore, past it); without, what comes before the
  // pattern is dropped as it comes. npos with `why` set at the end of the stream or a stall.
  std::size_t find(const std::string& pattern, bool keep, std::size_t limit, Fill& why);
  StreamNext stop(Fill why) const {
    return why == Fill::kStalled ? StreamNext::kStalled : StreamNext::kEnd;
  }

  ByteSource& in_;
  std::string delimiter_;  // "--BOUNDARY"
  std::size_t max_part_;
  std::string buffer_;
};

// http://[user:password@]host[:port][/path]: connects, asks for the path and reads the answer's
// headers. Returns nullptr when the answer is not a multipart stream (a video over HTTP, a
// redirect): FFmpeg reads those. Throws placedb::Error(kIo) naming the URL when it cannot
// connect within open_timeout_ms or the server answers with an error status.
class MjpegHttpStream {
 public:
  static std::unique_ptr<MjpegHttpStream> open(const std::string& url, int open_timeout_ms,
                                               int read_timeout_ms, const std::atomic<bool>& stop);
  ~MjpegHttpStream();
  MjpegHttpStream(const MjpegHttpStream&) = delete;
  MjpegHttpStream& operator=(const MjpegHttpStream&) = delete;

  StreamNext next(StreamPart& part) { return parts_->next(part); }

 private:
  class Socket;
  MjpegHttpStream() = default;
  std::unique_ptr<Socket> socket_;
  std::unique_ptr<MultipartReader> parts_;
};

}  // namespace placedb::cli
