#include "sources/mjpeg_stream.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <optional>

#include "base64.h"
#include "features/image_conversion.h"
#include "placedb/error.h"

namespace placedb::cli {
namespace {

constexpr std::size_t kNpos = std::string::npos;
constexpr std::size_t kMaxLine = 8192;  // a delimiter or header line
constexpr int kMaxHeaders = 64;         // lines of one part's or the answer's header
constexpr std::size_t kMaxAnswerHeader = 65536;
constexpr std::size_t kChunk = 65536;

using Clock = std::chrono::steady_clock;

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string trimmed(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == kNpos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

std::string percentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() &&
        std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out += static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

// "http://user:password@host:port/path?query": its parts.
struct HttpUrl {
  std::string host, port = "80", target = "/", userinfo;
};

std::optional<HttpUrl> parseHttpUrl(const std::string& url) {
  if (lower(url.substr(0, 7)) != "http://") return std::nullopt;
  HttpUrl u;
  std::string rest = url.substr(7);
  rest = rest.substr(0, rest.find('#'));
  const std::size_t slash = rest.find_first_of("/?");
  std::string authority = rest.substr(0, slash);
  if (slash != kNpos) u.target = rest[slash] == '/' ? rest.substr(slash) : "/" + rest.substr(slash);
  if (const std::size_t at = authority.rfind('@'); at != kNpos) {
    u.userinfo = authority.substr(0, at);
    authority = authority.substr(at + 1);
  }
  if (!authority.empty() && authority.front() == '[') {  // [IPv6]:port
    const std::size_t close = authority.find(']');
    if (close == kNpos) return std::nullopt;
    u.host = authority.substr(1, close - 1);
    if (close + 1 < authority.size() && authority[close + 1] == ':')
      u.port = authority.substr(close + 2);
  } else if (const std::size_t colon = authority.rfind(':'); colon != kNpos) {
    u.host = authority.substr(0, colon);
    u.port = authority.substr(colon + 1);
  } else {
    u.host = authority;
  }
  if (u.host.empty() || u.port.empty()) return std::nullopt;
  return u;
}

// The value of `name` (lower case) among "Name: value" header lines.
std::string headerValue(const std::string& header, const std::string& name) {
  std::size_t start = 0;
  while (start < header.size()) {
    std::size_t end = header.find('\n', start);
    if (end == kNpos) end = header.size();
    const std::string line = header.substr(start, end - start);
    const std::size_t colon = line.find(':');
    if (colon != kNpos && lower(trimmed(line.substr(0, colon))) == name)
      return trimmed(line.substr(colon + 1));
    start = end + 1;
  }
  return "";
}

// The boundary parameter of a multipart Content-Type, without quotes; "" when there is none.
std::string boundaryOf(const std::string& content_type) {
  const std::string type = lower(content_type);
  if (type.rfind("multipart/", 0) != 0) return "";
  const std::size_t at = type.find("boundary=");
  if (at == kNpos) return "";
  std::string value = content_type.substr(at + 9);
  value = trimmed(value.substr(0, value.find(';')));
  if (value.size() >= 2 && value.front() == '"' && value.back() == '"')
    value = value.substr(1, value.size() - 2);
  return value;
}

}  // namespace

std::size_t maxStreamPartBytes() { return 3 * static_cast<std::size_t>(kMaxImagePixels); }

// ---- Parts ----

MultipartReader::MultipartReader(ByteSource& in, const std::string& boundary,
                                 std::size_t max_part_bytes, std::string already_read)
    // Some servers name the boundary with the "--" of its delimiter lines already in it; the
    // shorter pattern is found in both forms of the line.
    : in_(in),
      delimiter_(boundary.rfind("--", 0) == 0 ? boundary : "--" + boundary),
      max_part_(max_part_bytes),
      buffer_(std::move(already_read)) {}

MultipartReader::Fill MultipartReader::fill() {
  char chunk[kChunk];
  const long n = in_.read(chunk, sizeof chunk);
  if (n < 0) return Fill::kStalled;
  if (n == 0) return Fill::kEnd;
  buffer_.append(chunk, static_cast<std::size_t>(n));
  return Fill::kMore;
}

std::size_t MultipartReader::find(const std::string& pattern, bool keep, std::size_t limit,
                                  Fill& why) {
  std::size_t from = 0;
  for (;;) {
    const std::size_t at = buffer_.find(pattern, from);
    if (at != kNpos) return at;
    if (buffer_.size() > limit) {
      if (keep) {
        why = Fill::kMore;
        return kNpos;
      }
      buffer_.erase(0, buffer_.size() - (pattern.size() - 1));  // what may begin the pattern
    }
    if (buffer_.size() >= pattern.size()) from = buffer_.size() - (pattern.size() - 1);
    why = fill();
    if (why != Fill::kMore) return kNpos;
  }
}

StreamNext MultipartReader::next(StreamPart& part) {
  part = StreamPart();
  Fill why = Fill::kMore;
  // The next delimiter line: what comes before it (the line break ending a part, a preamble,
  // junk) is dropped as it comes.
  std::size_t at = find(delimiter_, false, kMaxLine, why);
  if (at == kNpos) return stop(why);
  buffer_.erase(0, at);
  std::size_t eol = find("\n", true, kMaxLine, why);
  if (eol == kNpos) {
    if (why != Fill::kMore) return stop(why);
    buffer_.erase(0, delimiter_.size());
    part.problem = "a part delimiter line longer than 8192 bytes";
    return StreamNext::kPart;
  }
  if (buffer_.compare(0, delimiter_.size() + 2, delimiter_ + "--") == 0)
    return StreamNext::kEnd;  // the closing delimiter
  buffer_.erase(0, eol + 1);

  // The part's header lines, up to an empty one.
  std::optional<std::uint64_t> length;
  bool length_unreadable = false;
  for (int lines = 0;; ++lines) {
    eol = find("\n", true, kMaxLine, why);
    if (eol == kNpos) {
      if (why != Fill::kMore) return stop(why);
      part.problem = "a part header line longer than 8192 bytes";
      return StreamNext::kPart;  // the next call finds the next delimiter
    }
    std::string line = buffer_.substr(0, eol);
    buffer_.erase(0, eol + 1);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (lines == kMaxHeaders) {
      part.problem = "a part with more than 64 header lines";
      return StreamNext::kPart;
    }
    const std::string value = headerValue(line, "content-length");
    if (value.empty()) continue;
    if (value.find_first_not_of("0123456789") != kNpos)
      length_unreadable = true;
    else  // 19 digits fit; more say "too large" as well as any number would
      length = value.size() > 19 ? UINT64_MAX : std::stoull(value);
  }
  if (length_unreadable) {
    part.problem = "a part whose Content-Length is not a number";
    return StreamNext::kPart;
  }

  if (length && *length > max_part_) {
    // Skipped as it comes, never held: its header says it is no image placedb would take.
    part.problem = fmt::format(
        "a part of {} bytes, over the limit of {} bytes (the raw pixels of the largest image "
        "placedb takes): skipped without being read",
        *length, max_part_);
    for (std::uint64_t left = *length; left > 0;) {
      if (buffer_.empty() && (why = fill()) != Fill::kMore) return stop(why);
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, buffer_.size()));
      buffer_.erase(0, n);
      left -= n;
    }
    return StreamNext::kPart;
  }
  if (length) {
    while (buffer_.size() < *length)
      if ((why = fill()) != Fill::kMore) return stop(why);
    part.bytes.assign(buffer_, 0, static_cast<std::size_t>(*length));
    buffer_.erase(0, static_cast<std::size_t>(*length));
    return StreamNext::kPart;
  }
  // Without a Content-Length the part runs to the line break before the next delimiter.
  const std::size_t end = find("\r\n" + delimiter_, true, max_part_, why);
  if (end == kNpos) {
    if (why != Fill::kMore) return stop(why);
    part.problem =
        fmt::format("a part longer than {} bytes (without a Content-Length): skipped", max_part_);
    buffer_.erase(0, buffer_.size() - (delimiter_.size() + 1));
    return StreamNext::kPart;
  }
  part.bytes.assign(buffer_, 0, end);
  buffer_.erase(0, end);
  return StreamNext::kPart;
}

