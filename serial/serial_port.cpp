#include "serial/serial_port.hpp"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include "serial/serial_linux.hpp"

namespace candp2::serial {

namespace {

std::string errno_text(int err) {
  return std::strerror(err);
}

void set_error(std::string* error, std::string text) {
  if (error) *error = std::move(text);
}

// Standard termios rates reachable with cfsetspeed(); the others go through termios2 BOTHER.
speed_t standard_speed(std::uint32_t baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 500000:
      return B500000;
    case 1500000:
      return B1500000;
    case 3000000:
      return B3000000;
    default:
      return 0;
  }
}

// UNIX98 pseudo-terminal ends: the terminal side has majors 136..143, the ptmx side major 5 minor 2
// (or the devpts ptmx); posix_openpt() descriptors are always ptys.
bool is_pty_fd(int fd) {
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISCHR(st.st_mode)) return false;
  const unsigned maj = major(st.st_rdev);
  char name[64];
  return (maj >= 136 && maj <= 143) || (maj == 5 && minor(st.st_rdev) == 2) ||
         ::ptsname_r(fd, name, sizeof name) == 0;
}

}  // namespace

bool parse_pty_port(std::string_view port, std::string* path) {
  constexpr std::string_view prefix = "pty:";
  if (port.substr(0, prefix.size()) != prefix) return false;
  if (path) *path = std::string(port.substr(prefix.size()));
  return true;
}

Duration char_time(std::uint32_t baud, std::size_t chars) {
  // docs/profibus.md "The line's physics": 11 bits a character, rounded up.
  return std::max(phy::char_time(baud, chars), Duration(1));
}

// ---- ParmrkDecoder

void ParmrkDecoder::feed(const std::uint8_t* data, std::size_t size, std::vector<RxByte>& out) {
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint8_t b = data[i];
    switch (state_) {
      case State::Data:
        if (b == 0xFF)
          state_ = State::Ff;
        else
          out.push_back({b, false});
        break;
      case State::Ff:
        if (b == 0xFF) {  // termios(3) PARMRK: a data byte 0xFF is doubled
          out.push_back({0xFF, false});
          state_ = State::Data;
        } else if (b == 0x00) {
          state_ = State::FfZero;
        } else {  // not a valid mark (PARMRK off on the peer): pass both bytes
          out.push_back({0xFF, false});
          out.push_back({b, false});
          state_ = State::Data;
        }
        break;
      case State::FfZero:  // 0xFF 0x00 X: X received with a parity/framing error (X=0: break)
        out.push_back({b, true});
        state_ = State::Data;
        break;
    }
  }
}

// ---- EchoFilter

void EchoFilter::sent(const std::uint8_t* data, std::size_t size, Time deadline) {
  for (std::size_t i = 0; i < size; ++i) expected_.push_back({data[i], deadline});
}

void EchoFilter::filter(std::vector<RxByte>& bytes, std::size_t from, Time now) {
  while (!expected_.empty() && expected_.front().deadline < now) {
    expected_.pop_front();
    ++lost_;
  }
  std::size_t w = from;
  for (std::size_t r = from; r < bytes.size(); ++r) {
    const RxByte b = bytes[r];
    if (!expected_.empty()) {
      if (!b.parity_error && b.value == expected_.front().value) {
        expected_.pop_front();
        ++dropped_;
        continue;
      }
      lost_ += expected_.size();
      expected_.clear();
    }
    bytes[w++] = b;
  }
  bytes.resize(w);
}

// ---- SerialPort

SerialPort::SerialPort(const SerialOptions& options)
    : options_(options), log_(options.log, "serial") {}

SerialPort::~SerialPort() {
  if (!link_path_.empty()) {
    // Remove the link only while it is still ours (another process may have replaced it).
    char target[256];
    const ssize_t n = ::readlink(link_path_.c_str(), target, sizeof target - 1);
    if (n > 0 && std::string(target, static_cast<std::size_t>(n)) == pts_path_)
      ::unlink(link_path_.c_str());
  }
  if (pts_fd_ >= 0) ::close(pts_fd_);
  if (fd_ >= 0) ::close(fd_);
}

std::unique_ptr<SerialPort> SerialPort::open(const SerialOptions& options, std::string* error) {
  std::unique_ptr<SerialPort> port(new SerialPort(options));
  std::string link;
  const bool ok =
      parse_pty_port(options.port, &link) ? port->open_pty(link, error) : port->open_device(error);
  if (!ok) return nullptr;
  return port;
}

