#include "http/documents.hpp"

#include <algorithm>
#include <charconv>

namespace candp2::http {

namespace {

constexpr std::size_t kRowsPerStep = 8;       // status: slot rows per step
constexpr std::size_t kGatewaysPerStep = 16;  // metrics: status blocks read per step

// Appends an object's text without its closing brace, so members can follow.
void open_object(std::string& out, const std::string& object) {
  out.append(object, 0, object.empty() ? 0 : object.size() - 1);
}

void put(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}
void put(std::string& out, std::uint64_t v) {
  out += std::to_string(v);
}

}  // namespace

namespace {

// The per-gateway and per-slave families (docs/daemon.md "Metrics"; docs/slaves.md "Front panel
// and HTTP API"), one step each: the fields of the station table (station/status.hpp) with a
// metric of that kind, in the metric's rank order, read from the status blocks.
struct Family {
  const station::Field* field;
  const station::Metric* metric;
};

std::vector<Family> families(bool slaves) {
  std::vector<Family> out;
  for (const auto& f : station::fields()) {
    const auto& m = slaves ? f.slave_metric : f.gateway_metric;
    if (m.rank) out.push_back({&f, &m});
  }
  std::sort(out.begin(), out.end(),
            [](const Family& a, const Family& b) { return a.metric->rank < b.metric->rank; });
  return out;
}

const std::vector<Family>& gateway_families() {
  static const std::vector<Family> f = families(false);
  return f;
}

const std::vector<Family>& slave_families() {
  static const std::vector<Family> f = families(true);
  return f;
}

}  // namespace

// ------------------------------------------------------------------------ GET /api/v1/status

bool StatusBuild::step(Time now) {
  if (done_) return true;
  const std::size_t gateways = model_.sources().gateways.size();
  const std::size_t buses = model_.sources().buses.size();
  if (!started_) {
    started_ = true;
    open_object(out_, model_.status_head(now, false).dump());
    out_ += ",\"buses\":[";
  } else if (bus_ < buses) {
    if (bus_ > 0) out_ += ',';
    out_ += model_.bus_text(bus_++, now, true);
  } else if (!drives_) {
    drives_ = true;
    nlohmann::json drives = nlohmann::json::array();
    for (std::size_t i = 0; i < model_.sources().drives.size(); ++i)
      drives.push_back(model_.drive_json(i));
    out_ += "],\"drives\":" + drives.dump() + ",\"gateways\":[";
  } else if (slaves_open_) {
    if (slave_ > 0) out_ += ',';
    out_ += model_.slave_json(slave_++, now).dump();
  } else if (!in_gateway_) {
    if (gateway_ > 0) out_ += ',';
    open_object(out_, model_.gateway_head(gateway_, now).dump());
    out_ += ",\"slots\":[";
    rows_ = model_.slot_count(gateway_);
    row_ = 0;
    in_gateway_ = true;
  } else {
    for (std::size_t k = 0; k < kRowsPerStep && row_ < rows_; ++k, ++row_) {
      if (row_ > 0) out_ += ',';
      out_ += model_.slot_json(gateway_, row_, now, true).dump();
    }
  }
  if (in_gateway_ && row_ >= rows_) {
    out_ += "]}";
    in_gateway_ = false;
    ++gateway_;
  }
  if (drives_ && !in_gateway_ && gateway_ >= gateways && !slaves_open_) {
    out_ += "],\"slaves\":[";
    slaves_open_ = true;
  }
  if (slaves_open_ && slave_ >= model_.sources().slaves.size()) {
    out_ += "]}\n";
    done_ = true;
  }
  return done_;
}

// ---------------------------------------------------------------------------- GET /metrics

void MetricsBuild::family(std::string_view name, std::string_view type, std::string_view help) {
  out_ += "# HELP ";
  out_ += name;
  out_ += ' ';
  out_ += help;
  out_ += "\n# TYPE ";
  out_ += name;
  out_ += ' ';
  out_ += type;
  out_ += '\n';
}

void MetricsBuild::per_row(const station::Field& f, const station::Metric& m,
                           const std::vector<Row>& rows) {
  if (!m.type.empty()) family(m.name, m.type, m.help.empty() ? f.meaning : m.help);
  for (const auto& r : rows) {
    out_ += m.name;
    out_ += '{';
    out_ += r.labels;
    if (!m.reason.empty()) {
      out_ += ",reason=\"";
      out_ += m.reason;
      out_ += '"';
    }
    out_ += "} ";
    put(out_, f.get(r.status));
    out_ += '\n';
  }
}

// docs/can-bus.md "Seen from outside": only when a bus is timed (the families of a configuration
// without one are as before).
void MetricsBuild::timed_buses() {
  const auto& src = model_.sources();
  if (std::none_of(src.buses.begin(), src.buses.end(), [](const auto& b) { return b.timed; }))
    return;
  auto each = [&](auto&& row) {
    for (const auto& b : src.buses)
      if (b.timed) row(b.cfg->name, *b.timed);
  };
  auto line = [&](std::string_view name, const std::string& labels, auto v) {
    out_ += name;
    out_ += '{';
    out_ += labels;
    out_ += "} ";
    put(out_, v);
    out_ += '\n';
  };
  family("candp2_bus_timed_load_ratio", "gauge",
         "bus in time: bits frames occupied in the last complete second / bit rate (exact)");
  each([&](const std::string& bus, const can::TimedBus& t) {
    line("candp2_bus_timed_load_ratio", "bus=\"" + bus + "\"", t.load(now_).last_pct / 100.0);
  });
  family("candp2_bus_timed_load_max_ratio", "gauge",
         "bus in time: the most loaded complete second so far");
  each([&](const std::string& bus, const can::TimedBus& t) {
    line("candp2_bus_timed_load_max_ratio", "bus=\"" + bus + "\"", t.load(now_).max_pct / 100.0);
  });
  family("candp2_bus_tx_lost_total", "counter",
         "bus in time: frames lost past a node's full transmit queue");
  each([&](const std::string& bus, const can::TimedBus& t) {
    line("candp2_bus_tx_lost_total", "bus=\"" + bus + "\"", t.lost());
  });
  family("candp2_bus_error_frames_total", "counter",
         "bus in time: error frames (frames that ended in an error and were sent again)");
  each([&](const std::string& bus, const can::TimedBus& t) {
    line("candp2_bus_error_frames_total", "bus=\"" + bus + "\"", t.error_frames());
  });
  // docs/can-bus.md "Error confinement": each node's error counters.
  auto per_node = [&](std::string_view name, std::string_view help, auto value) {
    family(name, "gauge", help);
    each([&](const std::string& bus, const can::TimedBus& t) {
      for (std::size_t n = 0; n < t.nodes(); ++n)
        if (t.present(n))
          line(name, "bus=\"" + bus + "\",node=\"" + t.name(n) + "\"", value(t.confinement(n)));
    });
  };
  per_node("candp2_can_node_tec", "bus in time: the node's transmit error counter",
           [](const can::TimedBus::Confinement& c) { return std::uint64_t{c.tec}; });
  per_node("candp2_can_node_rec", "bus in time: the node's receive error counter",
           [](const can::TimedBus::Confinement& c) { return std::uint64_t{c.rec}; });
  auto per_id = [&](std::string_view name, std::string_view type, std::string_view help,
                    auto value) {
    family(name, type, help);
    std::vector<can::TimedBus::IdStatistics> list;  // by arbitration key, as the status
    each([&](const std::string& bus, const can::TimedBus& t) {
      t.identifiers(list);
      for (const auto& s : list) {
        std::string labels = "bus=\"" + bus + "\",id=\"" + std::to_string(s.id.id) + "\"";
        if (s.id.extended) labels += ",ext=\"1\"";
        if (s.remote) labels += ",rtr=\"1\"";
        line(name, labels, value(s));
      }
    });
  };
  auto seconds = [](Duration d) { return static_cast<double>(d.count()) / 1e6; };
  per_id("candp2_can_id_frames_total", "counter", "bus in time: frames of the identifier",
         [](const can::TimedBus::IdStatistics& s) { return s.frames; });
  per_id("candp2_can_id_latency_mean_seconds", "gauge",
         "bus in time: queueing latency of the identifier, send request to start of frame, mean",
         [&](const can::TimedBus::IdStatistics& s) { return seconds(s.latency_mean()); });
  per_id("candp2_can_id_latency_max_seconds", "gauge",
         "bus in time: queueing latency of the identifier, send request to start of frame, max",
         [&](const can::TimedBus::IdStatistics& s) { return seconds(s.latency_max); });
}

bool MetricsBuild::step(Time now) {
  now_ = now;
  if (done_) return true;
  started_ = true;
  const auto& gateways = model_.sources().gateways;
  if (rows_.size() < gateways.size()) {
    for (std::size_t n = 0; n < kGatewaysPerStep && rows_.size() < gateways.size(); ++n) {
      const auto& g = gateways[rows_.size()];
      const station::Status st = g.status(now);
      rows_.push_back({"gateway=\"" + std::to_string(st.dp_address) + "\",bus=\"" + g.cfg->bus +
                           "\",name=\"" + g.cfg->name + "\"",
                       st});
    }
    return false;
  }
  const auto& slaves = model_.sources().slaves;
  if (slave_rows_.size() < slaves.size()) {
    for (std::size_t n = 0; n < kGatewaysPerStep && slave_rows_.size() < slaves.size(); ++n) {
      const auto& sl = slaves[slave_rows_.size()];
      slave_rows_.push_back(
          {"address=\"" + std::to_string(sl.cfg->address) + "\",name=\"" + sl.cfg->name + "\"",
           sl.status(now)});
    }
    return false;
  }
  if (family_ < gateway_families().size()) {
    const auto& f = gateway_families()[family_++];
    per_row(*f.field, *f.metric, rows_);
    return false;
  }
  if (!slaves.empty() && slave_family_ < slave_families().size()) {
    const auto& f = slave_families()[slave_family_++];
    per_row(*f.field, *f.metric, slave_rows_);
    return false;
  }
  model_.refresh_load(now);
  tail();
  done_ = true;
  return true;
}

void MetricsBuild::tail() {
  const auto& src = model_.sources();
  family("candp2_bus_frames_total", "counter", "CAN frames seen on the bus");
  for (const auto& b : src.buses)
    if (b.monitor) {
      out_ += "candp2_bus_frames_total{bus=\"" + b.cfg->name + "\"} ";
      put(out_, b.monitor->frames());
      out_ += '\n';
    }
  family("candp2_bus_load_ratio", "gauge",
         "bus load over the last second: estimated bits (stuff bits worst case) / bit rate");
  for (std::size_t i = 0; i < src.buses.size(); ++i)
    if (src.buses[i].monitor) {
      out_ += "candp2_bus_load_ratio{bus=\"" + src.buses[i].cfg->name + "\"} ";
      put(out_, model_.bus_load(i));
      out_ += '\n';
    }
  timed_buses();
  auto one = [&](std::string_view name, std::string_view labels, std::uint64_t v) {
    out_ += name;
    if (!labels.empty()) {
      out_ += '{';
      out_ += labels;
      out_ += '}';
    }
    out_ += ' ';
    put(out_, v);
    out_ += '\n';
  };
  if (src.modbus) {
    const ModbusFigures m = src.modbus();
    family("candp2_modbus_requests_total", "counter",
           "Modbus/TCP requests answered (normal and exception answers)");
    one("candp2_modbus_requests_total", "result=\"ok\"", m.requests);
    one("candp2_modbus_requests_total", "result=\"exception\"", m.exceptions);
    family("candp2_modbus_clients", "gauge", "Modbus/TCP clients connected");
    one("candp2_modbus_clients", "", m.clients);
  }
  {  // docs/daemon.md "Host stalls"
    const HostStalls st = src.host_stalls ? src.host_stalls() : HostStalls{};
    auto sec = [](Duration d) { return static_cast<double>(d.count()) / 1e6; };
    family(
        "candp2_host_stalls_total", "counter",
        "host stalls: loop wakes later than master.host_stall_ms, kept from the simulated world");
    one("candp2_host_stalls_total", "", st.count);
    family("candp2_host_stall_seconds_total", "counter", "the host stalls' time in all");
    out_ += "candp2_host_stall_seconds_total ";
    put(out_, sec(st.total));
    out_ += '\n';
    family("candp2_host_stall_longest_seconds", "gauge", "the longest host stall");
    out_ += "candp2_host_stall_longest_seconds ";
    put(out_, sec(st.longest));
    out_ += '\n';
  }
  const auto& h = model_.http_counters();
  family("candp2_http_connections", "gauge", "HTTP connections open");
  one("candp2_http_connections", "", h.connections);
  family("candp2_http_connections_closed_total", "counter",
         "HTTP connections the daemon closed: evicted at http.max_clients for a new one, timed "
         "out after http.idle_timeout_s without a complete request");
  one("candp2_http_connections_closed_total", "reason=\"evicted\"", h.clients_evicted);
  one("candp2_http_connections_closed_total", "reason=\"idle\"", h.clients_timed_out);
  family("candp2_http_sse_clients", "gauge", "Server-Sent Events streams open");
  one("candp2_http_sse_clients", "", h.sse_clients);
  family("candp2_http_snapshots_dropped_total", "counter",
         "live-view rounds a stream skipped because it was still writing an earlier event");
  one("candp2_http_snapshots_dropped_total", "", h.snapshots_dropped);
  family("candp2_http_event_bytes_total", "counter", "bytes of Server-Sent Events written");
  one("candp2_http_event_bytes_total", "", h.event_bytes);
  if (src.line) {  // the line in time (docs/profibus.md "The line in time")
    // docs/daemon.md "Statistics of the steady line".
    const auto times = [&](const std::string& name, const char* help, const fdl::RotationTimes& c) {
      family(name, "gauge", help);
      for (const auto& [stat, d] :
           {std::pair{"last", c.last}, {"min", c.min}, {"mean", c.mean()}, {"max", c.max}}) {
        out_ += name;
        out_ += "{stat=\"";
        out_ += stat;
        out_ += "\"} ";
        put(out_, static_cast<double>(d.count()) / 1e6);
        out_ += '\n';
      }
    };
    times("candp2_line_bus_cycle_seconds",
          "the measured PROFIBUS bus cycle: the last, shortest, mean and longest token rotation "
          "that parameterized no station",
          src.line->bus_cycle());
    times("candp2_line_parameterization_cycle_seconds",
          "the last, shortest, mean and longest token rotation that parameterized a station "
          "(start-up, a station lost or parameterized again)",
          src.line->parameterization_cycle());
    family("candp2_line_retries_total", "counter", "requests the master repeated on the line");
    one("candp2_line_retries_total", "", src.line->retries());
  }
  if (src.line_stats) {  // docs/profibus.md "Line statistics": one family a counter of the table
    const fdl::LineStatistics& st = *src.line_stats;
    const auto stations = st.stations();
    std::string labels;
    for (const auto& f : fdl::kStationCounters) {
      const std::string name =
          "candp2_line_" + std::string(f.name) + (f.counter ? "_total" : std::string());
      family(name, f.counter ? "counter" : "gauge", f.meaning);
      for (const std::uint8_t a : stations) {
        labels = "station=\"" + std::to_string(a) + "\"";
        one(name, labels, st.station(a).*f.member);
      }
    }
    family("candp2_line_station_live", "gauge",
           "the live list: 0 none, 1 ok (configured, answering), 2 missing (configured, not "
           "answering), 3 phantom (answering, not configured)");
    for (const std::uint8_t a : stations) {
      labels = "station=\"" + std::to_string(a) + "\"";
      one("candp2_line_station_live", labels, static_cast<std::uint64_t>(st.live(a)));
    }
    family("candp2_line_illegals_unattributed_total", "counter",
           "illegal telegrams on the line no station could be blamed for (no answer was due)");
    one("candp2_line_illegals_unattributed_total", "", st.illegals_unattributed());
  }
  if (src.cycle) {
    const auto s = src.cycle->summary();
    family("candp2_master_cycles_total", "counter", "DP master cycles started");
    one("candp2_master_cycles_total", "", s.cycles);
    family("candp2_master_cycles_missed_total", "counter",
           "DP master cycles missed: grid points that passed without a cycle because the one "
           "before started more than a period late");
    one("candp2_master_cycles_missed_total", "", s.missed);
    family("candp2_master_cycle_lateness_seconds", "gauge",
           "how late the master cycle started against its grid point (overruns included), over "
           "the last cycles");
    for (const auto& [q, us] : {std::pair{"0.5", s.p50_us}, {"0.99", s.p99_us}, {"1", s.max_us}}) {
      out_ += "candp2_master_cycle_lateness_seconds{quantile=\"";
      out_ += q;
      out_ += "\"} ";
      put(out_, us / 1e6);
      out_ += '\n';
    }
  }
}

}  // namespace candp2::http
