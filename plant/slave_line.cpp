#include "plant/slave_line.hpp"

#include <algorithm>

#include "common/hex.hpp"

namespace candp2::plant {

SlaveLine::SlaveLine(const config::ProfibusConfig& config, dp::ProcessImage& image, LogSink* log)
    : config_(config),
      image_(image),
      log_(log, "profibus"),
      front_(fdl::SlaveFrontEndOptions{.baud = config.baud,
                                       .master_address = config.master_address,
                                       .default_min_tsdr_bits =
                                           static_cast<std::uint8_t>(config.bus.min_tsdr_bits)},
             log) {}

void SlaveLine::set_tap(
    std::function<void(std::span<const std::uint8_t>, bool from_emulation, Time)> tap) {
  tap_ = std::move(tap);
  // Every telegram on the line goes to the tap (requests to other stations too: a capture shows
  // the whole line).
  front_.set_observer([this](std::span<const std::uint8_t> raw, Time now) {
    if (tap_) tap_(raw, false, now);
  });
}

bool SlaveLine::add(dp::DpSlave& slave, const dp::SlaveParameters& params, std::string name) {
  if (!front_.add(slave)) return false;
  auto st = std::make_unique<Station>();
  st->slave = &slave;
  st->name = std::move(name);
  // The configured slots' PLC addresses, mapped as the built-in master maps them.
  st->map = dp::map_image(params);
  stations_.push_back(std::move(st));
  return true;
}

SlaveLine::Station* SlaveLine::station(std::uint8_t address) {
  for (auto& s : stations_)
    if (s->slave->info().address == address) return s.get();
  return nullptr;
}

void SlaveLine::on_bytes(std::span<const std::uint8_t> bytes, Time now) {
  handled(front_.on_bytes(bytes, now), now);
}

void SlaveLine::on_bad_char(std::uint8_t byte, Time now) {
  front_.parser().feed_bad_char(byte);
  handled(front_.on_bytes({}, now), now);
}

void SlaveLine::on_gap(Time now) {
  handled(front_.on_gap(now), now);
}

void SlaveLine::handled(std::optional<fdl::Reply> reply, Time request_end) {
  if (!reply) return;
  if (Station* st = station(reply->station)) {
    if (!st->present) {
      log_.info("station " + std::to_string(reply->station) + " (" + st->name +
                "): " + (st->last_request ? "master returned" : "a master talks to it"));
      st->present = true;
    }
    st->last_request = request_end;
    st->request_end = request_end;
    mirror(*st);
  }
  reply_ = std::move(reply);
}

std::optional<fdl::Reply> SlaveLine::take_reply() {
  auto r = std::move(reply_);
  reply_.reset();
  return r;
}

void SlaveLine::sent(const fdl::Reply& reply, Time now) {
  if (tap_) tap_(reply.bytes, true, now);
  if (Station* st = station(reply.station)) {
    const auto us = static_cast<std::uint32_t>(std::max<std::int64_t>(
        0, std::chrono::duration_cast<microseconds>(now - st->request_end).count()));
    st->response_us = us;
    st->response_max_us = std::max(st->response_max_us, us);
  }
  if (log_.enabled(LogLevel::Trace))
    log_.log(LogLevel::Trace,
             "station " + std::to_string(reply.station) + " > " + hex_bytes(reply.bytes));
}

void SlaveLine::mirror(Station& st) {
  // docs/profibus.md "The line inside candp2d": the Modbus image shows what travels on the wire.
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

void SlaveLine::check_presence(Time now) {
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

std::optional<station::LineStatus> SlaveLine::status(std::uint8_t address) const {
  const fdl::StationStats* s = front_.stats(address);
  if (!s) return std::nullopt;
  station::LineStatus l;
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

}  // namespace candp2::plant