// ---- The HTTP connection ----

class MjpegHttpStream::Socket : public ByteSource {
 public:
  Socket(int fd, const std::atomic<bool>& stop) : fd_(fd), stop_(stop) {}
  ~Socket() override { ::close(fd_); }
  void setTimeout(int timeout_ms) { timeout_ms_ = timeout_ms; }

  // Waits in short steps, so that a stop request (the source closing) ends a wait at once.
  long read(char* out, std::size_t size) override {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms_);
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      const int ready = ::poll(&p, 1, 100);
      if (ready < 0 && errno != EINTR) return 0;
      if (ready <= 0) {
        if (Clock::now() >= deadline) return -1;
        continue;
      }
      const ssize_t n = ::recv(fd_, out, size, 0);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      return n < 0 ? 0 : static_cast<long>(n);
    }
    return 0;
  }

  int fd() const { return fd_; }

 private:
  int fd_;
  const std::atomic<bool>& stop_;
  int timeout_ms_ = 10000;
};

MjpegHttpStream::~MjpegHttpStream() = default;

std::unique_ptr<MjpegHttpStream> MjpegHttpStream::open(const std::string& url, int open_timeout_ms,
                                                       int read_timeout_ms,
                                                       const std::atomic<bool>& stop) {
  const auto u = parseHttpUrl(url);
  if (!u) return nullptr;
  const auto fail = [&url](const std::string& why) -> std::unique_ptr<MjpegHttpStream> {
    throw Error(ErrorCode::kIo, fmt::format("cannot open live source {}: {}", url, why));
  };
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int rc = ::getaddrinfo(u->host.c_str(), u->port.c_str(), &hints, &found); rc != 0)
    return fail(::gai_strerror(rc));
  const auto deadline = Clock::now() + std::chrono::milliseconds(open_timeout_ms);
  int fd = -1, error = ETIMEDOUT;
  for (addrinfo* a = found; a && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
    if (fd < 0) continue;
    if (::connect(fd, a->ai_addr, a->ai_addrlen) != 0 && errno != EINPROGRESS) {
      error = errno;
      ::close(fd);
      fd = -1;
      continue;
    }
    pollfd p{fd, POLLOUT, 0};
    int ready = 0;
    while (!stop && ready == 0 && Clock::now() < deadline) ready = ::poll(&p, 1, 100);
    socklen_t size = sizeof error;
    if (ready <= 0 || ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size) != 0 || error != 0) {
      if (ready <= 0) error = ETIMEDOUT;
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  if (fd < 0) return fail(std::strerror(error));
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::unique_ptr<MjpegHttpStream> stream(new MjpegHttpStream());
  stream->socket_ = std::make_unique<Socket>(fd, stop);

  std::string request = fmt::format(
      "GET {} HTTP/1.0\r\nHost: {}\r\nUser-Agent: placedb\r\nAccept: */*\r\n", u->target,
      u->host.find(':') != kNpos ? "[" + u->host + "]:" + u->port : u->host + ":" + u->port);
  if (!u->userinfo.empty()) {
    const std::string credentials = percentDecoded(u->userinfo);
    request += "Authorization: Basic " +
               base64Encode(reinterpret_cast<const std::uint8_t*>(credentials.data()),
                            credentials.size()) +
               "\r\n";
  }
  request += "\r\n";
  for (std::size_t sent = 0; sent < request.size();) {
    const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return fail(std::strerror(n < 0 ? errno : EPIPE));
    sent += static_cast<std::size_t>(n);
  }

  // The answer's status line and headers.
  stream->socket_->setTimeout(std::max<int>(
      1,
      static_cast<int>(
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count())));
  std::string answer;
  std::size_t header_end = kNpos;
  while ((header_end = answer.find("\r\n\r\n")) == kNpos) {
    if (answer.size() > kMaxAnswerHeader) return fail("the server's answer has no end of header");
    char chunk[4096];
    const long n = stream->socket_->read(chunk, sizeof chunk);
    if (n < 0) return fail("no answer within the open timeout");
    if (n == 0) return fail("the server closed the connection without an answer");
    answer.append(chunk, static_cast<std::size_t>(n));
  }
  const std::string header = answer.substr(0, header_end + 2);
  const std::string status = header.substr(0, header.find('\r'));
  int code = 0;
  if (status.rfind("HTTP/", 0) != 0 || std::sscanf(status.c_str(), "HTTP/%*s %d", &code) != 1)
    return fail("not an HTTP answer");
  if (code >= 300 && code < 400) return nullptr;  // a redirect: FFmpeg follows it
  if (code != 200) return fail("the server answered " + trimmed(status.substr(status.find(' '))));
  const std::string boundary = boundaryOf(headerValue(header, "content-type"));
  if (boundary.empty()) return nullptr;  // not a multipart stream: FFmpeg's to read
  stream->socket_->setTimeout(read_timeout_ms);
  stream->parts_ = std::make_unique<MultipartReader>(
      *stream->socket_, boundary, maxStreamPartBytes(), answer.substr(header_end + 4));
  return stream;
}

}  // namespace placedb::cli
