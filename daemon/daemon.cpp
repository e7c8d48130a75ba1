#include "daemon/daemon.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "can/socketcan.hpp"
#include "can/socketcand.hpp"
#include "capture/can_log.hpp"
#include "daemon/bitrate_supervisor.hpp"
#include "daemon/profibus_line.hpp"
#include "daemon/profibus_master_line.hpp"
#include "drive_sim/file_parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "http/http_server.hpp"
#include "http/http_status.hpp"
#include "modbus/modbus_map.hpp"
#include "modbus/modbus_server.hpp"
#include "plant/cycle_stats.hpp"

namespace candp2::daemon {

namespace {

using capture::CanLog;
using config::BusType;
using faults::CanFaultLayer;
using faults::FaultyDrive;
using faults::kForceReal;
using http::BusMonitor;
using http::BusSource;
using http::HttpServer;
using http::StatusModel;
using http::StatusSources;
using plant::CycleStats;

// ------------------------------------------------------------------------------ state file
// Stored wake-up and SYNC values per DP address (emulator-spec §1.1: they survive restarts of the
// daemon when a state file is configured): {"gateways": {"5": {"wakeup_s": 0, "sync_ms": 100}}}.

struct Stored {
  std::uint8_t wakeup_s = 0;
  std::uint16_t sync_ms = 0;
  friend bool operator==(const Stored&, const Stored&) = default;
};

std::map<std::uint8_t, Stored> load_state(const std::string& path, const Logger& log) {
  std::map<std::uint8_t, Stored> out;
  std::ifstream in(path);
  if (!in) return out;  // nothing stored yet
  try {
    const auto j = nlohmann::json::parse(in);
    for (const auto& [key, v] : j.at("gateways").items()) {
      const int address = std::stoi(key);
      if (address < 0 || address > 255) continue;
      Stored s;
      s.wakeup_s = static_cast<std::uint8_t>(std::min(v.at("wakeup_s").get<unsigned>(), 254u));
      s.sync_ms = static_cast<std::uint16_t>(std::min(v.at("sync_ms").get<unsigned>(), 65534u));
      out[static_cast<std::uint8_t>(address)] = s;
    }
  } catch (const std::exception& e) {
    log.error("state file " + path + " unreadable, using the configured values: " + e.what());
    out.clear();
  }
  return out;
}

bool save_state(const std::string& path, const std::map<std::uint8_t, Stored>& state,
                std::string* error) {
  nlohmann::json j;
  j["gateways"] = nlohmann::json::object();
  for (const auto& [address, s] : state)
    j["gateways"][std::to_string(address)] = {{"wakeup_s", s.wakeup_s}, {"sync_ms", s.sync_ms}};
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << j.dump(2) << "\n";
    if (!out) {
      *error = "cannot write " + tmp;
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);  // atomic: a crash never leaves half a file
  if (ec) {
    *error = "cannot rename " + tmp + " to " + path + ": " + ec.message();
    return false;
  }
  return true;
}

// ----------------------------------------------------------------------------------- parts

class DaemonImpl;

struct Bus {
  config::BusConfig cfg;
  std::unique_ptr<can::VirtualBus> vbus;
  std::unique_ptr<can::VirtualEndpoint> export_endpoint;
  std::unique_ptr<can::SocketcandServer> export_server;
  BusMonitor monitor;                   // every frame once: counts, bus load, trace (HTTP face)
  EventLoop::TimerId export_timer = 0;  // the export's idle timeouts
  std::optional<Time> export_armed;
};

// One emulated gateway: its CAN channel, the gateway engine and its Modbus face.
struct GatewayUnit final : modbus::GatewayFace, can::FrameSink {
  DaemonImpl* daemon = nullptr;
  config::GatewayConfig cfg;
  Bus* bus = nullptr;
  std::unique_ptr<can::Channel> channel;
  can::VirtualEndpoint* endpoint = nullptr;  // == channel on virtual buses
  bool logs_bus = false;                     // writes the CAN log for its (non-virtual) bus
  std::unique_ptr<gw::Gateway> gateway;
  EventLoop::TimerId timer = 0;
  std::optional<Time> armed;
  BitrateSupervisor* link = nullptr;  // SocketCAN: the interface's bit rate (docs/transports.md)
  std::size_t link_index = 0;
  CanFaultLayer faults;               // between gateway and channel (docs/faults.md)
  EventLoop::TimerId link_timer = 0;  // socketcand client reconnection
  std::optional<Time> link_armed;

