#include "server/http/bounded_http.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <thread>
#include <vector>

namespace gearloop {
namespace {

using Clock = std::chrono::steady_clock;

// The state of the request being served on this thread.
struct ConnectionState {
  bool close_after_response = false;
  bool deadline_passed = false;
};
thread_local ConnectionState t_connection;
// True on the thread that turns away connections beyond max_connections.
thread_local bool t_overflow = false;

int Milliseconds(double seconds) {
  return static_cast<int>(std::max(0.0, seconds) * 1e3);
}

// Waits for `events` on `sock` for at most `timeout_ms`; true when ready.
bool WaitFor(socket_t sock, short events, int timeout_ms) {
  pollfd fd{sock, events, 0};
  int ready;
  do {
    ready = poll(&fd, 1, timeout_ms);
  } while (ready < 0 && errno == EINTR);
  return ready > 0;
}

std::string NumericAddress(const sockaddr_storage& address, int* port) {
  char host[NI_MAXHOST] = "";
  char service[NI_MAXSERV] = "";
  getnameinfo(reinterpret_cast<const sockaddr*>(&address),
              address.ss_family == AF_INET6 ? sizeof(sockaddr_in6)
                                            : sizeof(sockaddr_in),
              host,
              sizeof(host),
              service,
              sizeof(service),
              NI_NUMERICHOST | NI_NUMERICSERV);
  if (port != nullptr) *port = std::atoi(service);
  return host;
}

std::string PeerAddress(socket_t sock, int* port) {
  sockaddr_storage address{};
  socklen_t length = sizeof(address);
  if (getpeername(sock, reinterpret_cast<sockaddr*>(&address), &length) != 0)
    return "";
  return NumericAddress(address, port);
}

// A socket stream whose reads stop at the request's deadline as well as after
// the read timeout of silence (cpp-httplib's own stream only has the latter,
// so a client sending a byte every few seconds could hold a thread forever).
class DeadlineStream : public httplib::Stream {
 public:
  DeadlineStream(socket_t sock,
                 const ConnectionLimits& limits,
                 Clock::time_point deadline)
      : sock_(sock), limits_(limits), deadline_(deadline) {}

  bool is_readable() const override {
    const int remaining = RemainingMilliseconds();
    if (remaining <= 0) {
      t_connection.deadline_passed = true;
      return false;
    }
    const int timeout =
        std::min(remaining, Milliseconds(limits_.read_timeout_seconds));
    if (WaitFor(sock_, POLLIN, timeout)) return true;
    if (RemainingMilliseconds() <= 0) t_connection.deadline_passed = true;
    return false;
  }
  bool is_writable() const override {
    return WaitFor(sock_, POLLOUT, Milliseconds(limits_.write_timeout_seconds));
  }
  ssize_t read(char* ptr, size_t size) override {
    if (!is_readable()) return -1;
    ssize_t n;
    do {
      n = recv(sock_, ptr, size, 0);
    } while (n < 0 && errno == EINTR);
    return n;
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do {
      n = send(sock_, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    return n;
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = PeerAddress(sock_, &port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage address{};
    socklen_t length = sizeof(address);
    if (getsockname(sock_, reinterpret_cast<sockaddr*>(&address), &length) == 0)
      ip = NumericAddress(address, &port);
  }
  socket_t socket() const override { return sock_; }

 private:
  int RemainingMilliseconds() const {
    return static_cast<int>(
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ -
                                                              Clock::now())
            .count());
  }

  socket_t sock_;
  const ConnectionLimits& limits_;
  Clock::time_point deadline_;
};

// A fixed pool of connection threads. A connection that finds them all busy
// is not queued behind the slow ones: a single extra thread answers it 503
// and closes it (t_overflow), so the wait for a thread is never unbounded.
class BoundedTaskQueue : public httplib::TaskQueue {
 public:
  explicit BoundedTaskQueue(int threads) : capacity_(threads) {
    for (int i = 0; i < threads; ++i)
      threads_.emplace_back([this] { Work(false); });
    threads_.emplace_back([this] { Work(true); });
  }
  ~BoundedTaskQueue() override { shutdown(); }

  void enqueue(std::function<void()> fn) override {
    bool overflow = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      overflow = busy_ + static_cast<int>(jobs_.size()) >= capacity_;
      (overflow ? overflow_ : jobs_).push_back(std::move(fn));
    }
    // One waiter of the right kind, not all of them.
    (overflow ? overflow_ready_ : ready_).notify_one();
  }

  void shutdown() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;
      stopping_ = true;
    }
    ready_.notify_all();
    overflow_ready_.notify_all();
    for (std::thread& thread : threads_) thread.join();
  }

