// The status model behind candp2d's HTTP face (docs/daemon.md "HTTP face"): what GET
// /api/v1/status, GET /metrics and the page's Server-Sent Events show, built from the daemon's live
// objects.
//
// Read-only: it never changes a gateway, the master or a bus. It is built on the event loop's
// thread between two callbacks, so every value in one snapshot belongs to the same instant
// (between two master cycles). LED codes come from the Modbus status block (modbus::encode_status,
// manual table 3.3.1), so the page, Modbus and /metrics can never disagree.
#pragma once

#include <cstdint>
#include <deque>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "can/frame.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "gateway/gateway.hpp"
#include "modbus/modbus_map.hpp"
#include "modbus/modbus_server.hpp"
#include "plant/cycle_stats.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::drive {
class UnitekDrive;
}

namespace candp2::http {

// Bits a classic CAN data or remote frame occupies on the bus, stuff bits estimated by their upper
// bound (docs/daemon.md "Bus load"): gw::frame_bits(f) (SOF..EOF + 3 bit intermission) plus
// floor((n - 1) / 4) stuff bits, n = the stuffed part SOF..CRC = 34 + 8 * DLC (11-bit identifier)
// or 54 + 8 * DLC (29-bit); remote frames carry no data bytes.
std::uint32_t frame_bits_stuffed(const can::Frame& f);

// Every frame on one bus, counted and kept for the live trace. Fed by the daemon exactly once per
// frame (the bus's tap on virtual buses, the logging channel on SocketCAN/socketcand buses).
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
  const std::deque<Traced>& trace() const { return trace_; }

 private:
  std::uint64_t frames_ = 0;
  std::uint64_t bits_ = 0;
  std::deque<Traced> trace_;
};

struct GatewaySource {
  const config::GatewayConfig* cfg = nullptr;
  gw::Gateway* gateway = nullptr;
  modbus::GatewayFace* face = nullptr;  // the Modbus status block (LEDs, diagnosis, counters)
};
struct BusSource {
  const config::BusConfig* cfg = nullptr;
  const BusMonitor* monitor = nullptr;
  std::uint32_t bitrate = 0;  // bit/s: the first gateway's configured CAN bit rate on this bus
};
struct DriveSource {
  const config::DriveConfig* cfg = nullptr;
  const drive::UnitekDrive* drive = nullptr;
};
// The HTTP face's own counters (filled by HttpServer, shown in the status JSON and /metrics).
struct HttpCounters {
  std::uint64_t requests = 0;
  std::uint64_t sse_clients = 0;
  std::uint64_t snapshots = 0;          // SSE snapshots built (one per push for all clients)
  std::uint64_t snapshots_dropped = 0;  // replaced before a slow client started writing them
  std::uint64_t last_build_us = 0;      // time the last snapshot took to build and serialize
};

struct StatusSources {
  const dp::DpMaster* master = nullptr;
  std::uint32_t cycle_ms = 10;
  const plant::CycleStats* cycle = nullptr;
  const modbus::ModbusServer* modbus = nullptr;
  std::vector<GatewaySource> gateways;
  std::vector<BusSource> buses;
  std::vector<DriveSource> drives;
};

class StatusModel {
 public:
  explicit StatusModel(StatusSources sources);

  // GET /api/v1/status and every SSE push: the whole state as JSON (docs/daemon.md lists the
  // fields). `now` is the loop's CLOCK_MONOTONIC time; ages in the JSON are relative to it.
  nlohmann::json status(Time now);
  // GET /metrics: Prometheus text exposition format 0.0.4.
  std::string metrics(Time now);

  const StatusSources& sources() const { return src_; }
  // The server's counters live here so the model can show them.
  HttpCounters& http_counters() { return http_; }

 private:
  nlohmann::json gateway_json(std::size_t index, Time now) const;
  void update_load(Time now);

  StatusSources src_;
  HttpCounters http_;
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
