#include "http/http_status.hpp"

#include <cstdio>
#include <sstream>

#include "drive_sim/unitek_drive.hpp"

namespace candp2::http {

namespace {

using nlohmann::json;

std::string hex_bytes(std::span<const std::uint8_t> bytes) {
  std::string out;
  out.reserve(bytes.size() * 3);
  char b[4];
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::snprintf(b, sizeof b, i ? " %02X" : "%02X", bytes[i]);
    out += b;
  }
  return out;
}

std::uint32_t get32(const modbus::StatusBlock& b, std::uint16_t at) {
  return (static_cast<std::uint32_t>(b[at]) << 16) | b[at + 1];
}

std::string_view direction(gw::SlotKind k) {
  switch (k) {
    case gw::SlotKind::Rx:
    case gw::SlotKind::CwIn:
    case gw::SlotKind::SegmentIn:
      return "rx";
    default:
      return "tx";
  }
}

double ms_since(Time now, Time then) {
  return static_cast<double>((now - then).count()) / 1000.0;
}

}  // namespace

std::uint32_t frame_bits_stuffed(const can::Frame& f) {
  // Stuffed region SOF..CRC: 34 (11-bit) / 54 (29-bit) bits + data; worst case one stuff bit per
  // four bits after the first (ISO 11898-1 bit stuffing after five equal bits, alternating runs).
  const std::uint32_t data = f.remote ? 0u : 8u * f.dlc;
  const std::uint32_t stuffed = (f.extended ? 54u : 34u) + data;
  return gw::frame_bits(f) + (stuffed - 1) / 4;
}

void BusMonitor::on_frame(const can::Frame& f, Time now) {
  ++frames_;
  bits_ += frame_bits_stuffed(f);
  trace_.push_back({frames_, now, f});
  if (trace_.size() > kTrace) trace_.pop_front();
}

StatusModel::StatusModel(StatusSources sources)
    : src_(std::move(sources)), load_(src_.buses.size()) {
  for (const auto& g : src_.gateways)
    addresses_.push_back(config::slave_parameters(*g.cfg).addresses);
}

void StatusModel::update_load(Time now) {
  for (std::size_t i = 0; i < src_.buses.size(); ++i) {
    const auto& b = src_.buses[i];
    auto& w = load_[i];
    if (!b.monitor) continue;
    if (w.start == Time{0}) {
      w = {now, b.monitor->bits(), 0, 0, b.monitor->frames()};
      continue;
    }
    const auto span = now - w.start;
    if (span < seconds(1)) continue;
    const double s = static_cast<double>(span.count()) / 1e6;
    w.load = b.bitrate ? static_cast<double>(b.monitor->bits() - w.bits) / s / b.bitrate : 0;
    w.fps = static_cast<double>(b.monitor->frames() - w.frames) / s;
    w.start = now;
    w.bits = b.monitor->bits();
    w.frames = b.monitor->frames();
  }
}

