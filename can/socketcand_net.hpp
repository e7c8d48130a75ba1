// Socket helpers shared by the socketcand server and client (not a public interface).
#pragma once

#include <sys/socket.h>
#include <unistd.h>

#include <string>
#include <string_view>
#include <utility>

namespace candp2::can::socketcand_net {

std::string errno_text(int err);

class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  UniqueFd(UniqueFd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  UniqueFd& operator=(UniqueFd&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  ~UniqueFd() { reset(); }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int get() const { return fd_; }
  explicit operator bool() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

bool is_printable_element(std::string_view e);
// Non-printable bytes as \xNN, for log lines.
std::string printable(std::string_view text);
std::string address_text(const sockaddr* sa);
// Stores the message (when error is not null) and returns false.
bool set_error(std::string* error, std::string message);
// A bus name socketcand accepts: 1..kMaxBusName printable characters without spaces or < >.
bool valid_bus_name(std::string_view name);

}  // namespace candp2::can::socketcand_net