 private:
  void Work(bool overflow) {
    t_overflow = overflow;
    std::deque<std::function<void()>>& jobs = overflow ? overflow_ : jobs_;
    std::condition_variable& ready = overflow ? overflow_ready_ : ready_;
    for (;;) {
      std::function<void()> fn;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready.wait(lock, [&] { return stopping_ || !jobs.empty(); });
        if (jobs.empty()) return;  // stopping, and nothing left to close
        fn = std::move(jobs.front());
        jobs.pop_front();
        if (!overflow) ++busy_;
      }
      fn();
      if (!overflow) {
        std::lock_guard<std::mutex> lock(mutex_);
        --busy_;
      }
    }
  }

  const int capacity_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable overflow_ready_;
  std::deque<std::function<void()>> jobs_;
  std::deque<std::function<void()>> overflow_;
  int busy_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

// Answers 503 without reading the request, and closes. The socket is made
// non-blocking first: a client that does not read cannot hold this thread.
void Refuse(socket_t sock, const std::string& message) {
  const std::string body =
      "{\"error\":{\"code\":\"unavailable\",\"message\":\"" + message +
      "\",\"field\":\"\"}}";
  const std::string response =
      "HTTP/1.1 503 Service Unavailable\r\nContent-Type: "
      "application/json\r\nRetry-After: 1\r\nConnection: close\r\n"
      "Content-Length: " +
      std::to_string(body.size()) + "\r\n\r\n" + body;
  timeval no_wait{0, 1000};
  setsockopt(sock, SOL_SOCKET, SO_SNDTIMEO, &no_wait, sizeof(no_wait));
  (void)send(sock, response.data(), response.size(), MSG_NOSIGNAL);
  shutdown(sock, SHUT_WR);
  close(sock);
}

// Closes after a response whose request was not read to its end. Closing a
// socket with unread data resets the connection, and a reset can reach the
// client before it has read the answer, which it then never sees. So: stop
// sending, and wait (up to 1 s, without reading: the client's further bytes
// only fill the kernel's buffers) for the client to close its side first.
void LingeringClose(socket_t sock, bool linger) {
  shutdown(sock, SHUT_WR);
  if (linger) {
    const auto until = Clock::now() + std::chrono::seconds(1);
    while (Clock::now() < until) {
      pollfd fd{sock, POLLRDHUP, 0};
      const int ready = poll(&fd, 1, 100);
      if (ready > 0 && (fd.revents & (POLLRDHUP | POLLHUP | POLLERR))) break;
      if (ready < 0 && errno != EINTR) break;
    }
  }
  close(sock);
}

void WriteTimeout(socket_t sock, double deadline_seconds) {
  const std::string body =
      "{\"error\":{\"code\":\"request_timeout\",\"message\":\"the request did "
      "not arrive within " +
      std::to_string(static_cast<int>(deadline_seconds)) +
      " s\",\"field\":\"\"}}";
  const std::string response =
      "HTTP/1.1 408 Request Timeout\r\nContent-Type: "
      "application/json\r\nConnection: close\r\nContent-Length: " +
      std::to_string(body.size()) + "\r\n\r\n" + body;
  (void)send(sock, response.data(), response.size(), MSG_NOSIGNAL);
}

}  // namespace

BoundedHttpServer::BoundedHttpServer(const ConnectionLimits& limits)
    : limits_(limits) {
  const int threads = std::max(1, limits_.max_connections);
  new_task_queue = [threads] { return new BoundedTaskQueue(threads); };
  set_keep_alive_max_count(
      static_cast<size_t>(std::max(1, limits_.max_requests_per_connection)));
  // SO_RCVTIMEO/SO_SNDTIMEO of each accepted socket; the stream above polls
  // before every read and write, so these are only a backstop.
  set_read_timeout(static_cast<time_t>(limits_.read_timeout_seconds) + 1, 0);
  set_write_timeout(static_cast<time_t>(limits_.write_timeout_seconds) + 1, 0);
  // Runs just before the head is written: a connection that will be closed
  // says so.
  set_post_routing_handler([](const httplib::Request&, httplib::Response& res) {
    if (!t_connection.close_after_response) return;
    res.headers.erase("Keep-Alive");
    res.set_header("Connection", "close");
  });
  // No SO_REUSEPORT: a second server on the same port must fail to bind
  // instead of sharing the port and splitting the requests between two
  // histories. SO_REUSEADDR only lets a restart bind over TIME_WAIT sockets.
  set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
}