json StatusModel::gateway_json(std::size_t index, Time now) const {
  const GatewaySource& g = src_.gateways[index];
  using namespace modbus::status;
  const auto block = g.face->status(now);
  const auto st = g.gateway->status();
  json j;
  j["name"] = g.cfg->name;
  j["bus"] = g.cfg->bus;
  j["dp_address"] = block[kDpAddress];
  j["dp_state"] = std::string(dp::to_string(st.dp_state));
  j["dp_state_code"] = block[kDpState];
  const auto view = src_.master ? src_.master->slave(g.gateway->address()) : std::nullopt;
  j["master_state"] = view ? std::string(dp::to_string(view->state)) : "";
  // manual table 3.3.1, encoded once in modbus::encode_status (docs/modbus.md led codes).
  j["leds"] = {{"P", block[kLedP]}, {"D", block[kLedD]}, {"E", block[kLedE]}, {"C", block[kLedC]}};
  json diag = json::array();
  for (int i = 0; i < 11; ++i) diag.push_back(block[kDiag + i]);
  j["diag"] = std::move(diag);
  j["bus_state"] = std::string(can::to_string(st.bus_state));
  j["released"] = st.released;
  j["nmt"] = std::string(gw::to_string(st.nmt));
  j["counters"] = {{"rx_frames", get32(block, kRxFrames)},
                   {"tx_frames", get32(block, kTxFrames)},
                   {"irq_lost", get32(block, kIrqLost)},
                   {"msg_lost", get32(block, kMsgLost)},
                   {"data_exchanges", get32(block, kDataExchanges)},
                   {"parameterizations", get32(block, kParameterizations)},
                   {"master_data_exchanges", view ? view->data_exchanges : 0u}};
  j["fifo"] = {{"level", st.fifo_level}, {"high_water", st.fifo_high_water}};
  j["sync_ms"] = st.sync_ms;
  j["wakeup_s"] = st.wakeup_s;

  // Set_Prm user parameters (manual §5.1.2): the accepted ones, else the configured ones.
  const bool accepted = g.gateway->user_prm().has_value();
  const gw::UserPrm& p = accepted ? *g.gateway->user_prm() : g.cfg->parameters;
  const auto user = gw::encode_user_prm(p);
  j["parameters"] = {
      {"accepted", accepted},
      {"bitrate", p.bitrate_index < gw::kBitrates.size() ? gw::kBitrates[p.bitrate_index] : 0},
      {"bitrate_index", p.bitrate_index},
      {"comm_window", p.comm_window},
      {"send_rtr", p.send_rtr},
      {"canopen", std::string(gw::to_string(p.role()))},
      {"start_frame", p.start_frame},
      {"page_mode", p.page_mode},
      {"module_id", p.module_id},
      {"can_diagnosis", p.can_diagnosis},
      {"rx_counter", p.rx_counter},
      {"tx_counter", p.tx_counter},
      {"wakeup_s", p.wakeup_s},
      {"sync_ms", p.sync_ms},
      {"watchdog_ms", g.cfg->watchdog_ms},
      {"user_prm_hex", hex_bytes(user)},
  };

  const auto& cfg = g.gateway->slot_config();
  j["page_mode"] = {
      {"enabled", cfg && cfg->page_mode},
      {"state", cfg && cfg->page_mode ? std::string(gw::to_string(g.gateway->page_mode().state()))
                                      : std::string()},
      {"pages_processed", g.gateway->page_mode().pages_processed()}};

  json slots = json::array();
  if (cfg && src_.master) {
    const auto& addresses = addresses_[index];
    const auto& stats = g.gateway->slot_engine().slot_stats();
    const auto& image = src_.master->image();
    for (std::size_t i = 0; i < cfg->slots.size(); ++i) {
      const gw::Slot& s = cfg->slots[i];
      json e;
      e["slot"] = s.index;
      e["kind"] = std::string(gw::to_string(s.kind));
      e["dir"] = std::string(direction(s.kind));
      if (s.id) {
        e["id"] = s.id->id;
        e["extended"] = s.id->extended;
      } else {
        e["id"] = nullptr;
        e["extended"] = false;
      }
      e["form"] = s.form;
      e["cycle_ms"] = s.cycle_ms;
      e["length"] = s.length;
      e["counter"] = s.counter;
      std::optional<std::uint16_t> plc;
      if (s.index < addresses.size())
        plc = s.is_input() ? addresses[s.index].input : addresses[s.index].output;
      if (plc && *plc + s.length <= dp::kImageSize) {
        e["plc"] = std::string(s.is_input() ? "I" : "Q") + std::to_string(*plc);
        const auto* base = s.is_input() ? image.inputs.data() : image.outputs.data();
        e["bytes"] = hex_bytes({base + *plc, s.length});
      } else {
        e["plc"] = nullptr;
        e["bytes"] = "";
      }
      const auto stat = i < stats.size() ? stats[i] : gw::SlotEngine::SlotStats{};
      e["frames"] = stat.frames;
      if (stat.last)
        e["age_ms"] = ms_since(now, *stat.last);
      else
        e["age_ms"] = nullptr;
      slots.push_back(std::move(e));
    }
  }
  j["slots"] = std::move(slots);
  return j;
}

