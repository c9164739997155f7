// A password given in a map's URI never shows in the process list: placedb overwrites it in its
// own arguments before anything else runs, so /proc/PID/cmdline (what `ps` shows every user)
// holds x's where it stood.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <iterator>

#include "cli_scratch.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// A TCP listener on the loopback address that accepts and never answers: a stream source that
// keeps `map` waiting, while the test reads its arguments, for as long as the test wants.
class SilentServer {
 public:
  SilentServer() {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof address;
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&address), size) != 0 ||
        ::listen(listener_, 1) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &size) != 0)
      throw std::runtime_error("cannot listen on the loopback address");
    port_ = ntohs(address.sin_port);
  }
  ~SilentServer() {
    if (client_ >= 0) ::close(client_);
    ::close(listener_);
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/stream.mjpg"; }
  // True once a client connected (within 60 s).
  bool accepted() {
    pollfd p{listener_, POLLIN, 0};
    if (::poll(&p, 1, 60000) != 1) return false;
    client_ = ::accept(listener_, nullptr, nullptr);
    return client_ >= 0;
  }
  void hangUp() {
    if (client_ >= 0) ::close(client_);
    client_ = -1;
  }

 private:
  int listener_ = -1, client_ = -1;
  int port_ = 0;
};

std::string commandLineOf(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (char& c : text)
    if (c == '\0') c = ' ';
  return text;
}

TEST(CliSecrets, APasswordInTheUriIsNotInTheProcessList) {
  const fs::path dir = scratchDir("CliSecrets_cmdline");
  SilentServer stream;
  // No server at port 9: the run never gets that far; the arguments are what is looked at.
  const std::string uri =
      "postgresql://robot:Tr0ub4dor@127.0.0.1:9/fleet?connect_timeout=1&password=c0rrect%20horse";
  Process mapping({PLACEDB_CLI_BINARY, "map", uri, stream.url(), "--log=" + uri + "-not-a-log"},
                  dir);
  ASSERT_TRUE(stream.accepted()) << "map never opened its source";
  // `map` opens its source only after parsing its arguments: they are scrubbed by now.
  const std::string shown = commandLineOf(mapping.pid());
  stream.hangUp();
  const auto r = mapping.wait();
  EXPECT_EQ(shown.find("Tr0ub4dor"), std::string::npos) << shown;
  EXPECT_EQ(shown.find("c0rrect"), std::string::npos) << shown;
  EXPECT_NE(shown.find("postgresql://robot:xxxxxxxxx@127.0.0.1:9/fleet?connect_timeout=1&"
                       "password=xxxxxxxxxxxxx"),
            std::string::npos)
      << shown;
  EXPECT_NE(shown.find(stream.url()), std::string::npos) << shown;
  expectCleanError(r, 3, stream.url());
  EXPECT_EQ(r.err.find("Tr0ub4dor"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace placedb::testing
