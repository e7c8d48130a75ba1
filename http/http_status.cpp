#include "http/http_status.hpp"

#include <array>
#include <cmath>
#include <cstdio>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"
#include "http/documents.hpp"
#include "plant/plant.hpp"

namespace candp2::http {

namespace {

using nlohmann::json;

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

// A time or a duration in milliseconds, as the documents show them.
double ms(Duration d) {
  return static_cast<double>(d.count()) / 1000.0;
}

double ms_since(Time now, Time then) {
  return ms(now - then);
}

// A row of the station table (station/status.hpp) by name; a name the table lacks does not
// compile.
consteval const station::Field& row(std::string_view name) {
  const station::Field* f = station::field(name);
  if (!f) throw "no such field in station::kFields";
  return *f;
}

// The four LEDs' codes (manual table 3.3.1) as the station table reads them.
json leds(const station::Status& s) {
  return {{"P", row("led_p").get(s)},
          {"D", row("led_d").get(s)},
          {"E", row("led_e").get(s)},
          {"C", row("led_c").get(s)}};
}

// The one line a tile shows when something is wrong, from the station's status (docs/modbus.md
// "Status block" lists the fields): the diagnosis' Prm/Cfg fault (manual §3.4), a CAN controller
// state other than ok, a master that stopped addressing the gateway. Empty when all is well.
std::string fault_text(const station::Status& s) {
  const auto d = [&](int i) { return s.diag[static_cast<std::size_t>(i)]; };
  if (d(8) == 0x3D)
    return "Prm fault: byte " + std::to_string(d(9)) + ", expected 0x" +
           hex_bytes(std::array{static_cast<std::uint8_t>(d(10))});
  if (d(8) == 0x3E)
    return "Cfg fault: slot " + std::to_string(d(9)) + ", code " + std::to_string(d(10));
  if (d(0) & 0x04) return "Cfg fault";
  if (d(0) & 0x40) return "Prm fault";
  static constexpr const char* kBus[] = {"", "CAN warning", "CAN error-passive", "CAN bus-off"};
  const std::uint64_t bus = row("bus_state").get(s);
  if (bus >= 1 && bus <= 3) return kBus[bus];
  if (row("addressed").get(s) == 0) return "not addressed by the master";
  return "";
}

}  // namespace

std::uint32_t frame_bits_stuffed(const can::Frame& f) {
  // The worst-case stuffing of docs/can-bus.md "Frames on the wire".
  return can::frame_bits_worst(f);
}

void BusMonitor::on_frame(const can::Frame& f, Time now) {
  bits_ += frame_bits_stuffed(f);
  ring_[frames_ % kTrace] = {frames_ + 1, now, f};
  ++frames_;
}

std::vector<BusMonitor::Traced> BusMonitor::trace() const {
  const std::uint64_t kept = std::min<std::uint64_t>(frames_, kTrace);
  std::vector<Traced> out;
  out.reserve(kept);
  for (std::uint64_t n = frames_ - kept; n < frames_; ++n) out.push_back(ring_[n % kTrace]);
  return out;
}

StatusModel::StatusModel(StatusSources sources)
    : src_(std::move(sources)), rates_(src_.gateways.size()), load_(src_.buses.size()) {
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

json StatusModel::gateway_head(std::size_t index, Time now) const {
  const GatewaySource& g = src_.gateways[index];
  const station::Status status = g.status(now);
  const gw::GatewayStatus& st = status.gateway;
  json j;
  j["name"] = g.cfg->name;
  j["bus"] = g.cfg->bus;
  j["dp_address"] = row("dp_address").get(status);
  j["dp_state"] = std::string(dp::to_string(st.dp_state));
  j["dp_state_code"] = row("dp_state").get(status);
  const plant::GatewayView gv = g.unit->view();
  const auto view = src_.master ? src_.master->slave(gv.address) : std::nullopt;
  j["master_state"] = view ? std::string(dp::to_string(view->state)) : "";
  j["leds"] = leds(status);  // manual table 3.3.1, encoded once in station::led::codes
  json diag = json::array();
  for (const std::uint8_t b : status.diag) diag.push_back(b);
  j["diag"] = std::move(diag);
  j["bus_state"] = std::string(can::to_string(st.bus_state));
  j["released"] = st.released;
  j["nmt"] = std::string(gw::to_string(st.nmt));
  // The gateway's counters of the station table (station/status.hpp), and the master's count.
  json counters = json::object();
  for (const auto& f : station::fields())
    if (f.shown & station::kGatewayCounters) counters[std::string(f.name)] = f.get(status);
  counters["master_data_exchanges"] = view ? view->data_exchanges : 0u;
  j["counters"] = std::move(counters);
  j["fifo"] = {{"level", st.fifo_level}, {"high_water", st.fifo_high_water}};
  j["sync_ms"] = st.sync_ms;
  j["wakeup_s"] = st.wakeup_s;

  // Set_Prm user parameters (manual §5.1.2): the accepted ones, else the configured ones.
  const gw::UserPrm& p = gv.parameters;
  const auto user = gw::encode_user_prm(p);
  j["parameters"] = {
      {"accepted", gv.accepted},
      {"bitrate", gw::bitrate_bps(p.bitrate_index).value_or(0)},
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

  const auto& cfg = gv.slot_config;
  j["page_mode"] = {
      {"enabled", cfg && cfg->page_mode},
      {"state", cfg && cfg->page_mode ? std::string(gw::to_string(gv.page_state)) : std::string()},
      {"pages_processed", gv.pages_processed}};
  j["slot_count"] = slot_count(index);
  return j;
}

std::size_t StatusModel::slot_count(std::size_t index) const {
  const auto& cfg = src_.gateways[index].unit->view().slot_config;
  return cfg && src_.master ? cfg->slots.size() : 0;
}

json StatusModel::slot_json(std::size_t index, std::size_t i, Time now, bool age) const {
  const GatewaySource& g = src_.gateways[index];
  const plant::GatewayView gv = g.unit->view();
  const auto& cfg = gv.slot_config;
  if (!cfg || !src_.master || i >= cfg->slots.size()) return nullptr;
  const auto& addresses = addresses_[index];
  const auto stats = gv.slot_stats;
  const auto& image = src_.master->image();
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
  const auto stat = i < stats.size() ? stats[i] : plant::GatewayView::SlotStats{};
  e["frames"] = stat.frames;
  if (age)
    e["age_ms"] = stat.last ? json(ms_since(now, *stat.last)) : json(nullptr);
  else
    e["last_ms"] = stat.last ? json(ms(*stat.last)) : json(nullptr);
  return e;
}

json StatusModel::tile(std::size_t index, Time now) {
  const GatewaySource& g = src_.gateways[index];
  const station::Status status = g.status(now);
  Rate& r = rates_[index];
  const std::uint32_t rx = status.gateway.rx_frames, tx = status.gateway.tx_frames;
  if (r.start == Time{0} || rx < r.rx || tx < r.tx) {  // first look, or a power cycle
    r = {now, rx, tx, 0, 0};
  } else if (now - r.start >= seconds(1)) {
    const double s = static_cast<double>((now - r.start).count()) / 1e6;
    r = {now, rx, tx, (rx - r.rx) / s, (tx - r.tx) / s};
  }
  json j;
  j["dp_address"] = row("dp_address").get(status);
  j["name"] = g.cfg->name;
  j["bus"] = g.cfg->bus;
  j["leds"] = leds(status);
  j["dp_state"] = std::string(dp::to_string(status.gateway.dp_state));
  j["fault"] = fault_text(status);
  // Whole frames/s: a tile changes only when something a viewer can see changes.
  j["fps"] = {{"rx", std::lround(r.rx_fps)}, {"tx", std::lround(r.tx_fps)}};
  return j;
}

json StatusModel::cycle_json() const {
  json cycle = {{"period_ms", src_.cycle_ms}};
  if (src_.cycle) {
    const auto s = src_.cycle->summary();
    cycle["cycles"] = s.cycles;
    cycle["missed"] = s.missed;
    cycle["lateness_us"] = {{"samples", s.samples},
                            {"p50", s.p50_us},
                            {"p99", s.p99_us},
                            {"max", s.max_us},
                            {"max_ever", s.max_ever_us}};
  }
  return cycle;
}

json StatusModel::line_json() const {
  if (!src_.line && !src_.line_stats) return nullptr;
  json j = {{"baud", src_.line_baud}};
  if (src_.line) {
    // docs/daemon.md "Statistics of the steady line": the bus cycle of the rotations that
    // parameterized no station, and those that did apart.
    const auto times = [](const fdl::RotationTimes& c) -> json {
      return {{"last", c.last.count()},
              {"min", c.min.count()},
              {"mean", c.mean().count()},
              {"max", c.max.count()},
              {"cycles", c.count}};
    };
    j["bus_cycle_us"] = times(src_.line->bus_cycle());
    j["parameterization_cycle_us"] = times(src_.line->parameterization_cycle());
    j["retries"] = src_.line->retries();
    j["gap_polls"] = src_.line->gap_polls();
  }
  if (!src_.line_stats) return j;
  // docs/profibus.md "Line statistics": the analyser's counters (fdl::kStationCounters) per
  // station, the live list and the faults on cue.
  const fdl::LineStatistics& st = *src_.line_stats;
  j["illegals_unattributed"] = st.illegals_unattributed();
  json live = {{"ok", json::array()}, {"missing", json::array()}, {"phantom", json::array()}};
  json stations = json::array();
  for (const std::uint8_t a : st.stations()) {
    const fdl::Live l = st.live(a);
    if (l != fdl::Live::None) live[std::string(fdl::to_string(l))].push_back(a);
    json s = {{"address", a}, {"live", fdl::to_string(l)}};
    for (const auto& f : fdl::kStationCounters) s[std::string(f.name)] = st.station(a).*f.member;
    s["fault"] = nullptr;
    if (src_.line) {
      if (const auto f = src_.line->fault(a); f.kind != fdl::StationFault::None)
        s["fault"] = {{"kind", fdl::to_string(f.kind)},
                      {"remaining", f.remaining},
                      {"every", f.every},
                      {"remaining_ms", f.remaining_time.count() / 1000}};
    }
    stations.push_back(std::move(s));
  }
  j["live_list"] = std::move(live);
  j["stations"] = std::move(stations);
  if (src_.line)
    j["noise_remaining_ms"] = src_.line->noise_remaining(src_.line->now()).count() / 1000;
  return j;
}

json StatusModel::modbus_json() const {
  if (!src_.modbus) return nullptr;
  const ModbusFigures m = src_.modbus();
  return {{"requests", m.requests},
          {"exceptions", m.exceptions},
          {"clients", m.clients},
          {"clients_accepted", m.clients_accepted}};
}

json StatusModel::http_json() const {
  return {{"requests", http_.requests},
          {"connections", http_.connections},
          {"clients_accepted", http_.clients_accepted},
          {"clients_evicted", http_.clients_evicted},
          {"clients_timed_out", http_.clients_timed_out},
          {"clients_refused", http_.clients_refused},
          {"sse_clients", http_.sse_clients},
          {"snapshots", http_.snapshots},
          {"snapshots_dropped", http_.snapshots_dropped},
          {"events", http_.events},
          {"event_bytes", http_.event_bytes},
          {"last_build_us", http_.last_build_us},
          {"work_us_max", http_.work_us_max}};
}

json StatusModel::host_stalls_json() const {
  const HostStalls h = src_.host_stalls ? src_.host_stalls() : HostStalls{};
  return {{"count", h.count}, {"total_ms", ms(h.total)}, {"longest_ms", ms(h.longest)}};
}

json StatusModel::trace_frame(const BusMonitor::Traced& t) const {
  return {{"seq", t.seq},
          {"t_ms", ms(t.time)},
          {"id", t.frame.id},
          {"ext", t.frame.extended},
          {"rtr", t.frame.remote},
          {"dlc", t.frame.dlc},
          {"data", hex_bytes(t.frame.payload())}};
}

json StatusModel::bus_json(std::size_t i, Time now, bool trace, bool identifiers) {
  update_load(now);
  const auto& b = src_.buses[i];
  json e = {{"name", b.cfg->name},
            {"type", std::string(config::to_string(b.cfg->type))},
            {"bitrate", b.bitrate}};
  if (b.monitor) {
    e["frames"] = b.monitor->frames();
    e["bits"] = b.monitor->bits();
    // docs/daemon.md "Bus load": an estimate on an ideal bus, the exact load of the last second on
    // a bus in time (the same number as its `load.last_pct`).
    e["load_pct"] = b.timed ? b.timed->load(now).last_pct : load_[i].load * 100.0;
    e["frames_per_s"] = load_[i].fps;
    if (b.timed) e.update(timed_json(*b.timed, now, identifiers));
    if (b.timed && b.faults) e["faults"] = faults_json(b.faults(now));
    if (trace) {
      json frames = json::array();
      for (const auto& t : b.monitor->trace()) frames.push_back(trace_frame(t));
      e["trace"] = std::move(frames);
    }
  }
  return e;
}

// docs/can-bus.md "Seen from outside": the CAN faults on cue in force, as the line shows a
// station's fault (line_json): what is left of a count or of a time.
json StatusModel::faults_json(const std::vector<plant::CanFaultView>& faults) {
  json out = json::array();
  for (const auto& f : faults)
    out.push_back({{"kind", plant::to_string(f.kind)},
                   {"node", f.node.empty() ? json(nullptr) : json(f.node)},
                   {"id", f.id ? json(f.id->id) : json(nullptr)},
                   {"ext", f.id && f.id->extended},
                   {"remaining", f.remaining},
                   {"every", f.every},
                   {"remaining_ms", f.remaining_time.count() / 1000}});
  return out;
}

std::string StatusModel::bus_text(std::size_t i, Time now, bool trace) {
  std::string text = bus_json(i, now, trace, false).dump();
  const can::TimedBus* t = src_.buses[i].timed;
  if (!t) return text;
  // The member's key cannot occur anywhere else in the text: a quote inside a string is escaped,
  // and no other object of a bus has an "identifiers" member.
  constexpr std::string_view placeholder = "\"identifiers\":null", null = "null";
  const std::size_t at = text.find(placeholder);
  if (at == std::string::npos) return text;  // not in this bus's text (no monitor)
  std::string ids;
  put_identifiers(ids, *t);
  text.replace(at + placeholder.size() - null.size(), null.size(), ids);
  return text;
}

namespace {
void put_number(std::string& out, double v) {
  // nlohmann::json's dump of a finite double (its own shortest round-trip digits), so that the
  // text is the one the json value would give, byte for byte.
  std::array<char, 64> buf{};
  out.append(buf.data(), nlohmann::detail::to_chars(buf.data(), buf.data() + buf.size(), v));
}
}  // namespace

// The identifiers' members, defined here once: the status documents take this text, timed_json()
// its parse. In nlohmann::json's order (its objects are std::maps: sorted keys) and with its
// digits, so that the text is the json's dump byte for byte.
void StatusModel::put_identifiers(std::string& out, const can::TimedBus& t) {
  std::vector<can::TimedBus::IdStatistics> list;
  t.identifiers(list);
  out += '[';
  for (std::size_t k = 0; k < list.size(); ++k) {
    const auto& s = list[k];
    if (k > 0) out += ',';
    out += s.id.extended ? "{\"ext\":true,\"frames\":" : "{\"ext\":false,\"frames\":";
    out += std::to_string(s.frames);
    out += ",\"id\":";
    out += std::to_string(s.id.id);
    out += ",\"jitter_ms\":";
    put_number(out, ms(s.jitter()));
    out += ",\"latency_ms\":{\"last\":";
    put_number(out, ms(s.latency_last));
    out += ",\"max\":";
    put_number(out, ms(s.latency_max));
    out += ",\"mean\":";
    put_number(out, ms(s.latency_mean()));
    out += "},\"period_ms\":";
    put_number(out, ms(s.period_mean()));
    out += s.remote ? ",\"rtr\":true}" : ",\"rtr\":false}";
  }
  out += ']';
}

// docs/can-bus.md "Seen from outside": the bus in time's own figures, exact (additive fields).
json StatusModel::timed_json(const can::TimedBus& t, Time now, bool identifiers) {
  const can::TimedBus::Load load = t.load(now);
  json ids;  // null: bus_text() writes them
  if (identifiers) {
    std::string text;
    put_identifiers(text, t);
    ids = json::parse(text);
  }
  // docs/can-bus.md "Error confinement": each node present on the bus, its counters and state.
  json nodes = json::array();
  for (std::size_t n = 0; n < t.nodes(); ++n) {
    if (!t.present(n)) continue;
    const can::TimedBus::Confinement& c = t.confinement(n);
    nodes.push_back({{"name", t.name(n)},
                     {"tec", c.tec},
                     {"rec", c.rec},
                     {"state", std::string(can::to_string(c.state))}});
  }
  return {{"timed_bitrate", t.bitrate()},
          {"load", {{"last_pct", load.last_pct}, {"max_pct", load.max_pct}}},
          {"frames_on_bus", t.frames()},
          {"tx_lost", t.lost()},
          {"error_frames", t.error_frames()},
          {"identifiers", std::move(ids)},
          {"nodes", std::move(nodes)}};
}

json StatusModel::drive_json(std::size_t i) const {
  const auto& d = src_.drives[i];
  const plant::DriveStatus st = d.unit->status();
  return {{"name", d.cfg->name},   {"bus", d.cfg->bus},
          {"enabled", st.enabled}, {"mode", std::string(drive::to_string(st.mode))},
          {"speed", st.speed},     {"position", st.position},
          {"status", st.status}};
}

std::optional<std::size_t> StatusModel::bus_of(std::size_t gateway) const {
  for (std::size_t b = 0; b < src_.buses.size(); ++b)
    if (src_.buses[b].cfg->name == src_.gateways[gateway].cfg->bus && src_.buses[b].monitor)
      return b;
  return std::nullopt;
}

json StatusModel::status_head(Time now, bool parts) {
  update_load(now);
  json j;
  j["version"] = 1;
  j["time_ms"] = ms(now);
  j["cycle"] = cycle_json();
  if (src_.line || src_.line_stats) j["line"] = line_json();
  if (src_.modbus) j["modbus"] = modbus_json();
  j["http"] = http_json();
  j["host_stalls"] = host_stalls_json();
  if (!parts) return j;
  json buses = json::array();
  for (std::size_t i = 0; i < src_.buses.size(); ++i) buses.push_back(bus_json(i, now, true));
  j["buses"] = std::move(buses);
  json drives = json::array();
  for (std::size_t i = 0; i < src_.drives.size(); ++i) drives.push_back(drive_json(i));
  j["drives"] = std::move(drives);
  return j;
}

json StatusModel::status(Time now) {
  json j = status_head(now);
  json gateways = json::array();
  for (std::size_t i = 0; i < src_.gateways.size(); ++i) {
    json g = gateway_head(i, now);
    json slots = json::array();
    for (std::size_t k = 0; k < slot_count(i); ++k) slots.push_back(slot_json(i, k, now, true));
    g["slots"] = std::move(slots);
    gateways.push_back(std::move(g));
  }
  j["gateways"] = std::move(gateways);
  json slaves = json::array();
  for (std::size_t i = 0; i < src_.slaves.size(); ++i) slaves.push_back(slave_json(i, now));
  j["slaves"] = std::move(slaves);
  return j;
}

std::string StatusModel::metrics(Time now) {
  MetricsBuild build(*this, 0);
  while (!build.step(now)) {
  }
  return build.take();
}

}  // namespace candp2::http