  void send(const can::Frame& frame) override;  // the gateway transmits
  std::uint8_t dp_address() const override { return gateway->address(); }
  modbus::StatusBlock status(Time now) override;
  void control(modbus::Control command, Time now) override;
  bool force_bus_state(std::uint16_t code, Time now) override;
  std::uint16_t forced_bus_state() const override { return faults.forced_code(); }
  void drop_received(std::uint16_t n, Time now) override;
  std::uint16_t drop_remaining() const override {
    return static_cast<std::uint16_t>(std::min<std::uint32_t>(faults.drop_remaining(), 0xFFFF));
  }
  // Gives the gateway the controller state and IRQ_LOST total through the fault layer.
  void update_controller() {
    gateway->set_controller_status(faults.state(channel->bus_state()),
                                   faults.rx_lost(channel->rx_lost()));
  }
  // A received frame through the fault layer.
  void receive(const can::Frame& frame, Time now) {
    if (faults.pass_rx()) gateway->on_can_frame(frame, now);
  }
  std::uint32_t reconnects() const;
};

struct DriveUnit final : modbus::DriveFace {
  config::DriveConfig cfg;
  std::unique_ptr<can::VirtualEndpoint> endpoint;
  std::unique_ptr<drive::FileParameterStore> store;
  // The drive with its fault injection (docs/faults.md), shared with the replay runner.
  std::unique_ptr<FaultyDrive> drive;
  EventLoop::TimerId timer = 0;
  std::optional<Time> armed;

  std::uint8_t modbus_unit() const override { return cfg.modbus_unit.value_or(0); }
  std::uint16_t fault_register(std::uint16_t index) const override {
    return drive->fault_register(index);
  }
  void set_fault_register(std::uint16_t index, std::uint16_t value, Time now) override {
    drive->set_fault_register(index, value, now, *endpoint, "requested over Modbus");
  }
};

class DaemonImpl final : public Daemon {
 public:
  DaemonImpl(const config::DaemonConfig& config, EventLoop& loop, LogSink* log)
      : config_(config), loop_(loop), log_sink_(log), log_(log, "daemon") {}

  ~DaemonImpl() override {
    // Unregister everything from the loop before the parts go away.
    http_.reset();
    if (deferred_) loop_.remove_deferred(deferred_);
    if (cycle_timer_) loop_.cancel_timer(cycle_timer_);
    for (auto& g : gateways_) {
      if (g->timer) loop_.cancel_timer(g->timer);
      if (g->link_timer) loop_.cancel_timer(g->link_timer);
    }
    for (auto& d : drives_)
      if (d->timer) loop_.cancel_timer(d->timer);
    for (auto& b : buses_)
      if (b->export_timer) loop_.cancel_timer(b->export_timer);
    for (int fd : watched_) loop_.remove_fd(fd);
    modbus_.reset();
  }

  bool start(std::string* error);

  std::uint16_t modbus_port() const override { return modbus_ ? modbus_->port() : 0; }
  std::optional<std::uint16_t> http_port() const override {
    return http_ ? std::optional<std::uint16_t>(http_->port()) : std::nullopt;
  }
  std::size_t modbus_clients() const override { return modbus_ ? modbus_->client_count() : 0; }
  std::optional<std::uint16_t> socketcand_port(std::string_view name) const override {
    for (const auto& b : buses_)
      if (b->cfg.name == name && b->export_server) return b->export_server->port();
    return std::nullopt;
  }
  std::string listening() const override;
  void reopen_can_log() override;
  void shutdown() override;
  dp::DpMaster& master() override { return *master_; }
  gw::Gateway* gateway(std::uint8_t dp_address) override {
    for (auto& g : gateways_)
      if (g->gateway->address() == dp_address) return g->gateway.get();
    return nullptr;
  }
  can::VirtualBus* virtual_bus(std::string_view name) override {
    for (auto& b : buses_)
      if (b->cfg.name == name) return b->vbus.get();
    return nullptr;
  }

  // Used by the units.
  void log_frame(const can::Frame& f, Bus& bus) {
    bus.monitor.on_frame(f, loop_.now());
    if (can_log_.is_open()) can_log_.write(f, EventLoop::wall_now(), bus.cfg.name);
  }
  dp::DpMaster& dp_master() { return *master_; }
  // emulator-spec §10: role slaves (an external master drives the gateways over FDL).
  bool external_master() const { return line_ != nullptr; }
  std::optional<modbus::StatusInputs::Line> line_status(std::uint8_t address) const {
    return line_ ? line_->status(address) : std::nullopt;
  }
  Time now() const { return loop_.now(); }
  const Logger& logger() const { return log_; }

 private:
  bool open_bus(Bus& b, std::string* error);
  bool open_gateway(GatewayUnit& g, std::string* error);
  bool open_drive(DriveUnit& d, std::string* error);
  bool watch(int fd, std::function<void()> on_readable, std::string* error);
  void drain_channel(GatewayUnit& g);
  bool drain_in_process();  // the deferred hook
  void rearm(GatewayUnit& g);
  void rearm(DriveUnit& d);
  void rearm_export(Bus& b);
  void rearm_link(GatewayUnit& g);
  void check_stored();
  void update_links();
  bool start_http(std::string* error);
  bool start_remote(std::string* error);  // profibus role master

