// The status model behind candp2d's HTTP face (docs/daemon.md "HTTP face"): what GET
// /api/v1/status, GET /metrics and the page's Server-Sent Events show, read from the plant through
// its accessors (the sources: http/plant_sources.hpp builds them) and its tap (the bus monitors).
//
// Read-only: it never changes a gateway, the master or a bus. Every function runs on the event
// loop's thread between two callbacks, so each piece it returns (one gateway, one slot row, the
// head of the status) belongs to one instant between two master cycles. The HTTP face builds a
// large status from such pieces over several loop turns (http/documents.hpp, http/live_view.hpp).
// A station's fields, LED codes included (manual table 3.3.1), come from its status
// (station::Status, gathered by plant/station_status.hpp) through the station table
// (station::kFields), the one every face reads, so the page, Modbus and /metrics can never
// disagree; values show as the status holds them (only Modbus saturates them to its registers). No
// other face is read.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "can/frame.hpp"
#include "can/timed_bus.hpp"
#include "common/host_stalls.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "plant/can_fault.hpp"
#include "plant/cycle_stats.hpp"
#include "plant/timed_line.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "station/status.hpp"

namespace candp2::plant {
class GatewayUnit;
class SlaveUnit;
class DriveUnit;
}  // namespace candp2::plant

namespace candp2::http {

// Bits a classic CAN data or remote frame occupies on the bus, stuff bits estimated by their upper
// bound (docs/daemon.md "Bus load"): can::frame_bits_worst(f).
std::uint32_t frame_bits_stuffed(const can::Frame& f);

// Every frame on one bus, counted and kept for the live trace. Fed exactly once per frame by the
// plant's tap (http::BusMonitors, http/plant_sources.hpp).
class BusMonitor {
 public:
  static constexpr std::size_t kTrace = 64;  // frames kept for the trace
  struct Traced {
    std::uint64_t seq;  // 1, 2, ... on this bus
    Time time;
    can::Frame frame;
  };
  void on_frame(const can::Frame& f, Time now);
  std::uint64_t frames() const { return frames_; }
  std::uint64_t bits() const { return bits_; }
  // The last kTrace frames (fewer at first), oldest first; built at each call.
  std::vector<Traced> trace() const;

 private:
  std::uint64_t frames_ = 0;
  std::uint64_t bits_ = 0;
  // A ring written at every frame: frame n (counted from 1) at (n − 1) % kTrace. No allocation
  // per frame, unlike a deque of kTrace that allocates and frees a block every few frames.
  std::array<Traced, kTrace> ring_{};
};

struct GatewaySource {
  const config::GatewayConfig* cfg = nullptr;
  const plant::GatewayUnit* unit = nullptr;
  // Its status now (LEDs, diagnosis, counters; plant/station_status.hpp).
  std::function<station::Status(Time)> status;
};
// A generic DP-V0 slave from its GSD (docs/slaves.md "Front panel and HTTP API").
struct SlaveSource {
  const config::SlaveConfig* cfg = nullptr;
  const plant::SlaveUnit* unit = nullptr;
  std::function<station::Status(Time)> status;               // plant/station_status.hpp
  std::function<std::vector<std::uint8_t>(Time)> diagnosis;  // the whole Slave_Diag answer
  bool line = false;  // on a profibus line in role slaves (else in-process)
};
struct BusSource {
  const config::BusConfig* cfg = nullptr;
  const BusMonitor* monitor = nullptr;
  std::uint32_t bitrate = 0;  // bit/s: the first gateway's configured CAN bit rate on this bus
  // A virtual bus with `bitrate` (docs/can-bus.md "The bus in time"); null otherwise.
  const can::TimedBus* timed = nullptr;
  // The CAN faults on cue in force on it at a time (Plant::can_faults; a bus in time only).
  std::function<std::vector<plant::CanFaultView>(Time)> faults;
};
struct DriveSource {
  const config::DriveConfig* cfg = nullptr;
  const plant::DriveUnit* unit = nullptr;
};
// The HTTP face's own counters (filled by HttpServer, shown in the status JSON and /metrics).
struct HttpCounters {
  std::uint64_t requests = 0;
  std::uint64_t connections = 0;        // open now
  std::uint64_t clients_accepted = 0;   // connections accepted since start
  std::uint64_t clients_evicted = 0;    // closed at max_clients for a new one
  std::uint64_t clients_timed_out = 0;  // closed after idle_timeout without a complete request
  std::uint64_t clients_refused = 0;    // not served (libmicrohttpd or the descriptor limit)
  std::uint64_t sse_clients = 0;
  std::uint64_t snapshots = 0;          // rounds published (the live view's pieces refreshed)
  std::uint64_t snapshots_dropped = 0;  // rounds a stream skipped because it was still writing
  std::uint64_t events = 0;             // SSE events written (full and changes)
  std::uint64_t event_bytes = 0;        // their bytes
  std::uint64_t last_build_us = 0;      // the last round: first piece to publication (wall time)
  std::uint64_t work_us_max = 0;        // the longest slice of snapshot work in one loop turn
};

// The Modbus face's figures, handed over by candp2d (the HTTP face reads no other face).
struct ModbusFigures {
  std::uint64_t requests = 0;    // answered normally
  std::uint64_t exceptions = 0;  // answered with an exception
  std::uint64_t clients = 0;     // connected now
  std::uint64_t clients_accepted = 0;
};

struct StatusSources {
  const dp::DpMaster* master = nullptr;
  std::uint32_t cycle_ms = 10;
  const plant::CycleStats* cycle = nullptr;
  // The line in time (docs/profibus.md "The line in time"); null on an ideal line, which then
  // shows no "line" (and no candp2_line_* metrics) at all.
  const plant::TimedLine* line = nullptr;
  // What an analyser counts on the line (docs/profibus.md "Line statistics"): the timed line's or
  // in role master the FDL master's; null otherwise.
  const fdl::LineStatistics* line_stats = nullptr;
  std::uint32_t line_baud = 0;              // of the line the statistics are counted on
  std::function<ModbusFigures()> modbus;    // empty: no Modbus face
  std::function<HostStalls()> host_stalls;  // empty: a world that never stalls (0)
  std::vector<GatewaySource> gateways;
  std::vector<SlaveSource> slaves;
  std::vector<BusSource> buses;
  std::vector<DriveSource> drives;
};

class StatusModel {
 public:
  explicit StatusModel(StatusSources sources);

