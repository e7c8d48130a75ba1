#include "daemon/profibus_master_line.hpp"

#include <algorithm>
#include <filesystem>

#include "common/hex.hpp"
#include "daemon/profibus_line.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::daemon {

namespace {
// A dead port (EIO/hangup) is opened again this often (docs/profibus.md).
constexpr Duration kReopenInterval = milliseconds(200);
// emulator-spec §10: a telegram is preceded by ≥ 33 bit times of idle (TSYN).
constexpr std::uint64_t kTsynBits = 33;

std::uint32_t clamp32(std::uint64_t v) {
  return static_cast<std::uint32_t>(std::min<std::uint64_t>(v, 0xFFFFFFFFu));
}
}  // namespace

Duration master_latency_allowance(bool is_pty, bool low_latency) {
  // docs/profibus.md "Timing in role master": a pty is a hand-over between two processes that
  // may wait for a CPU on a busy host; a serial port in low-latency mode delivers within ~1 ms;
  // without it (FTDI latency timer, 16 ms by default) the answer may sit in the adapter.
  if (is_pty) return milliseconds(20);
  return low_latency ? milliseconds(3) : milliseconds(20);
}

std::unique_ptr<ProfibusMasterLine> ProfibusMasterLine::open(const config::ProfibusConfig& config,
                                                             std::uint8_t master_address,
                                                             EventLoop& loop, LogSink* log,
                                                             std::string* error) {
  std::unique_ptr<ProfibusMasterLine> line(new ProfibusMasterLine(config, loop, log));
  std::string e;
  if (!line->open_port(&e)) {
    *error = "PROFIBUS line (" + config.json_path + ".port): " + e;
    return nullptr;
  }
  ProfibusMasterLine* self = line.get();
  line->fdl_ = std::make_unique<fdl::FdlMaster>(
      fdl::MasterStationOptions{.address = master_address,
                                .baud = config.baud,
                                .slot_time_bits = config.slot_time_bits,
                                .retries = config.retries,
                                .latency_allowance = master_latency_allowance(
                                    line->port_->is_pty(), line->port_->low_latency())},
      [self](std::span<const std::uint8_t> bytes, Time) { self->send(bytes); }, log);
  return line;
}

ProfibusMasterLine::ProfibusMasterLine(const config::ProfibusConfig& config, EventLoop& loop,
                                       LogSink* log)
    : config_(config), loop_(loop), log_sink_(log), log_(log, "profibus") {}

ProfibusMasterLine::~ProfibusMasterLine() {
  if (deadline_timer_) loop_.cancel_timer(deadline_timer_);
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  if (reopen_timer_) loop_.cancel_timer(reopen_timer_);
  if (port_) loop_.remove_fd(port_->fd());
}

bool ProfibusMasterLine::open_port(std::string* error) {
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
  on_pty_ = port_->is_pty() || (!ec && real.rfind("/dev/pts/", 0) == 0);
  port_desc_ = port_text(*port_, config_.port);
  return true;
}