  config::DaemonConfig config_;
  EventLoop& loop_;
  LogSink* log_sink_;
  Logger log_;
  std::vector<std::unique_ptr<Bus>> buses_;
  std::vector<std::unique_ptr<GatewayUnit>> gateways_;
  std::vector<std::unique_ptr<DriveUnit>> drives_;
  std::map<std::string, std::unique_ptr<BitrateSupervisor>> links_;  // by SocketCAN interface
  std::unique_ptr<dp::DpMaster> master_;
  std::unique_ptr<modbus::ProcessImageMap> map_;
  std::unique_ptr<modbus::ModbusServer> modbus_;
  CanLog can_log_;
  std::map<std::uint8_t, Stored> stored_;
  std::vector<int> watched_;
  EventLoop::DeferredId deferred_ = 0;
  EventLoop::TimerId cycle_timer_ = 0;
  CycleStats cycle_stats_;
  std::unique_ptr<ProfibusSlaveLine> line_;                  // profibus role slaves
  std::unique_ptr<ProfibusMasterLine> master_line_;          // profibus role master
  std::vector<std::unique_ptr<RemoteStationFace>> remotes_;  // role master: the remote stations
  std::unique_ptr<StatusModel> status_model_;                // declared last: destroyed first
  std::unique_ptr<HttpServer> http_;
};

void GatewayUnit::send(const can::Frame& frame) {
  // Virtual buses log every frame through their tap. On SocketCAN and socketcand buses the first
  // gateway's channel logs what it sends and receives: it receives what the other gateways on
  // that bus send (separate sockets/connections), so every frame is logged once.
  if (!faults.pass_tx()) return;  // forced bus-off: dropped, counted (docs/faults.md)
  if (logs_bus) daemon->log_frame(frame, *bus);
  channel->send(frame);
}

std::uint32_t GatewayUnit::reconnects() const {
  if (const auto* c = dynamic_cast<const can::SocketcandClientChannel*>(channel.get()))
    return c->reconnects();
  return 0;
}

bool GatewayUnit::force_bus_state(std::uint16_t code, Time) {
  if (!faults.force(code)) return false;
  daemon->logger().warn(cfg.name + ": CAN controller state " +
                        (code == kForceReal
                             ? std::string("no longer forced (real state)")
                             : "forced to " + std::string(can::to_string(*faults.forced()))) +
                        " over Modbus");
  update_controller();
  return true;
}

void GatewayUnit::drop_received(std::uint16_t n, Time) {
  faults.drop_next(n);
  daemon->logger().warn(cfg.name + ": the next " + std::to_string(n) +
                        " received frame(s) will be dropped (IRQ_LOST)");
}

modbus::StatusBlock GatewayUnit::status(Time now) {
  modbus::StatusInputs in;
  in.gateway = gateway->status();
  in.diag = gateway->dp().slave_diag(now);
  in.dp_address = gateway->address();
  if (link) in.bitrate = link->status(link_index);
  if (const auto view = daemon->dp_master().slave(gateway->address())) {
    in.master_state = view->state;
    in.parameterizations = view->parameterizations;
    in.addressed = view->addressed;
  }
  in.line = daemon->line_status(gateway->address());
  in.forced_state = faults.forced_code();
  in.tx_suppressed = faults.tx_suppressed();
  in.rx_suppressed = faults.rx_suppressed();
  in.rx_drop_remaining = faults.drop_remaining();
  in.reconnects = reconnects();
  return modbus::encode_status(in);
}

void GatewayUnit::control(modbus::Control command, Time now) {
  switch (command) {
    case modbus::Control::None:
      return;
    case modbus::Control::PowerCycle:
      // The master notices the missing Data_Exchange answer and parameterizes again after its
      // retry delay, as a real master would.
      daemon->logger().info(cfg.name + ": power cycle requested over Modbus");
      gateway->power_cycle(now);
      return;
    case modbus::Control::Reparameterize:
      if (daemon->external_master()) {
        // emulator-spec §10 role slaves: the external master parameterizes; it cannot be forced.
        daemon->logger().warn(cfg.name +
                              ": re-parameterization requested over Modbus ignored: an external "
                              "PROFIBUS master drives this gateway (write 1 to power-cycle it)");
        return;
      }
      daemon->logger().info(cfg.name + ": re-parameterization requested over Modbus");
      daemon->dp_master().reparameterize(gateway->address(), now);
      return;
    case modbus::Control::MasterStops:
      daemon->logger().warn(cfg.name + ": the master stops addressing it (requested over Modbus)");
      daemon->dp_master().set_addressed(gateway->address(), false, now);
      return;
    case modbus::Control::MasterResumes:
      daemon->logger().info(cfg.name + ": the master addresses it again (requested over Modbus)");
      daemon->dp_master().set_addressed(gateway->address(), true, now);
      return;
  }
}

bool DaemonImpl::watch(int fd, std::function<void()> on_readable, std::string* error) {
  if (!loop_.add_fd(
          fd, EventLoop::kReadable, [cb = std::move(on_readable)](std::uint32_t) { cb(); }, error))
    return false;
  watched_.push_back(fd);
  return true;
}

bool DaemonImpl::open_bus(Bus& b, std::string* error) {
  if (b.cfg.type != BusType::Virtual) return true;  // channels are opened per gateway
  b.vbus = std::make_unique<can::VirtualBus>();
  if (b.cfg.socketcand_listen) {
    b.export_endpoint = b.vbus->endpoint("socketcand:" + b.cfg.channel);
    can::SocketcandServer::Options o;
    o.host = b.cfg.socketcand_listen->host;
    o.port = b.cfg.socketcand_listen->port;
    o.channel = b.cfg.channel;
    o.max_clients = b.cfg.socketcand_max_clients;
    o.idle_timeout = seconds(b.cfg.socketcand_idle_timeout_s);
    std::string e;
    b.export_server = can::SocketcandServer::listen(o, *b.export_endpoint, log_sink_, &e);
    if (!b.export_server) {
      *error = "bus \"" + b.cfg.name + "\" (" + b.cfg.json_path + ".socketcand): " + e;
      return false;
    }
    can::SocketcandServer* server = b.export_server.get();
    Bus* bp = &b;
    for (int fd : server->poll_fds())
      if (!watch(
              fd,
              [this, bp, server, fd] {
                server->on_readable(fd, EventLoop::wall_now());
                rearm_export(*bp);
              },
              error))
        return false;
    log_.info("bus " + b.cfg.name + ": socketcand export on " + b.cfg.socketcand_listen->host +
              ":" + std::to_string(server->port()) + ", bus name \"" + b.cfg.channel + "\"");
  }
  // Every frame on the bus: to the CAN log and to the socketcand clients. Frames the clients sent
  // were already forwarded to the other clients by the server (socketcand.hpp).
  Bus* bus = &b;
  b.vbus->add_tap([this, bus](const can::Frame& f, Time, std::string_view sender) {
    log_frame(f, *bus);
    if (bus->export_server && sender != bus->export_endpoint->name())
      bus->export_server->publish(f, EventLoop::wall_now());
  });
  return true;
}

bool DaemonImpl::open_gateway(GatewayUnit& g, std::string* error) {
  const auto& b = g.bus->cfg;
  std::string e;
  const std::string where =
      "gateway \"" + g.cfg.name + "\" on bus \"" + b.name + "\" (" + b.json_path + "): ";
  switch (b.type) {
    case BusType::Virtual: {
      auto ep = g.bus->vbus->endpoint("gw:" + g.cfg.name);
      g.endpoint = ep.get();
      g.channel = std::move(ep);
      break;
    }
    case BusType::SocketCan:
      // One raw socket per gateway: gateways on one interface see each other's frames, as
      // separate devices on a bus do. A down interface is no start error: bus-off until it is up
      // (docs/transports.md "Down interfaces").
      g.channel = can::open_socketcan(b.interface, &e,
                                      {.receive_own = false, .log = log_sink_, .allow_down = true});
      if (!g.channel) {
        *error = where + "cannot open SocketCAN interface " + b.interface + ": " + e;
        return false;
      }
      if (auto& link = links_[b.interface]; !link)
        link = std::make_unique<BitrateSupervisor>(b.interface, b.bitrate, b.restart_ms,
                                                   netlink_ops(b.interface), log_sink_);
      g.link = links_[b.interface].get();
      g.link_index = g.link->add_gateway(g.cfg.name);
      break;
    case BusType::Socketcand:
      g.channel =
          can::connect_socketcand(b.remote.host, b.remote.port, b.channel, &e, 3000, log_sink_);
      if (!g.channel) {
        *error = where + e;
        return false;
      }
      break;
  }
  if (g.channel->poll_fd() >= 0 &&
      !watch(
          g.channel->poll_fd(), [this, unit = &g] { drain_channel(*unit); }, error))
    return false;
  gw::GatewayOptions o;
  o.address = g.cfg.address;
  o.cia301_bootup = g.cfg.cia301_bootup;
  o.stored_wakeup_s = g.cfg.stored_wakeup_s;
  o.stored_sync_ms = g.cfg.stored_sync_ms;
  if (const auto it = stored_.find(g.cfg.dp_address()); it != stored_.end()) {
    o.stored_wakeup_s = it->second.wakeup_s;
    o.stored_sync_ms = it->second.sync_ms;
  }
  o.log = log_sink_;
  g.gateway = std::make_unique<gw::Gateway>(o, g, loop_.now());
  if (!config_.profibus) master_->add_slave(g.gateway->dp(), config::slave_parameters(g.cfg));
  log_.info("gateway " + g.cfg.name + ": DP address " + std::to_string(g.gateway->address()) +
            ", " + std::to_string(g.cfg.slots.size()) + " slots, bus " + b.name + " (" +
            std::string(config::to_string(b.type)) + ")");
  return true;
}

bool DaemonImpl::open_drive(DriveUnit& d, std::string* error) {
  Bus* bus = nullptr;
  for (auto& b : buses_)
    if (b->cfg.name == d.cfg.bus) bus = b.get();
  if (!bus || !bus->vbus) {
    *error = "drive \"" + d.cfg.name + "\": bus \"" + d.cfg.bus + "\" is not a virtual bus";
    return false;
  }
  d.endpoint = bus->vbus->endpoint("drive:" + d.cfg.name);
  if (d.cfg.state_file) d.store = std::make_unique<drive::FileParameterStore>(*d.cfg.state_file);
  drive::UnitekDrive::Options o;
  o.rx_id = d.cfg.rx_id;
  o.tx_id = d.cfg.tx_id;
  o.name = d.cfg.name;
  try {
    d.drive = std::make_unique<FaultyDrive>(o, log_sink_, d.store.get());
  } catch (const std::exception& e) {
    *error = "drive \"" + d.cfg.name + "\" (" + d.cfg.json_path + "): " + e.what();
    return false;
  }
  char ids[64];
  std::snprintf(ids, sizeof ids, "Rx ID 0x%03X, Tx ID 0x%03X", static_cast<unsigned>(d.cfg.rx_id),
                static_cast<unsigned>(d.cfg.tx_id));
  log_.info("drive " + d.cfg.name + ": Unitek on bus " + d.cfg.bus + ", " + ids);
  return true;
}

bool DaemonImpl::start(std::string* error) {
  if (config_.state_file) stored_ = load_state(*config_.state_file, log_);
  if (config_.can_log && !can_log_.open(*config_.can_log, error)) return false;

  for (const auto& bc : config_.buses) {
    auto b = std::make_unique<Bus>();
    b->cfg = bc;
    if (!open_bus(*b, error)) return false;
    buses_.push_back(std::move(b));
  }
  master_ = std::make_unique<dp::DpMaster>(
      dp::MasterOptions{.address = config_.master_address,
                        .retry_delay = milliseconds(config_.retry_ms)},
      log_sink_);
  // emulator-spec §10 role master: the gateways are remote stations on the line; nothing local.
  if (config_.remote_gateways() && !start_remote(error)) return false;
  for (const auto& gc : config_.gateways) {
    if (config_.remote_gateways()) break;
    auto g = std::make_unique<GatewayUnit>();
    g->daemon = this;
    g->cfg = gc;
    for (auto& b : buses_)
      if (b->cfg.name == gc.bus) g->bus = b.get();
    if (!g->bus) {
      *error = "gateway \"" + gc.name + "\": unknown bus \"" + gc.bus + "\"";
      return false;
    }
    g->logs_bus = g->bus->cfg.type != BusType::Virtual &&
                  std::none_of(gateways_.begin(), gateways_.end(),
                               [&](const auto& other) { return other->bus == g->bus; });
    if (!open_gateway(*g, error)) return false;
    gateways_.push_back(std::move(g));
  }
  for (const auto& dc : config_.drives) {
    auto d = std::make_unique<DriveUnit>();
    d->cfg = dc;
    if (!open_drive(*d, error)) return false;
    drives_.push_back(std::move(d));
  }
  check_stored();

  if (config_.profibus && !config_.remote_gateways()) {
    // emulator-spec §10 role slaves: the gateways answer FDL on the line; the built-in master
    // does not run.
    line_ = ProfibusSlaveLine::open(*config_.profibus, loop_, master_->image(), log_sink_, error);
    if (!line_) return false;
    for (auto& g : gateways_)
      line_->add(g->gateway->dp(), config::slave_parameters(g->cfg), g->cfg.name);
    log_.info("PROFIBUS line " + line_->describe() + ": " + std::to_string(gateways_.size()) +
              " gateway(s) answer an external master");
  }

  std::vector<modbus::GatewayFace*> faces;
  for (auto& g : gateways_) faces.push_back(g.get());
  for (auto& r : remotes_) faces.push_back(r.get());
  std::vector<modbus::DriveFace*> drive_faces;
  for (auto& d : drives_)
    if (d->cfg.modbus_unit) drive_faces.push_back(d.get());
  map_ = std::make_unique<modbus::ProcessImageMap>(master_->image(), std::move(faces),
                                                   std::move(drive_faces));
  map_->set_outputs_read_only(line_ != nullptr);
  std::string e;
  modbus_ = modbus::ModbusServer::listen({.host = config_.modbus_listen.host,
                                          .port = config_.modbus_listen.port,
                                          .max_clients = config_.modbus_max_clients,
                                          .idle_timeout = seconds(config_.modbus_idle_timeout_s)},
                                         loop_, *map_, log_sink_, &e);
  if (!modbus_) {
    *error = "Modbus/TCP ($.modbus.listen): " + e;
    return false;
  }

  if (config_.http_listen && !start_http(error)) return false;

  deferred_ = loop_.add_deferred([this] { return drain_in_process(); });
  cycle_stats_.start(loop_.now() + milliseconds(config_.cycle_ms), milliseconds(config_.cycle_ms));
  if (line_) {
    // Role slaves: an external master cycles the gateways; no built-in master cycle runs.
    cycle_timer_ = loop_.add_periodic(milliseconds(config_.cycle_ms), [this] {
      update_links();
      if (http_) http_->after_cycle(loop_.now());
      check_stored();
    });
    return true;
  }
  cycle_timer_ = loop_.add_periodic(milliseconds(config_.cycle_ms), [this] {
    cycle_stats_.record(loop_.now());
    master_->cycle(loop_.now());
    if (master_line_) {
      master_line_->rearm();
      master_line_->check_presence(*master_);
    }
    update_links();
    if (http_) http_->after_cycle(loop_.now());
    check_stored();
  });
  log_.info("master " + std::to_string(config_.master_address) + ": cycle " +
            std::to_string(config_.cycle_ms) + " ms, " + std::to_string(gateways_.size()) +
            " gateway(s)");
  return true;
}

bool DaemonImpl::start_remote(std::string* error) {
  master_line_ =
      ProfibusMasterLine::open(*config_.profibus, config_.master_address, loop_, log_sink_, error);
  if (!master_line_) return false;
  for (const auto& gc : config_.gateways) {
    master_->add_slave(master_line_->station(gc.dp_address()), config::slave_parameters(gc));
    remotes_.push_back(std::make_unique<RemoteStationFace>(gc.dp_address(), gc.name, *master_,
                                                           *master_line_, log_sink_));
  }
  log_.info("PROFIBUS line " + master_line_->describe() + ": master " +
            std::to_string(config_.master_address) + " drives " + std::to_string(remotes_.size()) +
            " remote station(s)");
  return true;
}

bool DaemonImpl::start_http(std::string* error) {
  const auto& at = *config_.http_listen;
  if (at.host.rfind("127.", 0) != 0)
    log_.warn("http.listen " + at.to_string() +
              ": not a loopback address; the status page and API are readable from the network");
  StatusSources src;
  src.master = master_.get();
  src.cycle_ms = config_.cycle_ms;
  src.cycle = &cycle_stats_;
  src.modbus = modbus_.get();
  for (auto& g : gateways_) src.gateways.push_back({&g->cfg, g->gateway.get(), g.get()});
  for (auto& b : buses_) {
    BusSource bs{&b->cfg, &b->monitor, 0};
    for (auto& g : gateways_)  // manual table 5.1.1: the bit rate the gateway is set to
      if (g->bus == b.get() && !bs.bitrate &&
          g->cfg.parameters.bitrate_index < gw::kBitrates.size())
        bs.bitrate = gw::kBitrates[g->cfg.parameters.bitrate_index];
    src.buses.push_back(bs);
  }
  for (auto& d : drives_) src.drives.push_back({&d->cfg, &d->drive->drive()});
  status_model_ = std::make_unique<StatusModel>(std::move(src));
  std::string e;
  http_ = HttpServer::listen(
      {.host = at.host, .port = at.port, .status_after_cycle = config_.cycle_ms <= 100}, loop_,
      *status_model_, log_sink_, &e);
  if (!http_) {
    *error = "HTTP ($.http.listen): " + e;
    return false;
  }
  return true;
}

void DaemonImpl::drain_channel(GatewayUnit& g) {
  const Time now = loop_.now();
  while (auto f = g.channel->receive()) {
    if (g.logs_bus) log_frame(*f, *g.bus);
    g.receive(*f, now);
  }
  g.update_controller();
  rearm_link(g);
}

bool DaemonImpl::drain_in_process() {
  bool work = false;
  const Time now = loop_.now();
  for (auto& g : gateways_) {
    if (g->endpoint) {
      while (auto f = g->endpoint->receive()) {
        g->receive(*f, now);
        work = true;
      }
      g->update_controller();
    }
  }
  for (auto& d : drives_) {
    while (auto f = d->endpoint->receive()) {
      d->drive->on_frame(*f, now, *d->endpoint);  // muted: stops answering
      work = true;
    }
  }
  // The export endpoint only sends (frames for clients come through the tap): discard its queue.
  for (auto& b : buses_)
    if (b->export_endpoint)
      while (b->export_endpoint->receive()) {
      }
  for (auto& g : gateways_) rearm(*g);
  for (auto& d : drives_) rearm(*d);
  return work;
}

void DaemonImpl::rearm(GatewayUnit& g) {
  const auto next = g.gateway->next_deadline();
  if (next == g.armed && (g.timer || !next)) return;
  if (g.timer) loop_.cancel_timer(g.timer);
  g.timer = 0;
  g.armed = next;
  if (!next) return;
  g.timer = loop_.add_timer(*next - loop_.now(), [this, unit = &g] {
    unit->timer = 0;
    unit->armed.reset();
    unit->gateway->advance(loop_.now());
  });
}

void DaemonImpl::rearm(DriveUnit& d) {
  const auto next = d.drive->next_deadline();
  if (next == d.armed && (d.timer || !next)) return;
  if (d.timer) loop_.cancel_timer(d.timer);
  d.timer = 0;
  d.armed = next;
  if (!next) return;
  d.timer = loop_.add_timer(*next - loop_.now(), [this, unit = &d] {
    unit->timer = 0;
    unit->armed.reset();
    unit->drive->advance(loop_.now(), *unit->endpoint);
  });
}

void DaemonImpl::update_links() {
  const Time now = loop_.now();
  for (auto& g : gateways_) {
    if (!g->link) continue;
    const auto& prm = g->gateway->user_prm();  // the accepted Set_Prm (emulator-spec §1.1 byte 8)
    g->link->update(
        g->link_index,
        prm ? std::optional<std::uint32_t>(gw::kBitrates.at(prm->bitrate_index)) : std::nullopt,
        now);
  }
}

// A socketcand client channel's reconnection timer (can/socketcand_client.hpp).
void DaemonImpl::rearm_link(GatewayUnit& g) {
  auto* link = dynamic_cast<can::SocketcandClientChannel*>(g.channel.get());
  if (!link) return;
  const auto next = link->next_deadline();
  if (next == g.link_armed && (g.link_timer || !next)) return;
  if (g.link_timer) loop_.cancel_timer(g.link_timer);
  g.link_timer = 0;
  g.link_armed = next;
  if (!next) return;
  g.link_timer =
      loop_.add_timer(std::max(Duration(0), *next - loop_.now()), [this, link, unit = &g] {
        unit->link_timer = 0;
        unit->link_armed.reset();
        link->advance(loop_.now());
        drain_channel(*unit);  // shows the state and rearms
      });
}

// The socketcand export's idle timeouts run on the wall clock its on_readable() is given.
void DaemonImpl::rearm_export(Bus& b) {
  const auto next = b.export_server->next_deadline();
  if (next == b.export_armed && (b.export_timer || !next)) return;
  if (b.export_timer) loop_.cancel_timer(b.export_timer);
  b.export_timer = 0;
  b.export_armed = next;
  if (!next) return;
  b.export_timer =
      loop_.add_timer(std::max(Duration(0), *next - EventLoop::wall_now()), [this, bus = &b] {
        bus->export_timer = 0;
        bus->export_armed.reset();
        bus->export_server->advance(EventLoop::wall_now());
        rearm_export(*bus);
      });
}

void DaemonImpl::check_stored() {
  if (!config_.state_file) return;
  bool changed = false;
  for (const auto& g : gateways_) {
    const Stored now{g->gateway->stored_wakeup_s(), g->gateway->stored_sync_ms()};
    auto [it, inserted] = stored_.try_emplace(g->gateway->address(), now);
    if (inserted || it->second != now) {
      it->second = now;
      changed = true;
    }
  }
  if (!changed) return;
  std::string error;
  if (!save_state(*config_.state_file, stored_, &error)) log_.error("state file: " + error);
}

std::string DaemonImpl::listening() const {
  std::string out = "modbus " + config_.modbus_listen.host + ":" + std::to_string(modbus_port());
  if (http_) out += ", http " + config_.http_listen->host + ":" + std::to_string(http_->port());
  for (const auto& b : buses_)
    if (b->export_server)
      out += ", bus " + b->cfg.name + " socketcand " + b->cfg.socketcand_listen->host + ":" +
             std::to_string(b->export_server->port());
  if (line_) out += ", profibus " + line_->describe();
  if (master_line_) out += ", profibus " + master_line_->describe();
  return out;
}

void DaemonImpl::reopen_can_log() {
  if (!config_.can_log) {
    log_.info("SIGHUP: no CAN log configured");
    return;
  }
  std::string error;
  if (can_log_.reopen(&error))
    log_.info("CAN log reopened: " + can_log_.path());
  else
    log_.error(error);
}

void DaemonImpl::shutdown() {
  if (cycle_timer_) loop_.cancel_timer(cycle_timer_);
  cycle_timer_ = 0;
  check_stored();
  log_.info("shut down after " + [&] {
    std::uint64_t n = 0;
    for (const auto& s : master_->slaves()) n += s.data_exchanges;
    return std::to_string(n);
  }() + " Data_Exchange cycles");
}

}  // namespace

std::unique_ptr<Daemon> Daemon::start(const config::DaemonConfig& config, EventLoop& loop,
                                      LogSink* log, std::string* error) {
  auto d = std::make_unique<DaemonImpl>(config, loop, log);
  std::string e;
  if (!d->start(&e)) {
    if (error) *error = e;
    return nullptr;
  }
  return d;
}

// ------------------------------------------------------------------------------ map report

std::string modbus_map_text(const config::DaemonConfig& config) {
  std::ostringstream out;
  out << "Modbus/TCP " << config.modbus_listen.to_string() << " (emulator-spec §8)\n\n";
  out << "Unit IDs (status block and control register of one gateway; the process image is the "
         "same for all):\n";
  for (std::size_t i = 0; i < config.gateways.size(); ++i) {
    const auto& g = config.gateways[i];
    out << "  " << static_cast<int>(g.dp_address()) << (i == 0 ? ", 0, 255" : "") << "  " << g.name
        << "\n";
  }
  out << "  other  exception 0x0B\n\n";
  out << "Process image (PLC bytes; register r = bytes 2r high, 2r+1 low; bit b = byte b/8 bit "
         "b%8):\n";
  char line[256];
  for (const auto& g : config.gateways) {
    const auto params = config::slave_parameters(g);
    const auto decoded = dp::decode_chk_cfg(params.cfg);
    for (std::size_t i = 0; i < decoded.entries.size() && i < g.slots.size(); ++i) {
      const auto& e = decoded.entries[i];
      std::string comment;
      for (auto b : e.manufacturer) {
        std::snprintf(line, sizeof line, "%s%02X", comment.empty() ? "" : ",", b);
        comment += line;
      }
      for (int dir = 0; dir < 2; ++dir) {
        const bool input = dir == 0;
        const std::size_t n = input ? e.in_bytes() : e.out_bytes();
        const auto addr = input ? params.addresses[i].input : params.addresses[i].output;
        if (!n || !addr) continue;
        const unsigned first = *addr, last = static_cast<unsigned>(*addr + n - 1);
        std::snprintf(line, sizeof line,
                      "  %-10s slot %-2zu %-6s %s %4u..%-4u  %s %4u..%-4u  %s %5u..%-5u  %s\n",
                      g.name.c_str(), i, input ? "input" : "output", input ? "I" : "Q", first, last,
                      input ? "input registers  " : "holding registers", first / 2, last / 2,
                      input ? "discrete inputs" : "coils          ", first * 8, last * 8 + 7,
                      comment.empty() ? "" : ("comment " + comment).c_str());
        out << line;
        if (first % 2 || last % 2 == 0)
          out << "             (odd byte boundaries: the first/last register is shared with "
                 "neighbouring bytes)\n";
      }
    }
  }
  out << "\nStatus block (input registers, unit ID = DP address):\n";
  for (const auto& f : modbus::status_fields()) {
    const unsigned a = modbus::kStatusBase + f.offset;
    if (f.registers == 1)
      std::snprintf(line, sizeof line, "  %u        ", a);
    else
      std::snprintf(line, sizeof line, "  %u..%u  ", a, a + f.registers - 1);
    out << line << f.name << ": " << f.meaning << "\n";
  }
  out << "\nControl (holding register " << modbus::kControlRegister
      << ", unit ID = DP address): write 1 = power cycle, 2 = re-parameterize, 3 = the master "
         "stops addressing the gateway, 4 = it resumes; reads the last command\n";
  out << "Faults (docs/faults.md): holding register " << modbus::kForcedStateRegister
      << " = forced CAN state (0 real, 1 warning, 2 error-passive, 3 bus-off), "
      << modbus::kDropRxRegister << " = drop the next N received frames (IRQ_LOST)\n";
  out << "Exceptions: 0x01 unsupported function, 0x02 address outside the tables, 0x03 bad "
         "quantity/value, 0x0B unknown unit ID\n";
  return out.str();
}

}  // namespace candp2::daemon