  // GET /api/v1/status: the whole state as JSON in one piece (docs/daemon.md lists the fields).
  // `now` is the loop's CLOCK_MONOTONIC time; ages in the JSON are relative to it. The HTTP face
  // assembles the same document from the pieces below (status_head, gateway_head, slot_json,
  // slave_json).
  nlohmann::json status(Time now);
  // Everything of status() but "gateways"; `parts` false: without "buses" and "drives" too.
  nlohmann::json status_head(Time now, bool parts = true);
  // One gateway of status() without its "slots"; slot_count() rows go there (slot_json).
  nlohmann::json gateway_head(std::size_t gateway, Time now) const;
  std::size_t slot_count(std::size_t gateway) const;
  // Slot row k of a gateway. `age` true: "age_ms" relative to now (status); false: "last_ms", the
  // loop time of the slot's last frame, which changes only with a frame (the live view).
  nlohmann::json slot_json(std::size_t gateway, std::size_t k, Time now, bool age) const;
  // One generic slave of status() (http/slave_status.cpp): its GSD, DP and master state, the
  // whole diagnosis, its modules, the field side's bytes, the faults forced on it.
  nlohmann::json slave_json(std::size_t slave, Time now) const;

  // The live view's pieces (docs/daemon.md "Server-Sent Events"): a gateway's overview tile
  // (address, name, LEDs, DP state, fault, frames/s over the last second), the cycle, Modbus and
  // HTTP figures, a bus without or with its trace, a drive.
  nlohmann::json tile(std::size_t gateway, Time now);
  // A generic slave's tile: address, name, model, DP state, fault (no LEDs, no frames).
  nlohmann::json slave_tile(std::size_t slave, Time now) const;
  nlohmann::json cycle_json() const;
  // The line in time: baud rate, measured bus cycle (last, min, mean, max in µs), retries; null
  // on an ideal line (docs/daemon.md "HTTP face").
  nlohmann::json line_json() const;
  nlohmann::json modbus_json() const;
  nlohmann::json http_json() const;
  // {"count", "total_ms", "longest_ms"}: the host stalls (docs/daemon.md "Host stalls").
  nlohmann::json host_stalls_json() const;
  // With `identifiers` false, a bus in time's "identifiers" member is null (bus_text()).
  nlohmann::json bus_json(std::size_t bus, Time now, bool trace, bool identifiers = true);
  // bus_json(...).dump(), with a bus in time's identifiers written straight as text (the status
  // documents list each identifier of each bus: docs/can-bus.md "Performance").
  std::string bus_text(std::size_t bus, Time now, bool trace);
  static nlohmann::json timed_json(const can::TimedBus& t, Time now, bool identifiers = true);
  // A bus in time's "identifiers" array, as text (timed_json() gives its parse).
  static void put_identifiers(std::string& out, const can::TimedBus& t);
  static nlohmann::json faults_json(const std::vector<plant::CanFaultView>& faults);
  nlohmann::json trace_frame(const BusMonitor::Traced& t) const;
  nlohmann::json drive_json(std::size_t drive) const;
  // The bus a gateway is on (index into sources().buses), if it has a monitor there.
  std::optional<std::size_t> bus_of(std::size_t gateway) const;

  // GET /metrics: Prometheus text exposition format 0.0.4 (in one piece; the HTTP face builds it
  // in steps, http/documents.hpp).
  std::string metrics(Time now);
  // Bus load over the last window (fraction of the bit rate), after refresh_load().
  void refresh_load(Time now) { update_load(now); }
  double bus_load(std::size_t bus) const { return load_[bus].load; }

  const StatusSources& sources() const { return src_; }
  // The server's counters live here so the model can show them.
  HttpCounters& http_counters() { return http_; }

 private:
  void update_load(Time now);

  StatusSources src_;
  HttpCounters http_;
  // Frames/s of a gateway's tile over the last completed window of >= 1 s.
  struct Rate {
    Time start{0};
    std::uint32_t rx = 0, tx = 0;
    double rx_fps = 0, tx_fps = 0;
  };
  std::vector<Rate> rates_;
  // Bus load over the last completed window of >= 1 s: bits at the window's start.
  struct LoadWindow {
    Time start{0};
    std::uint64_t bits = 0;
    double load = 0;  // fraction of the bit rate
    double fps = 0;   // frames/s
    std::uint64_t frames = 0;
  };
  std::vector<LoadWindow> load_;
  std::vector<std::vector<dp::EntryAddress>> addresses_;  // per gateway: PLC addresses of entries
};

}  // namespace candp2::http
