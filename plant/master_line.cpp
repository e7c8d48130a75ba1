#include "plant/master_line.hpp"

#include <algorithm>

#include "common/hex.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::plant {

namespace {
std::uint32_t clamp32(std::uint64_t v) {
  return static_cast<std::uint32_t>(std::min<std::uint64_t>(v, 0xFFFFFFFFu));
}
}  // namespace

MasterLine::MasterLine(const config::ProfibusConfig& config, std::uint8_t master_address,
                       LogSink* log)
    : log_(log, "profibus"),
      fdl_(
          fdl::MasterStationOptions{.address = master_address,
                                    .baud = config.baud,
                                    .slot_time_bits = config.bus.slot_time_bits,
                                    .retries = static_cast<std::uint8_t>(config.bus.retry_limit)},
          [this](std::span<const std::uint8_t> bytes, Time now) { transmit(bytes, now); }, log) {
  fdl_.set_observer([this](std::span<const std::uint8_t> raw, Time now) {
    statistics_.observe(raw, received_start(raw.size(), now));
    if (tap_) tap_(raw, false, now);
  });
  fdl_.set_drop_observer([this](std::span<const std::uint8_t> raw, Time now) {
    statistics_.observe_illegal(received_start(raw.size(), now));
  });
}

void MasterLine::add_remote(std::uint8_t address, std::string name) {
  names_[address] = std::move(name);
  statistics_.configure(address);
}

void MasterLine::set_port(WriteFn write, bool paced, Duration latency_allowance) {
  write_ = std::move(write);
  paced_ = paced;
  fdl_.set_latency_allowance(latency_allowance);
}

void MasterLine::transmit(std::span<const std::uint8_t> bytes, Time now) {
  // docs/profibus.md: DA is byte 1 of SD1/SD3, byte 4 of SD2 (bit 7 = a DSAP follows).
  std::optional<std::uint8_t> to;
  if (bytes.size() >= 6 && (bytes[0] == fdl::kSD1 || bytes[0] == fdl::kSD3))
    to = static_cast<std::uint8_t>(bytes[1] & fdl::kAddrMask);
  else if (bytes.size() >= 9 && bytes[0] == fdl::kSD2)
    to = static_cast<std::uint8_t>(bytes[4] & fdl::kAddrMask);
  const fdl::MasterStationStats* st = to ? fdl_.stats(*to) : nullptr;
  // The FDL master says when it repeats; anything else is a new request (docs/profibus.md "Line
  // statistics in role master"), and the statistics count the repeat: the one count of it,
  // `repeats` and `station_retries`. Counted even without a port: the master sent it and waits
  // in vain, so the live list agrees with its Station_Non_Existent.
  if (!st || to != sent_to_ || !fdl_.repeating()) statistics_.new_request();
  statistics_.observe(bytes, now);
  sent_to_ = to;
  answers_before_ = st ? st->responses : 0;
  if (tap_) tap_(bytes, true, now);
  if (!write_) return;  // no port: the telegram is lost on the wire; the slot time expires
  write_(bytes);
  request_end_ = now + (paced_ ? fdl_.wire_time(bytes.size()) : Duration(0));
  if (log_.enabled(LogLevel::Trace)) log_.log(LogLevel::Trace, "> " + hex_bytes(bytes));
}

void MasterLine::on_bytes(std::span<const std::uint8_t> bytes, Time now) {
  const auto station = sent_to_;
  const std::uint64_t before = answers_before_;
  fdl_.on_bytes(bytes, now);
  // A new valid answer from the station asked last: its response time (status block).
  if (!station) return;
  const fdl::MasterStationStats* st = fdl_.stats(*station);
  if (!st || st->responses <= before) return;
  answers_before_ = st->responses;
  const auto us = static_cast<std::uint32_t>(std::max<std::int64_t>(
      0, std::chrono::duration_cast<microseconds>(now - request_end_).count()));
  auto& t = times_[*station];
  t.last_us = us;
  t.max_us = std::max(t.max_us, us);
}

void MasterLine::on_bad_char(std::uint8_t byte, Time now) {
  fdl_.on_bad_char(byte, now);
}

void MasterLine::check_presence(const dp::DpMaster& master) {
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
                std::to_string(fdl_.options().retries) + " retries): Station_Non_Existent");
  }
}

station::LineStatus MasterLine::status(std::uint8_t address, const dp::DpMaster& master) const {
  station::LineStatus l;
  l.role = 2;  // docs/modbus.md kLineRole: 2 role master
  const auto& p = fdl_.line_stats();
  l.telegrams = clamp32(p.telegrams);
  l.fcs_errors = clamp32(p.fcs_errors);
  l.other_errors = clamp32(p.framing_errors + p.parity_errors);
  if (const fdl::MasterStationStats* s = fdl_.stats(address)) {
    l.requests = clamp32(s->telegrams_sent);
    // The repeats the line statistics counted (one count, docs/profibus.md "Line statistics in
    // role master").
    l.retries = clamp32(statistics_.station(address).repeats);
  }
  // The last / highest response time (request's last character → answer complete).
  if (const auto it = times_.find(address); it != times_.end()) {
    l.response_us = it->second.last_us;
    l.response_max_us = it->second.max_us;
  }
  if (const auto v = master.slave(address))
    l.present = v->last_diag && !((*v->last_diag)[0] & dp::kDiag1StationNonExistent);
  return l;
}

}  // namespace candp2::plant
