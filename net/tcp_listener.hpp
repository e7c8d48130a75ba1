// One listening TCP socket for the daemon's faces (docs/daemon.md): the Modbus/TCP server and the
// HTTP face bind, listen and accept through this one helper. IPv4 numeric addresses only (the
// configuration's "127.0.0.1:1502"), port 0 = any free port, non-blocking, close-on-exec,
// SO_REUSEADDR so that a restarted daemon gets its port back while old connections linger in
// TIME_WAIT.
#pragma once

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace candp2::net {

class TcpListener {
 public:
  // nullptr and *error ("cannot listen on 127.0.0.1:1502: Address already in use") on failure.
  static std::unique_ptr<TcpListener> listen(const std::string& host, std::uint16_t port,
                                             int backlog, std::string* error);
  ~TcpListener();
  TcpListener(const TcpListener&) = delete;
  TcpListener& operator=(const TcpListener&) = delete;

  int fd() const { return fd_; }
  std::uint16_t port() const { return port_; }  // the port actually bound
  // Hands the descriptor over (to a library that serves the socket itself); fd() is -1 after.
  int release();

  // Accepts pending connections (non-blocking, close-on-exec), at most `max`, and hands each to
  // `on_client(fd, peer)`, which owns the descriptor from then on. Returns false after an accept
  // error other than "nothing pending" (*error tells it, errno is accept's: EMFILE when the
  // process is out of descriptors); the listener stays usable.
  using OnClient = std::function<void(int fd, const sockaddr_in& peer)>;
  bool accept_all(const OnClient& on_client, std::string* error, std::size_t max = SIZE_MAX);

 private:
  TcpListener(int fd, std::uint16_t port) : fd_(fd), port_(port) {}
  int fd_ = -1;
  std::uint16_t port_ = 0;
};

// "127.0.0.1:50412"
std::string peer_name(const sockaddr_in& peer);

}  // namespace candp2::net
