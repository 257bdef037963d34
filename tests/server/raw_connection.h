// tests/server/raw_connection.h: a raw TCP connection to the test server, for
// what httplib::Client will not send (broken framing, trickled bytes, bodies
// larger than the limit).
#ifndef GEARLOOP_TESTS_SERVER_RAW_CONNECTION_H_
#define GEARLOOP_TESTS_SERVER_RAW_CONNECTION_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace gearloop {
namespace testing_util {

class RawConnection {
 public:
  explicit RawConnection(int port, int receive_timeout_seconds = 10) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ =
        connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) ==
        0;
    timeval timeout{receive_timeout_seconds, 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  }
  ~RawConnection() { close(fd_); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;
  bool connected() const { return connected_; }
  // False once the peer no longer takes data.
  bool Send(const std::string& data) {
    return send(fd_, data.data(), data.size(), MSG_NOSIGNAL) ==
           static_cast<ssize_t>(data.size());
  }
  // Until the end of a response head, the peer closing, or the socket
  // timeout.
  std::string ReceiveHead() {
    std::string out;
    char buffer[4096];
    while (out.find("\r\n\r\n") == std::string::npos) {
      const ssize_t n = recv(fd_, buffer, sizeof(buffer), 0);
      if (n <= 0) break;
      out.append(buffer, static_cast<size_t>(n));
    }
    return out;
  }
  // Until the peer closes or the socket timeout.
  std::string ReceiveAll() {
    std::string out;
    char buffer[4096];
    for (;;) {
      const ssize_t n = recv(fd_, buffer, sizeof(buffer), 0);
      if (n <= 0) break;
      out.append(buffer, static_cast<size_t>(n));
    }
    return out;
  }
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

}  // namespace testing_util
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_SERVER_RAW_CONNECTION_H_
