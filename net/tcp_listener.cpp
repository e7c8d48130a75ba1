#include "net/tcp_listener.hpp"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace candp2::net {

std::unique_ptr<TcpListener> TcpListener::listen(const std::string& host, std::uint16_t port,
                                                 int backlog, std::string* error) {
  const std::string where = host + ":" + std::to_string(port);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    *error = "cannot listen on " + where + ": \"" + host + "\" is not a numeric IPv4 address";
    return nullptr;
  }
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    *error = "cannot listen on " + where + ": socket: " + std::strerror(errno);
    return nullptr;
  }
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(fd, backlog) != 0) {
    *error = "cannot listen on " + where + ": " + std::strerror(errno);
    ::close(fd);
    return nullptr;
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len);
  return std::unique_ptr<TcpListener>(new TcpListener(fd, ntohs(bound.sin_port)));
}

TcpListener::~TcpListener() {
  if (fd_ >= 0) ::close(fd_);
}

int TcpListener::release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

bool TcpListener::accept_all(const OnClient& on_client, std::string* error, std::size_t max) {
  for (std::size_t n = 0; n < max;) {
    sockaddr_in peer{};
    socklen_t len = sizeof peer;
    const int fd =
        ::accept4(fd_, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      on_client(fd, peer);
      ++n;
      continue;
    }
    if (errno == EINTR || errno == ECONNABORTED) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
    const int e = errno;
    *error = std::string("accept failed: ") + std::strerror(e);
    errno = e;
    return false;
  }
  return true;
}

std::string peer_name(const sockaddr_in& peer) {
  char host[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &peer.sin_addr, host, sizeof host);
  return std::string(host) + ":" + std::to_string(ntohs(peer.sin_port));
}

}  // namespace candp2::net
