#include "profibus_line/line_port.hpp"

#include <filesystem>

#include "common/line_physics.hpp"

namespace candp2::profibus_line {

serial::SerialOptions serial_options(const config::ProfibusConfig& config, LogSink* log) {
  serial::SerialOptions o;
  o.port = config.port;
  o.baud = config.baud;
  o.rs485 = config.rs485;
  o.echo = config.echo;
  o.log = log;
  return o;
}

std::string port_text(const serial::SerialPort& port, const std::string& configured) {
  return port.is_pty() ? "pty " + port.link_path() + " -> " + port.terminal_path() : configured;
}

Duration master_latency_allowance(bool is_pty, bool low_latency) {
  // docs/profibus.md "Timing in role master": a pty is a hand-over between two processes that
  // may wait for a CPU on a busy host; a serial port in low-latency mode delivers within ~1 ms;
  // without it (FTDI latency timer, 16 ms by default) the answer may sit in the adapter.
  if (is_pty) return milliseconds(20);
  return low_latency ? milliseconds(3) : milliseconds(20);
}

// ------------------------------------------------------------------------------- role slaves

std::unique_ptr<SlaveLinePort> SlaveLinePort::open(const config::ProfibusConfig& config,
                                                   plant::SlaveLine& line, EventLoop& loop,
                                                   LogSink* log, std::string* error) {
  std::unique_ptr<SlaveLinePort> p(new SlaveLinePort(config, line, loop, log));
  std::string e;
  p->port_ = serial::SerialPort::open(serial_options(config, log), &e);
  if (!p->port_) {
    *error = "PROFIBUS line (" + config.json_path + ".port): " + e;
    return nullptr;
  }
  SlaveLinePort* self = p.get();
  if (!loop.add_fd(
          p->port_->fd(), EventLoop::kReadable,
          [self](std::uint32_t events) {
            if (events & EventLoop::kWritable) {
              std::string err;
              if (!self->port_->flush(self->loop_.now(), &err)) self->log_.error(err);
              if (self->port_->pending() == 0)
                self->loop_.modify_fd(self->port_->fd(), EventLoop::kReadable);
            }
            if (events & (EventLoop::kReadable | EventLoop::kHangup)) self->on_readable();
          },
          &e)) {
    *error = "PROFIBUS line (" + config.json_path + ".port): " + e;
    return nullptr;
  }
  p->watching_ = true;
  return p;
}

SlaveLinePort::SlaveLinePort(const config::ProfibusConfig& config, plant::SlaveLine& line,
                             EventLoop& loop, LogSink* log)
    : config_(config), line_(line), loop_(loop), log_(log, "profibus") {}

SlaveLinePort::~SlaveLinePort() {
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  if (send_timer_) loop_.cancel_timer(send_timer_);
  if (watching_) loop_.remove_fd(port_->fd());
}

std::string SlaveLinePort::describe() const {
  return port_text(*port_, config_.port) + ", " + std::to_string(config_.baud) +
         " baud, role slaves";
}

void SlaveLinePort::on_readable() {
  const Time now = loop_.now();
  rx_.clear();
  std::string error;
  const long n = port_->read(rx_, now, &error);
  if (n < 0) {
    // A device that is gone (USB adapter unplugged: EIO) would report readable forever: stop
    // watching it; the gateways stay, their watchdogs take them out of Data_Exch.
    log_.error(error + ": the PROFIBUS line is dead; restart candp2d when the port is back");
    if (watching_) loop_.remove_fd(port_->fd());
    watching_ = false;
    return;
  }
  if (rx_.empty()) return;
  serial::split_parity(
      rx_, [&](std::span<const std::uint8_t> run) { line_.on_bytes(run, now); },
      [&](std::uint8_t bad) { line_.on_bad_char(bad, now); });
  answer();
  // A partial telegram: idle for TSYN (docs/profibus.md) ends it.
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  gap_timer_ = 0;
  if (line_.partial())
    gap_timer_ = loop_.add_timer(line_.bit_times(phy::kTsynBits), [this] {
      gap_timer_ = 0;
      line_.on_gap(loop_.now());
      answer();
    });
}

void SlaveLinePort::answer() {
  auto reply = line_.take_reply();
  if (!reply) return;
  // A newer request supersedes an answer still waiting for its min_TSDR.
  if (send_timer_) loop_.cancel_timer(send_timer_);
  send_timer_ = 0;
  const Time now = loop_.now();
  if (reply->not_before <= now) {
    send(*reply);
    return;
  }
  send_timer_ = loop_.add_timer(reply->not_before - now, [this, r = std::move(*reply)] {
    send_timer_ = 0;
    send(r);
  });
}

void SlaveLinePort::send(const fdl::Reply& reply) {
  const Time now = loop_.now();
  std::string error;
  if (!port_->write(reply.bytes.data(), reply.bytes.size(), now, &error)) {
    log_.error(error);
    return;
  }
  if (port_->pending() > 0)
    loop_.modify_fd(port_->fd(), EventLoop::kReadable | EventLoop::kWritable);
  line_.sent(reply, now);
}

// ------------------------------------------------------------------------------- role master

std::unique_ptr<MasterLinePort> MasterLinePort::open(const config::ProfibusConfig& config,
                                                     plant::MasterLine& line, EventLoop& loop,
                                                     LogSink* log, std::string* error) {
  std::unique_ptr<MasterLinePort> p(new MasterLinePort(config, line, loop, log));
  std::string e;
  if (!p->open_port(&e)) {
    *error = "PROFIBUS line (" + config.json_path + ".port): " + e;
    return nullptr;
  }
  return p;
}

MasterLinePort::MasterLinePort(const config::ProfibusConfig& config, plant::MasterLine& line,
                               EventLoop& loop, LogSink* log)
    : config_(config), line_(line), loop_(loop), log_sink_(log), log_(log, "profibus") {}

MasterLinePort::~MasterLinePort() {
  line_.clear_port();
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  if (reopen_timer_) loop_.cancel_timer(reopen_timer_);
  if (port_) loop_.remove_fd(port_->fd());
}

bool MasterLinePort::open_port(std::string* error) {
  auto port = serial::SerialPort::open(serial_options(config_, log_sink_), error);
  if (!port) return false;
  if (!loop_.add_fd(
          port->fd(), EventLoop::kReadable,
          [this](std::uint32_t events) {
            if (!port_) return;
            if (events & EventLoop::kWritable) {
              std::string err;
              if (!port_->flush(loop_.now(), &err)) log_.error(err);
              if (port_->pending() == 0) loop_.modify_fd(port_->fd(), EventLoop::kReadable);
            }
            if (events & (EventLoop::kReadable | EventLoop::kHangup))
              on_readable(events & EventLoop::kHangup);
          },
          error))
    return false;
  port_ = std::move(port);
  // A pseudo-terminal (ours, or a pty's terminal end opened as a device) does not pace bytes at
  // the bit rate: they arrive as soon as they are written.
  std::error_code ec;
  const auto real = std::filesystem::canonical(config_.port, ec).string();
  const bool on_pty = port_->is_pty() || (!ec && real.rfind("/dev/pts/", 0) == 0);
  port_desc_ = port_text(*port_, config_.port);
  line_.set_port([this](std::span<const std::uint8_t> bytes) { write(bytes); }, !on_pty,
                 master_latency_allowance(port_->is_pty(), port_->low_latency()));
  return true;
}

void MasterLinePort::close_port(const std::string& why) {
  log_.error(why + ": the PROFIBUS line is down; opening " + config_.port + " again every " +
             std::to_string(std::chrono::duration_cast<milliseconds>(kReopenInterval).count()) +
             " ms");
  line_.clear_port();
  loop_.remove_fd(port_->fd());
  port_.reset();
  if (reopen_timer_) return;
  reopen_timer_ = loop_.add_periodic(kReopenInterval, [this] {
    std::string e;
    if (!open_port(&e)) return;  // still gone; stations keep showing Station_Non_Existent
    loop_.cancel_timer(reopen_timer_);
    reopen_timer_ = 0;
    log_.info("PROFIBUS line " + describe() + ": port open again");
  });
}

std::string MasterLinePort::describe() const {
  return (port_desc_.empty() ? config_.port : port_desc_) + ", " + std::to_string(config_.baud) +
         " baud, role master";
}

void MasterLinePort::write(std::span<const std::uint8_t> bytes) {
  if (!port_) return;
  std::string error;
  if (!port_->write(bytes.data(), bytes.size(), loop_.now(), &error)) {
    log_.error(error);
    return;
  }
  if (port_->pending() > 0)
    loop_.modify_fd(port_->fd(), EventLoop::kReadable | EventLoop::kWritable);
}

void MasterLinePort::on_readable(bool hangup) {
  const Time now = loop_.now();
  rx_.clear();
  std::string error;
  const long n = port_->read(rx_, now, &error);
  if (n < 0) {
    close_port(error);
    return;
  }
  if (n == 0 && hangup) {
    // Hangup with nothing to read: the other end of a pty closed.
    close_port("read " + config_.port + ": end of file");
    return;
  }
  serial::split_parity(
      rx_, [&](std::span<const std::uint8_t> run) { line_.on_bytes(run, now); },
      [&](std::uint8_t bad) { line_.on_bad_char(bad, now); });
  // Idle ≥ TSYN after the last character ends a partial telegram (docs/profibus.md).
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  gap_timer_ = loop_.add_timer(line_.bit_times(phy::kTsynBits), [this] {
    gap_timer_ = 0;
    line_.on_gap(loop_.now());
  });
}

}  // namespace candp2::profibus_line