bool SerialPort::open_device(std::string* error) {
  const std::string& path = options_.port;
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    set_error(error, "open " + path + ": " + errno_text(errno));
    return false;
  }
  if (!::isatty(fd_)) {
    set_error(error, path + " is not a serial device (not a terminal)");
    return false;
  }
  if (!configure(fd_, false, error)) return false;
  if (options_.rs485) {
    const int err = detail::set_rs485(fd_);
    if (err != 0) {
      set_error(error,
                "RS-485 mode (TIOCSRS485) on " + path + ": " + errno_text(err) +
                    (err == ENOTTY || err == EINVAL ? " (the driver does not offer it)" : ""));
      return false;
    }
    log_.info("RS-485 mode on " + path);
  }
  const int err = detail::set_low_latency(fd_);
  if (err == 0) {
    low_latency_ = true;
  } else if (err == ENOTTY || err == EINVAL || err == EOPNOTSUPP) {
    log_.debug("low-latency mode not offered by the driver of " + path + ": " + errno_text(err));
  } else {
    log_.warn("low-latency mode on " + path + ": " + errno_text(err));
  }
  ::tcflush(fd_, TCIOFLUSH);
  log_.info("opened " + path + " at " + std::to_string(baud_) + " baud 8E1" +
            (low_latency_ ? ", low latency" : ""));
  return true;
}