json StatusModel::status(Time now) {
  update_load(now);
  json j;
  j["version"] = 1;
  j["time_ms"] = static_cast<double>(now.count()) / 1000.0;
  json cycle = {{"period_ms", src_.cycle_ms}};
  if (src_.cycle) {
    const auto s = src_.cycle->summary();
    cycle["cycles"] = s.cycles;
    cycle["lateness_us"] = {{"samples", s.samples},
                            {"p50", s.p50_us},
                            {"p99", s.p99_us},
                            {"max", s.max_us},
                            {"max_ever", s.max_ever_us}};
  }
  j["cycle"] = std::move(cycle);
  if (src_.modbus) {
    const auto& ms = src_.modbus->stats();
    j["modbus"] = {{"requests", ms.requests},
                   {"exceptions", ms.exceptions},
                   {"clients", src_.modbus->client_count()},
                   {"clients_accepted", ms.clients_accepted}};
  }
  j["http"] = {{"requests", http_.requests},
               {"sse_clients", http_.sse_clients},
               {"snapshots", http_.snapshots},
               {"snapshots_dropped", http_.snapshots_dropped},
               {"last_build_us", http_.last_build_us}};
  json buses = json::array();
  for (std::size_t i = 0; i < src_.buses.size(); ++i) {
    const auto& b = src_.buses[i];
    json e = {{"name", b.cfg->name},
              {"type", std::string(config::to_string(b.cfg->type))},
              {"bitrate", b.bitrate}};
    if (b.monitor) {
      e["frames"] = b.monitor->frames();
      e["bits"] = b.monitor->bits();
      e["load_pct"] = load_[i].load * 100.0;
      e["frames_per_s"] = load_[i].fps;
      json trace = json::array();
      for (const auto& t : b.monitor->trace())
        trace.push_back({{"seq", t.seq},
                         {"t_ms", static_cast<double>(t.time.count()) / 1000.0},
                         {"id", t.frame.id},
                         {"ext", t.frame.extended},
                         {"rtr", t.frame.remote},
                         {"dlc", t.frame.dlc},
                         {"data", hex_bytes(t.frame.payload())}});
      e["trace"] = std::move(trace);
    }
    buses.push_back(std::move(e));
  }
  j["buses"] = std::move(buses);
  json gateways = json::array();
  for (std::size_t i = 0; i < src_.gateways.size(); ++i) gateways.push_back(gateway_json(i, now));
  j["gateways"] = std::move(gateways);
  json drives = json::array();
  for (const auto& d : src_.drives)
    drives.push_back({{"name", d.cfg->name},
                      {"bus", d.cfg->bus},
                      {"enabled", d.drive->enabled()},
                      {"mode", std::string(drive::to_string(d.drive->control_mode()))},
                      {"speed", d.drive->speed_actual()},
                      {"position", d.drive->position_actual()},
                      {"status", d.drive->status()}});
  j["drives"] = std::move(drives);
  return j;
}