int BoundedHttpServer::BindExclusive(const std::string& host, int port) {
  bind_error_.clear();
  const int bound = port == 0 ? bind_to_any_port(host)
                              : (bind_to_port(host, port) ? port : -1);
  if (bound >= 0) {
    // cpp-httplib listens with a backlog of 5: a burst of connections would
    // wait for SYN retransmits (1 s, 3 s, ...). Listening again on a
    // listening socket only sets a longer queue.
    ::listen(svr_sock_, 1024);
    return bound;
  }
  // cpp-httplib does not say why; bind a probe socket the same way to learn
  // the reason.
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  const int resolved =
      getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found);
  if (resolved != 0) {
    bind_error_ = std::string("cannot resolve host: ") + gai_strerror(resolved);
    return -1;
  }
  bind_error_ = "cannot bind";
  const int probe = ::socket(found->ai_family, SOCK_STREAM, 0);
  if (probe >= 0) {
    int yes = 1;
    setsockopt(probe, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    if (::bind(probe, found->ai_addr, found->ai_addrlen) != 0 ||
        ::listen(probe, 1) != 0) {
      bind_error_ = std::strerror(errno);
      if (errno == EADDRINUSE)
        bind_error_ += " (another server is listening on this port)";
    }
    ::close(probe);
  }
  freeaddrinfo(found);
  return -1;
}

void BoundedHttpServer::CloseAfterResponse() {
  t_connection.close_after_response = true;
}

bool BoundedHttpServer::DeadlinePassed() {
  return t_connection.deadline_passed;
}

int BoundedHttpServer::OpenConnections() const {
  std::lock_guard<std::mutex> lock(clients_mutex_);
  return open_connections_;
}

bool BoundedHttpServer::AdmitClient(const std::string& address) {
  std::lock_guard<std::mutex> lock(clients_mutex_);
  int& count = connections_by_client_[address];
  if (count >= limits_.max_connections_per_client) {
    if (count == 0) connections_by_client_.erase(address);
    return false;
  }
  ++count;
  ++open_connections_;
  return true;
}

void BoundedHttpServer::ReleaseClient(const std::string& address) {
  std::lock_guard<std::mutex> lock(clients_mutex_);
  auto it = connections_by_client_.find(address);
  if (it != connections_by_client_.end() && --it->second <= 0)
    connections_by_client_.erase(it);
  --open_connections_;
}

bool BoundedHttpServer::process_and_close_socket(socket_t sock) {
  if (t_overflow) {
    Refuse(sock, "the server is at its connection limit; retry shortly");
    return false;
  }
  const std::string client = PeerAddress(sock, nullptr);
  if (!AdmitClient(client)) {
    Refuse(sock, "too many connections from this address");
    return false;
  }
  const bool ret = ServeConnection(sock);
  ReleaseClient(client);
  return ret;
}

bool BoundedHttpServer::ServeConnection(socket_t sock) {
  bool ret = false;
  bool drain = false;
  const int idle_ms = Milliseconds(limits_.idle_timeout_seconds);
  for (int served = 0; served < limits_.max_requests_per_connection; ++served) {
    // Wait for the next request in slices, so that Stop() is noticed.
    int waited_ms = 0;
    bool readable = false;
    while (svr_sock_ != INVALID_SOCKET && waited_ms < idle_ms) {
      if ((readable = WaitFor(sock, POLLIN, 50))) break;
      waited_ms += 50;
    }
    if (!readable) break;
    t_connection = ConnectionState{};
    const auto deadline = Clock::now() + std::chrono::milliseconds(Milliseconds(
                                             limits_.request_deadline_seconds));
    DeadlineStream stream(sock, limits_, deadline);
    bool connection_closed = false;
    const bool last = served + 1 == limits_.max_requests_per_connection;
    ret = process_request(stream, last, connection_closed, nullptr);
    if (!ret && t_connection.deadline_passed)
      WriteTimeout(sock, limits_.request_deadline_seconds);
    drain = t_connection.close_after_response || t_connection.deadline_passed;
    if (!ret || connection_closed || drain) break;
  }
  LingeringClose(sock, drain);
  return ret;
}

}  // namespace gearloop