bool SerialPort::open_pty(const std::string& link, std::string* error) {
  if (link.empty()) {
    set_error(error, "pty: needs a path (\"pty:/tmp/profibus\")");
    return false;
  }
  struct stat st;
  if (::lstat(link.c_str(), &st) == 0 && !S_ISLNK(st.st_mode)) {
    set_error(error, "pty link " + link + " exists and is not a symbolic link; not replacing it");
    return false;
  }
  fd_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (fd_ < 0) {
    set_error(error, std::string("posix_openpt: ") + errno_text(errno));
    return false;
  }
  if (::grantpt(fd_) != 0 || ::unlockpt(fd_) != 0) {
    set_error(error, std::string("grantpt/unlockpt: ") + errno_text(errno));
    return false;
  }
  char name[128];
  if (::ptsname_r(fd_, name, sizeof name) != 0) {
    set_error(error, std::string("ptsname: ") + errno_text(errno));
    return false;
  }
  pts_path_ = name;
  const int flags = ::fcntl(fd_, F_GETFL);
  ::fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
  // Our own open terminal end: while it is open the peer may close and reopen PATH without our side
  // seeing EIO / POLLHUP.
  pts_fd_ = ::open(name, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (pts_fd_ < 0) {
    set_error(error, "open " + pts_path_ + ": " + errno_text(errno));
    return false;
  }
  // Both ends raw 8E1 (no echo, no line editing): the terminal end until the peer sets its own.
  // One termios for both ends: Linux applies termios calls on the master to the terminal end
  // (tty_mode_ioctl uses tty->link), and what the peer writes reaches us through the master's own
  // fixed raw line discipline. So: the terminal end raw 8E1 without parity marks (a 0xFF would
  // reach the peer doubled, and a pty has no parity errors anyway), nothing to unescape here.
  if (!configure(pts_fd_, true, error, false)) return false;
  mark_parity_ = false;

  // Atomic replace: a temporary link renamed over PATH (a stale link from a killed process goes).
  bool replaced = false;
  if (::lstat(link.c_str(), &st) == 0) {
    replaced = true;
    char target[256];
    const ssize_t n = ::readlink(link.c_str(), target, sizeof target - 1);
    const std::string old = n > 0 ? std::string(target, static_cast<std::size_t>(n)) : "?";
    log_.info("replacing stale link " + link + " -> " + old);
  }
  const std::string tmp = link + ".tmp" + std::to_string(::getpid());
  ::unlink(tmp.c_str());
  if (::symlink(pts_path_.c_str(), tmp.c_str()) != 0) {
    set_error(error, "symlink " + link + " -> " + pts_path_ + ": " + errno_text(errno));
    return false;
  }
  if (::rename(tmp.c_str(), link.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    set_error(error, "symlink " + link + " -> " + pts_path_ + ": " + errno_text(err));
    return false;
  }
  link_path_ = link;
  (void)replaced;
  log_.info("pseudo-terminal " + pts_path_ + " at " + link);
  return true;
}

bool SerialPort::configure(int fd, bool is_pty, std::string* error, bool mark_parity) {
  const std::string& what = is_pty ? pts_path_ : options_.port;
  struct termios tio;
  if (::tcgetattr(fd, &tio) != 0) {
    set_error(error, "tcgetattr " + what + ": " + errno_text(errno));
    return false;
  }
  ::cfmakeraw(&tio);
  // docs/profibus.md: 8 data bits, even parity, one stop bit; no modem control, no flow control.
  tio.c_cflag &= ~(CSIZE | PARODD | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | PARENB | CLOCAL | CREAD;
  // Parity errors marked in the stream (0xFF 0x00 X), a data 0xFF doubled; no software flow
  // control.
  tio.c_iflag &= ~(IGNPAR | ISTRIP | IXON | IXOFF | IXANY | IGNBRK | BRKINT);
  if (mark_parity) tio.c_iflag |= INPCK | PARMRK;
  tio.c_cc[VMIN] = 0;  // non-blocking reads
  tio.c_cc[VTIME] = 0;
  const speed_t std_speed = standard_speed(options_.baud);
  if (std_speed != 0) ::cfsetspeed(&tio, std_speed);
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) {
    const int err = errno;
    // Some kernels refuse PARENB on a pseudo-terminal (EINVAL): a pty is a byte pipe without
    // characters on a wire, so parity means nothing there; it runs 8N1 and the rest stays.
    bool ok = false;
    if (err == EINVAL && is_pty_fd(fd)) {
      tio.c_cflag &= ~PARENB;
      ok = ::tcsetattr(fd, TCSANOW, &tio) == 0;
      if (ok) log_.debug(what + ": the pseudo-terminal does not take PARENB; parity is not used");
    }
    if (!ok) {
      set_error(error, "tcsetattr " + what + ": " + errno_text(err));
      return false;
    }
  }
  if (std_speed == 0) {
    const int err = detail::set_baud_termios2(fd, options_.baud);
    if (err != 0) {
      set_error(error, "baud " + std::to_string(options_.baud) + " rejected by the driver of " +
                           what + ": " + errno_text(err));
      return false;
    }
  }
  // Read back. TCGETS2's speed fields are only meaningful for BOTHER: with a Bxxx constant a pty
  // keeps stale ones there, so standard rates are checked with cfgetospeed().
  if (std_speed != 0) {
    struct termios back;
    if (::tcgetattr(fd, &back) == 0 && ::cfgetospeed(&back) != std_speed) {
      set_error(error,
                "baud " + std::to_string(options_.baud) + " rejected by the driver of " + what);
      return false;
    }
  } else {
    std::uint32_t ispeed = 0, ospeed = 0;
    if (detail::get_baud_termios2(fd, &ispeed, &ospeed) == 0) {
      // A driver may round to what its divider can do; more than 3 % off is not the same rate.
      const double ratio = static_cast<double>(ospeed) / options_.baud;
      if (ratio < 0.97 || ratio > 1.03) {
        set_error(error, "baud " + std::to_string(options_.baud) + " rejected by the driver of " +
                             what + ": it set " + std::to_string(ospeed));
        return false;
      }
    }
  }
  baud_ = options_.baud;
  return true;
}

long SerialPort::read_raw(std::uint8_t* buffer, std::size_t size, std::string* error) {
  const ssize_t n = ::read(fd_, buffer, size);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return 0;
    set_error(error, "read " + options_.port + ": " + errno_text(errno));
    return -1;
  }
  return static_cast<long>(n);
}

long SerialPort::read(std::vector<RxByte>& out, Time now, std::string* error) {
  long total = 0;
  std::uint8_t buffer[512];
  for (;;) {
    const long n = read_raw(buffer, sizeof buffer, error);
    if (n < 0) return -1;
    if (n == 0) break;
    const std::size_t from = out.size();
    if (mark_parity_)
      parmrk_.feed(buffer, static_cast<std::size_t>(n), out);
    else
      for (long i = 0; i < n; ++i) out.push_back({buffer[i], false});
    for (std::size_t i = from; i < out.size(); ++i)
      if (out[i].parity_error) ++parity_errors_;
    if (options_.echo) echo_.filter(out, from, now);
    total += n;
    if (static_cast<std::size_t>(n) < sizeof buffer) break;
  }
  return total;
}

bool SerialPort::write(const std::uint8_t* data, std::size_t size, Time now, std::string* error) {
  out_.insert(out_.end(), data, data + size);
  return flush(now, error);
}

bool SerialPort::flush(Time now, std::string* error) {
  while (!out_.empty()) {
    const ssize_t n = ::write(fd_, out_.data(), out_.size());
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
      if (errno == EINTR) continue;
      set_error(error, "write " + options_.port + ": " + errno_text(errno));
      out_.clear();
      return false;
    }
    if (options_.echo) {
      // The echo of the last byte comes back at the earliest after all bytes queued before it
      // (in the driver) have gone out; allow their transmission time plus the timeout.
      const Time deadline = now + char_time(baud_, out_.size()) + options_.echo_timeout;
      echo_.sent(out_.data(), static_cast<std::size_t>(n), deadline);
    }
    out_.erase(out_.begin(), out_.begin() + n);
  }
  return true;
}

}  // namespace candp2::serial