void ProfibusMasterLine::close_port(const std::string& why) {
  log_.error(why + ": the PROFIBUS line is down; opening " + config_.port + " again every " +
             std::to_string(std::chrono::duration_cast<milliseconds>(kReopenInterval).count()) +
             " ms");
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

std::string ProfibusMasterLine::describe() const {
  return (port_desc_.empty() ? config_.port : port_desc_) + ", " + std::to_string(config_.baud) +
         " baud, role master";
}

void ProfibusMasterLine::send(std::span<const std::uint8_t> bytes) {
  // No port (it died, reopening): the telegram is lost on the wire; the slot time expires.
  if (!port_) return;
  std::string error;
  if (!port_->write(bytes.data(), bytes.size(), loop_.now(), &error)) {
    log_.error(error);
    return;
  }
  if (port_->pending() > 0)
    loop_.modify_fd(port_->fd(), EventLoop::kReadable | EventLoop::kWritable);
  // emulator-spec §10: DA is byte 1 of SD1/SD3, byte 4 of SD2 (bit 7 = a DSAP follows).
  sent_to_.reset();
  if (bytes.size() >= 6 && (bytes[0] == fdl::kSD1 || bytes[0] == fdl::kSD3))
    sent_to_ = static_cast<std::uint8_t>(bytes[1] & fdl::kAddrMask);
  else if (bytes.size() >= 9 && bytes[0] == fdl::kSD2)
    sent_to_ = static_cast<std::uint8_t>(bytes[4] & fdl::kAddrMask);
  request_end_ = loop_.now() + (on_pty_ ? Duration(0) : fdl_->wire_time(bytes.size()));
  if (sent_to_) answers_before_ = fdl_->stats(*sent_to_) ? fdl_->stats(*sent_to_)->responses : 0;
  if (log_.enabled(LogLevel::Trace)) log_.log(LogLevel::Trace, "> " + hex_bytes(bytes));
}

void ProfibusMasterLine::on_readable(bool hangup) {
  const Time now = loop_.now();
  rx_.clear();
  std::string error;
  const long n = port_->read(rx_, now, &error);
  if (n < 0) {
    close_port(error);
    rearm();
    return;
  }
  if (n == 0 && hangup) {
    // Hangup with nothing to read: the other end of a pty closed.
    close_port("read " + config_.port + ": end of file");
    rearm();
    return;
  }
  const auto station = sent_to_;
  const Time request_end = request_end_;
  const std::uint64_t before = answers_before_;
  serial::split_parity(
      rx_, [&](std::span<const std::uint8_t> run) { fdl_->on_bytes(run, now); },
      [&](std::uint8_t bad) { fdl_->on_bad_char(bad, now); });
  // A new valid answer from the station asked last: its response time (status block).
  if (station) {
    const fdl::MasterStationStats* st = fdl_->stats(*station);
    if (st && st->responses > before) {
      const auto us = static_cast<std::uint32_t>(std::max<std::int64_t>(
          0, std::chrono::duration_cast<microseconds>(now - request_end).count()));
      auto& t = times_[*station];
      t.last_us = us;
      t.max_us = std::max(t.max_us, us);
    }
  }
  // Idle ≥ TSYN after the last character ends a partial telegram (emulator-spec §10).
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  gap_timer_ = loop_.add_timer(fdl_->bit_times(kTsynBits), [this] {
    gap_timer_ = 0;
    fdl_->on_gap(loop_.now());
    rearm();
  });
  rearm();
}

void ProfibusMasterLine::rearm() {
  const auto next = fdl_->next_deadline();
  if (next == armed_ && (deadline_timer_ || !next)) return;
  if (deadline_timer_) loop_.cancel_timer(deadline_timer_);
  deadline_timer_ = 0;
  armed_ = next;
  if (!next) return;
  deadline_timer_ = loop_.add_timer(*next - loop_.now(), [this] {
    deadline_timer_ = 0;
    armed_.reset();
    fdl_->advance(loop_.now());
    rearm();
  });
}

void ProfibusMasterLine::check_presence(const dp::DpMaster& master) {
  for (const auto& v : master.slaves()) {
    if (!v.last_diag) continue;
    const bool there = !((*v.last_diag)[0] & dp::kDiag1StationNonExistent);
    const auto it = present_.find(v.address);
    if (it == present_.end()) {
      present_[v.address] = there;
      log_.info("station " + std::to_string(v.address) + ": " +
                (there ? "answers" : "does not answer (Station_Non_Existent)"));
      continue;
    }
    if (it->second == there) continue;
    it->second = there;
    if (there)
      log_.info("station " + std::to_string(v.address) + ": answers again; parameterizing");
    else
      log_.warn("station " + std::to_string(v.address) +
                ": lost (no answer within the slot time after " +
                std::to_string(fdl_->options().retries) + " retries): Station_Non_Existent");
  }
}

modbus::StatusInputs::Line ProfibusMasterLine::status(std::uint8_t address,
                                                      const dp::DpMaster& master) const {
  modbus::StatusInputs::Line l;
  l.role = 2;  // docs/modbus.md kLineRole: 2 role master
  const auto& p = fdl_->line_stats();
  l.telegrams = clamp32(p.telegrams);
  l.fcs_errors = clamp32(p.fcs_errors);
  l.other_errors = clamp32(p.framing_errors + p.parity_errors);
  if (const fdl::MasterStationStats* s = fdl_->stats(address)) {
    l.requests = clamp32(s->telegrams_sent);
    l.retries = clamp32(s->retries);
  }
  // Role master: the last / highest response time (request's last character → answer complete).
  if (const auto it = times_.find(address); it != times_.end()) {
    l.response_us = it->second.last_us;
    l.response_max_us = it->second.max_us;
  }
  if (const auto v = master.slave(address))
    l.present = v->last_diag && !((*v->last_diag)[0] & dp::kDiag1StationNonExistent);
  return l;
}

modbus::StatusBlock RemoteStationFace::status(Time) {
  modbus::StatusInputs in;
  in.dp_address = address_;
  if (const auto v = master_.slave(address_)) {
    in.master_state = v->state;
    in.parameterizations = v->parameterizations;
    if (v->last_diag) in.diag = *v->last_diag;
    // The slave's DP state as the master knows it (emulator-spec §10 role master).
    switch (v->state) {
      case dp::MasterSlaveState::DataExch:
        in.gateway.dp_state = dp::SlaveState::DataExch;
        break;
      case dp::MasterSlaveState::ChkCfg:
        in.gateway.dp_state = dp::SlaveState::WaitCfg;
        break;
      default:
        in.gateway.dp_state = dp::SlaveState::WaitPrm;
    }
    in.gateway.data_exchanges = v->data_exchanges;
    in.addressed = v->addressed;
  }
  in.line = line_.status(address_, master_);
  return modbus::encode_status(in);
}

void RemoteStationFace::control(modbus::Control command, Time now) {
  switch (command) {
    case modbus::Control::Reparameterize:
      log_.info(name_ + ": re-parameterization requested over Modbus");
      master_.reparameterize(address_, now);
      break;
    case modbus::Control::MasterStops:  // docs/faults.md: the PLC stops addressing the station
      master_.set_addressed(address_, false, now);
      break;
    case modbus::Control::MasterResumes:
      master_.set_addressed(address_, true, now);
      break;
    case modbus::Control::None:
    case modbus::Control::PowerCycle:  // refused before (refuses())
      return;
  }
  line_.rearm();
}

std::optional<std::string> RemoteStationFace::refuses(modbus::Control command) const {
  if (command != modbus::Control::PowerCycle) return std::nullopt;
  log_.warn(name_ +
            ": power cycle requested over Modbus refused: a remote station cannot be power-cycled "
            "over PROFIBUS (write 2 to re-parameterize it)");
  return "power cycle of remote station " + std::to_string(address_) +
         " (profibus role master): not possible over PROFIBUS";
}

}  // namespace candp2::daemon
