// The serial PHY of the PROFIBUS line (docs/profibus.md): a UART in raw 8E1 or a pseudo-terminal.
//
// Transport layer (like can/socketcan.hpp): it owns a descriptor and never reads a clock; the
// caller passes the time in and puts fd() into its event loop (non-blocking, no threads).
//
//   port "/dev/ttyUSB0"  a serial device: termios 8E1 raw, the bit rate (standard rates through
//                        cfsetspeed, the PROFIBUS rates 45.45k/93.75k/187.5k/6M/12M through
//                        termios2 BOTHER), low-latency mode where the driver offers it, optional
//                        kernel RS-485 mode (TIOCSRS485), parity errors marked (INPCK + PARMRK).
//   port "pty:PATH"      a pseudo-terminal: PATH becomes a symbolic link to its terminal end
//                        (/dev/pts/N; a stale link is replaced, a regular file is refused), removed
//                        when the port is closed. We keep the terminal end open ourselves, so a
//                        peer that closes and reopens PATH does not hang up our side.
//
// Received bytes come out as RxByte (value + parity-error flag) for the FDL stream parser's parity
// input. With `echo` the bytes we sent are dropped exactly as they come back (adapters that hear
// themselves on a two-wire RS-485 bus).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/line_physics.hpp"
#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2::serial {

// The rates a port takes are the PROFIBUS rates, phy::kLineRates (common/line_physics.hpp).

// "pty:PATH" -> PATH (true); anything else false.
bool parse_pty_port(std::string_view port, std::string* path);

// One character time at `baud` for 8E1 (phy::char_time), at least 1 µs.
Duration char_time(std::uint32_t baud, std::size_t chars = 1);

struct SerialOptions {
  std::string port;  // device path or "pty:PATH"
  std::uint32_t baud = 19200;
  bool rs485 = false;  // TIOCSRS485: SER_RS485_ENABLED | SER_RS485_RTS_ON_SEND
  bool echo = false;   // the adapter echoes what we send: drop it
  // How long after its own transmission time an echoed byte may still come back.
  Duration echo_timeout = milliseconds(20);
  LogSink* log = nullptr;
};

struct RxByte {
  std::uint8_t value = 0;
  bool parity_error = false;  // parity or framing error / break (PARMRK 0xFF 0x00 X)
  bool operator==(const RxByte&) const = default;
};

// Hands received characters to an FDL parser in order: runs of good characters in one piece
// (`run(span)`, never empty), a character with a parity error on its own (`bad(value)`;
// docs/profibus.md: the telegram it belongs to is discarded).
template <typename Run, typename Bad>
void split_parity(std::span<const RxByte> rx, Run&& run, Bad&& bad) {
  std::vector<std::uint8_t> chunk;
  chunk.reserve(rx.size());
  for (const auto& b : rx) {
    if (!b.parity_error) {
      chunk.push_back(b.value);
      continue;
    }
    if (!chunk.empty()) run(std::span<const std::uint8_t>(chunk));
    chunk.clear();
    bad(b.value);
  }
  if (!chunk.empty()) run(std::span<const std::uint8_t>(chunk));
}

// PARMRK unescaping (termios(3)): 0xFF 0xFF -> data 0xFF; 0xFF 0x00 X -> X with an error mark;
// everything else as is. Sequences split across reads are kept until complete. Pure.
class ParmrkDecoder {
 public:
  void feed(const std::uint8_t* data, std::size_t size, std::vector<RxByte>& out);
  void reset() { state_ = State::Data; }

 private:
  enum class State { Data, Ff, FfZero };
  State state_ = State::Data;
};

// Drops the echo of our own transmission: every byte sent is expected back, in order, until its
// deadline. A received byte equal to the next expected one is dropped; a different byte (or one
// with a parity error) means the echo was lost: expectations are cleared and the byte passes. Pure.
class EchoFilter {
 public:
  void sent(const std::uint8_t* data, std::size_t size, Time deadline);
  // Filters `bytes` in place; expectations older than `now` are forgotten first.
  void filter(std::vector<RxByte>& bytes, std::size_t from, Time now);
  std::size_t pending() const { return expected_.size(); }
  std::uint64_t dropped() const { return dropped_; }
  std::uint64_t lost() const { return lost_; }

 private:
  struct Expected {
    std::uint8_t value;
    Time deadline;
  };
  std::deque<Expected> expected_;
  std::uint64_t dropped_ = 0;
  std::uint64_t lost_ = 0;
};

class SerialPort {
 public:
  // Opens and configures the port; nullptr and *error ("open /dev/ttyUSB9: No such file or
  // directory", "baud 45450 rejected by the driver of /dev/ttyS0: ...") on failure.
  static std::unique_ptr<SerialPort> open(const SerialOptions& options, std::string* error);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  int fd() const { return fd_; }
  bool is_pty() const { return !link_path_.empty(); }
  const std::string& link_path() const { return link_path_; }     // pty: PATH
  const std::string& terminal_path() const { return pts_path_; }  // pty: /dev/pts/N
  std::uint32_t baud() const { return baud_; }
  bool low_latency() const { return low_latency_; }
  // Whether read_raw() delivers PARMRK escapes (serial devices, a pty's terminal end opened as a
  // device); false on our own pty master side.
  bool marks_parity() const { return mark_parity_; }
  const SerialOptions& options() const { return options_; }

  // Reads everything available (non-blocking), unescapes parity marks, drops our echo, appends to
  // `out`. Returns the number of raw bytes read (0: nothing available), -1 on an error (*error).
  long read(std::vector<RxByte>& out, Time now, std::string* error);
  // Raw bytes as the descriptor gives them (PARMRK escapes included unless marks_parity() is
  // false): for a sniffer.
  long read_raw(std::uint8_t* buffer, std::size_t size, std::string* error);

  // Writes (non-blocking); what the descriptor does not take now is queued: call flush() when
  // fd() is writable while pending() > 0. False and *error on a hard error.
  bool write(const std::uint8_t* data, std::size_t size, Time now, std::string* error);
  bool flush(Time now, std::string* error);
  std::size_t pending() const { return out_.size(); }

  const EchoFilter& echo_filter() const { return echo_; }
  std::uint64_t parity_errors() const { return parity_errors_; }

 private:
  explicit SerialPort(const SerialOptions& options);
  bool open_device(std::string* error);
  bool open_pty(const std::string& link, std::string* error);
  bool configure(int fd, bool is_pty, std::string* error, bool mark_parity = true);

  SerialOptions options_;
  Logger log_;
  int fd_ = -1;
  int pts_fd_ = -1;  // pty: our own open terminal end
  std::string link_path_;
  std::string pts_path_;
  std::uint32_t baud_ = 0;
  bool low_latency_ = false;
  ParmrkDecoder parmrk_;
  bool mark_parity_ = true;  // PARMRK in effect on what we read (not on a pty's master side)
  EchoFilter echo_;
  std::vector<std::uint8_t> out_;
  std::uint64_t parity_errors_ = 0;
};

}  // namespace candp2::serial