std::string StatusModel::metrics(Time now) {
  update_load(now);
  std::ostringstream out;
  auto family = [&](std::string_view name, std::string_view type, std::string_view help) {
    out << "# HELP " << name << ' ' << help << "\n# TYPE " << name << ' ' << type << '\n';
  };
  struct Row {
    std::string labels;
    modbus::StatusBlock block;
  };
  std::vector<Row> rows;
  for (const auto& g : src_.gateways)
    rows.push_back({"gateway=\"" + std::to_string(g.gateway->address()) + "\",bus=\"" + g.cfg->bus +
                        "\",name=\"" + g.cfg->name + "\"",
                    g.face->status(now)});
  using namespace modbus::status;
  auto per_gateway = [&](std::string_view name, std::string_view type, std::string_view help,
                         auto value) {
    family(name, type, help);
    for (const auto& r : rows) out << name << '{' << r.labels << "} " << value(r.block) << '\n';
  };
  per_gateway("candp2_gateway_can_frames_received_total", "counter",
              "CAN frames the gateway received since power-on",
              [](const auto& b) { return get32(b, kRxFrames); });
  per_gateway("candp2_gateway_can_frames_sent_total", "counter",
              "CAN frames the gateway sent since power-on",
              [](const auto& b) { return get32(b, kTxFrames); });
  family("candp2_gateway_can_frames_lost_total", "counter",
         "CAN frames lost: irq = before the gateway saw them (IRQ_LOST), fifo = dropped at the "
         "full Communication Window FIFO (MSG_LOST), emulator-spec §3");
  for (const auto& r : rows) {
    out << "candp2_gateway_can_frames_lost_total{" << r.labels << ",reason=\"irq\"} "
        << get32(r.block, kIrqLost) << '\n';
    out << "candp2_gateway_can_frames_lost_total{" << r.labels << ",reason=\"fifo\"} "
        << get32(r.block, kMsgLost) << '\n';
  }
  per_gateway("candp2_gateway_data_exchanges_total", "counter",
              "Data_Exchange telegrams the gateway answered",
              [](const auto& b) { return get32(b, kDataExchanges); });
  per_gateway("candp2_gateway_parameterizations_total", "counter",
              "Set_Prm telegrams the master sent to the gateway",
              [](const auto& b) { return get32(b, kParameterizations); });
  per_gateway("candp2_gateway_fifo_level", "gauge",
              "frames waiting in the Communication Window FIFO (manual §5.3)",
              [](const auto& b) { return b[kFifoLevel]; });
  per_gateway("candp2_gateway_fifo_high_water", "gauge", "highest FIFO level since power-on",
              [](const auto& b) { return b[kFifoHighWater]; });
  per_gateway("candp2_gateway_dp_state", "gauge",
              "DP slave state: 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch",
              [](const auto& b) { return b[kDpState]; });
  per_gateway("candp2_gateway_can_bus_state", "gauge",
              "CAN controller: 0 ok, 1 warning, 2 error-passive, 3 bus-off",
              [](const auto& b) { return b[kBusState]; });

  family("candp2_bus_frames_total", "counter", "CAN frames seen on the bus");
  for (const auto& b : src_.buses)
    if (b.monitor)
      out << "candp2_bus_frames_total{bus=\"" << b.cfg->name << "\"} " << b.monitor->frames()
          << '\n';
  family("candp2_bus_load_ratio", "gauge",
         "bus load over the last second: estimated bits (stuff bits worst case) / bit rate");
  for (std::size_t i = 0; i < src_.buses.size(); ++i)
    if (src_.buses[i].monitor)
      out << "candp2_bus_load_ratio{bus=\"" << src_.buses[i].cfg->name << "\"} " << load_[i].load
          << '\n';

  if (src_.modbus) {
    family("candp2_modbus_requests_total", "counter",
           "Modbus/TCP requests answered (normal and exception answers)");
    out << "candp2_modbus_requests_total{result=\"ok\"} " << src_.modbus->stats().requests << '\n';
    out << "candp2_modbus_requests_total{result=\"exception\"} " << src_.modbus->stats().exceptions
        << '\n';
    family("candp2_modbus_clients", "gauge", "Modbus/TCP clients connected");
    out << "candp2_modbus_clients " << src_.modbus->client_count() << '\n';
  }
  family("candp2_http_sse_clients", "gauge", "Server-Sent Events streams open");
  out << "candp2_http_sse_clients " << http_.sse_clients << '\n';
  family("candp2_http_snapshots_dropped_total", "counter",
         "SSE snapshots replaced by a newer one before a slow client started writing them");
  out << "candp2_http_snapshots_dropped_total " << http_.snapshots_dropped << '\n';
  if (src_.cycle) {
    const auto s = src_.cycle->summary();
    family("candp2_master_cycles_total", "counter", "DP master cycles started");
    out << "candp2_master_cycles_total " << s.cycles << '\n';
    family("candp2_master_cycle_lateness_seconds", "gauge",
           "how late the master cycle started against its grid, over the last cycles");
    out << "candp2_master_cycle_lateness_seconds{quantile=\"0.5\"} " << s.p50_us / 1e6 << '\n';
    out << "candp2_master_cycle_lateness_seconds{quantile=\"0.99\"} " << s.p99_us / 1e6 << '\n';
    out << "candp2_master_cycle_lateness_seconds{quantile=\"1\"} " << s.max_us / 1e6 << '\n';
  }
  return out.str();
}

}  // namespace candp2::http
