#include "daemon/profibus_line.hpp"

#include <algorithm>

#include "common/hex.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::daemon {

namespace {
// A station is "present" while its master sent it a request within this time (logs and status).
constexpr Duration kPresenceTimeout = milliseconds(1000);
}  // namespace

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

std::unique_ptr<ProfibusSlaveLine> ProfibusSlaveLine::open(const config::ProfibusConfig& config,
                                                           EventLoop& loop, dp::ProcessImage& image,
                                                           LogSink* log, std::string* error) {
  std::unique_ptr<ProfibusSlaveLine> line(new ProfibusSlaveLine(config, loop, image, log));
  std::string e;
  line->port_ = serial::SerialPort::open(serial_options(config, log), &e);
  if (!line->port_) {
    *error = "PROFIBUS line (" + config.json_path + ".port): " + e;
    return nullptr;
  }
  ProfibusSlaveLine* self = line.get();
  if (!loop.add_fd(
          line->port_->fd(), EventLoop::kReadable,
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
  line->watching_ = true;
  line->presence_timer_ = loop.add_periodic(milliseconds(100), [self] { self->check_presence(); });
  return line;
}

ProfibusSlaveLine::ProfibusSlaveLine(const config::ProfibusConfig& config, EventLoop& loop,
                                     dp::ProcessImage& image, LogSink* log)
    : config_(config),
      loop_(loop),
      image_(image),
      log_(log, "profibus"),
      front_(fdl::SlaveFrontEndOptions{.baud = config.baud,
                                       .master_address = config.master_address,
                                       .default_min_tsdr_bits = config.min_tsdr_bits},
             log) {}

ProfibusSlaveLine::~ProfibusSlaveLine() {
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  if (send_timer_) loop_.cancel_timer(send_timer_);
  if (presence_timer_) loop_.cancel_timer(presence_timer_);
  if (watching_) loop_.remove_fd(port_->fd());
}

bool ProfibusSlaveLine::add(dp::DpSlave& slave, const dp::SlaveParameters& params,
                            std::string name) {
  if (!front_.add(slave)) return false;
  auto st = std::make_unique<Station>();
  st->slave = &slave;
  st->name = std::move(name);
  // The configured slots' PLC addresses, mapped as the built-in master maps them.
  st->map = dp::map_image(params);
  stations_.push_back(std::move(st));
  return true;
}

ProfibusSlaveLine::Station* ProfibusSlaveLine::station(std::uint8_t address) {
  for (auto& s : stations_)
    if (s->slave->info().address == address) return s.get();
  return nullptr;
}

std::string ProfibusSlaveLine::describe() const {
  return port_text(*port_, config_.port) + ", " + std::to_string(config_.baud) +
         " baud, role slaves";
}

void ProfibusSlaveLine::on_readable() {
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
  auto& parser = front_.parser();
  serial::split_parity(
      rx_, [&](std::span<const std::uint8_t> run) { parser.feed(run); },
      [&](std::uint8_t bad) { parser.feed_bad_char(bad); });
  handle(front_.on_bytes({}, now), now);  // answers what the parser completed
  // A partial telegram: idle for TSYN (33 bit times, emulator-spec §10) ends it.
  if (gap_timer_) loop_.cancel_timer(gap_timer_);
  gap_timer_ = 0;
  if (parser.buffered() > 0)
    gap_timer_ = loop_.add_timer(front_.bit_times(33), [this] {
      gap_timer_ = 0;
      on_gap_timer();
    });
}

void ProfibusSlaveLine::on_gap_timer() {
  const Time now = loop_.now();
  handle(front_.on_gap(now), now);
}

void ProfibusSlaveLine::handle(std::optional<fdl::Reply> reply, Time request_end) {
  if (!reply) return;
  if (Station* st = station(reply->station)) {
    if (!st->present) {
      log_.info("station " + std::to_string(reply->station) + " (" + st->name +
                "): " + (st->last_request ? "master returned" : "a master talks to it"));
      st->present = true;
    }
    st->last_request = request_end;
    mirror(*st);
  }
  // A newer request supersedes an answer still waiting for its min_TSDR.
  if (send_timer_) loop_.cancel_timer(send_timer_);
  send_timer_ = 0;
  const Time now = loop_.now();
  if (reply->not_before <= now) {
    send(std::move(reply->bytes), reply->station, request_end);
    return;
  }
  send_timer_ = loop_.add_timer(
      reply->not_before - now,
      [this, bytes = std::move(reply->bytes), station = reply->station, request_end]() mutable {
        send_timer_ = 0;
        send(std::move(bytes), station, request_end);
      });
}

void ProfibusSlaveLine::send(std::vector<std::uint8_t> bytes, std::uint8_t address,
                             Time request_end) {
  const Time now = loop_.now();
  std::string error;
  if (!port_->write(bytes.data(), bytes.size(), now, &error)) {
    log_.error(error);
    return;
  }
  if (port_->pending() > 0)
    loop_.modify_fd(port_->fd(), EventLoop::kReadable | EventLoop::kWritable);
  if (Station* st = station(address)) {
    const auto us = static_cast<std::uint32_t>(std::max<std::int64_t>(
        0, std::chrono::duration_cast<microseconds>(now - request_end).count()));
    st->response_us = us;
    st->response_max_us = std::max(st->response_max_us, us);
  }
  if (log_.enabled(LogLevel::Trace))
    log_.log(LogLevel::Trace, "station " + std::to_string(address) + " > " + hex_bytes(bytes));
}

void ProfibusSlaveLine::mirror(Station& st) {
  // emulator-spec §10: the Modbus image shows what travels on the wire.
  const auto out = st.slave->outputs();
  const auto in = st.slave->inputs();
  for (const auto& m : st.map.out)
    if (m.dp_offset < out.size())
      std::copy_n(out.begin() + static_cast<std::ptrdiff_t>(m.dp_offset),
                  std::min(m.length, out.size() - m.dp_offset),
                  image_.outputs.begin() + m.plc_address);
  for (const auto& m : st.map.in)
    if (m.dp_offset < in.size())
      std::copy_n(in.begin() + static_cast<std::ptrdiff_t>(m.dp_offset),
                  std::min(m.length, in.size() - m.dp_offset),
                  image_.inputs.begin() + m.plc_address);
}

void ProfibusSlaveLine::check_presence() {
  const Time now = loop_.now();
  for (auto& st : stations_) {
    if (st->present && st->last_request && now - *st->last_request > kPresenceTimeout) {
      st->present = false;
      log_.warn("station " + std::to_string(st->slave->info().address) + " (" + st->name +
                "): no request for " +
                std::to_string(std::chrono::duration_cast<milliseconds>(kPresenceTimeout).count()) +
                " ms: master lost");
    }
  }
}

std::optional<modbus::StatusInputs::Line> ProfibusSlaveLine::status(std::uint8_t address) const {
  const fdl::StationStats* s = front_.stats(address);
  if (!s) return std::nullopt;
  modbus::StatusInputs::Line l;
  l.role = 1;
  const auto& p = front_.line_stats();
  l.telegrams = static_cast<std::uint32_t>(p.telegrams);
  l.fcs_errors = static_cast<std::uint32_t>(p.fcs_errors);
  l.other_errors = static_cast<std::uint32_t>(p.framing_errors + p.parity_errors);
  l.requests = static_cast<std::uint32_t>(s->requests);
  l.retries = static_cast<std::uint32_t>(s->repetitions);
  for (const auto& st : stations_)
    if (st->slave->info().address == address) {
      l.response_us = st->response_us;
      l.response_max_us = st->response_max_us;
      l.present = st->present;
    }
  return l;
}

}  // namespace candp2::daemon
