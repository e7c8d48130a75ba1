// candp2d's wiring: configuration → plant → faces, on one event loop (docs/architecture.md).
#include "daemon/daemon.hpp"

#include <algorithm>
#include <map>
#include <utility>

#include "bitrate/bitrate_supervisor.hpp"
#include "can/socketcan.hpp"
#include "can/socketcand.hpp"
#include "capture/can_log.hpp"
#include "capture/pcapng_tap.hpp"
#include "common/log_throttle.hpp"
#include "daemon/sim_clock.hpp"
#include "daemon/state_file.hpp"
#include "drive_sim/file_parameter_store.hpp"
#include "event_loop/deadline_timer.hpp"
#include "http/http_server.hpp"
#include "http/plant_sources.hpp"
#include "modbus/modbus_server.hpp"
#include "modbus/plant_faces.hpp"
#include "profibus_line/line_port.hpp"

namespace candp2::daemon {

namespace {

using config::BusType;

// A virtual bus exported over socketcand (docs/transports.md): its endpoint on the bus, the
// server, and the timer of the server's idle timeouts.
struct Export {
  plant::BusUnit* bus = nullptr;
  std::unique_ptr<can::VirtualEndpoint> endpoint;
  std::unique_ptr<can::SocketcandServer> server;
  std::unique_ptr<DeadlineTimer> timer;  // on the wall clock the server runs on
};

// A gateway's channel with a descriptor (SocketCAN, socketcand client) and, for socketcand
// clients, the reconnection timer.
struct Watched {
  std::size_t gateway = 0;
  can::SocketcandClientChannel* link = nullptr;
  std::unique_ptr<DeadlineTimer> timer;  // reconnection (socketcand clients only)
};

// The SocketCAN interface of a gateway: its bit-rate supervisor and the member index there.
struct LinkMember {
  bitrate::BitrateSupervisor* supervisor = nullptr;
  std::size_t member = 0;
};

class DaemonImpl final : public Daemon, private plant::Environment, private plant::Tap {
 public:
  DaemonImpl(const config::DaemonConfig& config, EventLoop& loop, LogSink* log)
      : config_(config),
        loop_(loop),
        log_sink_(log),
        log_(log, "daemon"),
        can_log_tap_(can_log_, [] { return EventLoop::wall_now(); }),
        // docs/daemon.md "Host stalls": not with a PROFIBUS line, whose foreign side runs on.
        clock_(config.profibus ? Duration(0) : milliseconds(config.host_stall_ms)),
        stall_log_(log_) {}

  ~DaemonImpl() override {
    // Unregister everything from the loop before the parts go away.
    http_.reset();
    if (deferred_) loop_.remove_deferred(deferred_);
    plant_timer_.reset();
    stall_flush_.reset();
    for (auto& w : watched_) w.timer.reset();
    for (auto& e : exports_) e->timer.reset();
    for (int fd : fds_) loop_.remove_fd(fd);
    slave_port_.reset();
    master_port_.reset();
    modbus_.reset();
  }

  bool start(std::string* error);

  std::uint16_t modbus_port() const override { return modbus_ ? modbus_->port() : 0; }
  std::optional<std::uint16_t> http_port() const override {
    return http_ ? std::optional<std::uint16_t>(http_->port()) : std::nullopt;
  }
  std::size_t modbus_clients() const override { return modbus_ ? modbus_->client_count() : 0; }
  std::optional<std::uint16_t> socketcand_port(std::string_view name) const override {
    for (const auto& e : exports_)
      if (e->bus->name() == name) return e->server->port();
    return std::nullopt;
  }
  std::string listening() const override;
  void reopen_can_log() override;
  void shutdown() override;
  dp::DpMaster& master() override { return plant_->master(); }
  gw::Gateway* gateway(std::uint8_t dp_address) override {
    auto* g = plant_->gateway_at(dp_address);
    return g ? &g->gateway() : nullptr;
  }
  can::VirtualBus* virtual_bus(std::string_view name) override {
    auto* b = plant_->bus(name);
    return b ? b->virtual_bus() : nullptr;
  }
  plant::Plant& plant() override { return *plant_; }

 private:
  // plant::Environment: the channels of SocketCAN and socketcand buses, the drives' files.
  std::unique_ptr<can::Channel> open_channel(const config::BusConfig& bus,
                                             const config::GatewayConfig& gateway,
                                             std::string* error) override;
  drive::ParameterStore* drive_store(const config::DriveConfig& drive) override;
  // plant::Tap: the HTTP face's bus monitors and the socketcand exports see every frame.
  void on_can(const plant::CanRecord& r) override;

  bool watch(int fd, std::function<void()> on_readable, std::string* error);
  bool start_exports(std::string* error);
  void start_capture();
  bool start_line(std::string* error);
  // "1 gateway(s)", "0 gateway(s), 2 generic slave(s)": the stations of the log lines.
  std::string stations() const {
    return std::to_string(config_.gateways.size()) + " gateway(s)" +
           (config_.slaves.empty()
                ? std::string()
                : ", " + std::to_string(config_.slaves.size()) + " generic slave(s)");
  }
  bool start_modbus(std::string* error);
  bool start_http(std::string* error);
  bool after_dispatch();  // the deferred hook
  void rearm_plant();
  void rearm_export(Export& e);
  void rearm_link(Watched& w);
  void after_cycle(Time now);
  // The simulated clock now (docs/daemon.md "Host stalls"): every plant call and every timer
  // armed from a plant deadline takes its time from here; finds and logs host stalls.
  Time sim_now();
  void check_stored();
  std::optional<modbus::BitrateStatus> bitrate(std::size_t gateway) const;

  config::DaemonConfig config_;
  EventLoop& loop_;
  LogSink* log_sink_;
  Logger log_;
  std::unique_ptr<plant::Plant> plant_;
  StoredMap stored_;        // what the state file holds
  bool state_kept_ = true;  // false: the state file's folder cannot be written (logged once)
  std::map<std::string, std::unique_ptr<bitrate::BitrateSupervisor>> supervisors_;  // by interface
  std::map<std::string, LinkMember> link_of_;     // by gateway name, while the plant is built
  std::vector<std::optional<LinkMember>> links_;  // by gateway index, from link_of_ at start
  std::vector<std::unique_ptr<drive::FileParameterStore>> drive_stores_;
  std::vector<std::unique_ptr<Export>> exports_;
  std::vector<Watched> watched_;
  capture::CanLog can_log_;
  capture::CanLogTap can_log_tap_;
  std::unique_ptr<capture::PcapngTap> pcapng_;  // capture section (docs/capture.md)
  std::unique_ptr<profibus_line::SlaveLinePort> slave_port_;
  std::unique_ptr<profibus_line::MasterLinePort> master_port_;
  modbus::PlantFaces faces_;
  std::unique_ptr<modbus::ProcessImageMap> map_;
  std::unique_ptr<modbus::ModbusServer> modbus_;
  std::vector<int> fds_;
  EventLoop::DeferredId deferred_ = 0;
  std::unique_ptr<DeadlineTimer> plant_timer_;
  SimClock clock_;
  std::optional<Time> due_;  // the simulated time plant_timer_ wakes the loop at
  LogThrottle stall_log_;
  std::unique_ptr<DeadlineTimer> stall_flush_;   // stall_log_'s summary, on the loop's clock
  std::unique_ptr<http::BusMonitors> monitors_;  // the HTTP face's tap: per bus counts and trace
  std::unique_ptr<http::StatusModel> status_model_;  // declared last: destroyed first
  std::unique_ptr<http::HttpServer> http_;
};

// ---------------------------------------------------------------------------- environment

std::unique_ptr<can::Channel> DaemonImpl::open_channel(const config::BusConfig& b,
                                                       const config::GatewayConfig& gc,
                                                       std::string* error) {
  std::string e;
  if (b.type == BusType::SocketCan) {
    // One raw socket per gateway: gateways on one interface see each other's frames, as
    // separate devices on a bus do. A down interface is no start error: bus-off until it is up
    // (docs/transports.md "Down interfaces").
    auto channel = can::open_socketcan(
        b.interface, &e, {.receive_own = false, .log = log_sink_, .allow_down = true});
    if (!channel) {
      *error = "cannot open SocketCAN interface " + b.interface + ": " + e;
      return nullptr;
    }
    auto& sup = supervisors_[b.interface];
    if (!sup)
      sup = std::make_unique<bitrate::BitrateSupervisor>(
          b.interface, b.bitrate, b.restart_ms, bitrate::netlink_ops(b.interface), log_sink_);
    link_of_[gc.name] = {sup.get(), sup->add_gateway(gc.name)};
    return channel;
  }
  auto channel =
      can::connect_socketcand(b.remote.host, b.remote.port, b.channel, &e, 3000, log_sink_);
  if (!channel) *error = e;
  return channel;
}

drive::ParameterStore* DaemonImpl::drive_store(const config::DriveConfig& d) {
  if (!d.state_file) return nullptr;
  drive_stores_.push_back(std::make_unique<drive::FileParameterStore>(*d.state_file));
  return drive_stores_.back().get();
}

std::optional<modbus::BitrateStatus> DaemonImpl::bitrate(std::size_t gateway) const {
  const auto& link = links_.at(gateway);
  if (!link) return std::nullopt;
  return link->supervisor->status(link->member);
}

// -------------------------------------------------------------------------------- observers

void DaemonImpl::on_can(const plant::CanRecord& r) {
  // Frames the clients sent were already forwarded to the other clients by the server
  // (can/socketcand_server.hpp).
  for (auto& e : exports_)
    if (e->bus->index() == r.bus && r.sender != e->endpoint->name())
      e->server->publish(r.frame, EventLoop::wall_now());
}

// ------------------------------------------------------------------------------------ start

bool DaemonImpl::watch(int fd, std::function<void()> on_readable, std::string* error) {
  if (!loop_.add_fd(
          fd, EventLoop::kReadable, [cb = std::move(on_readable)](std::uint32_t) { cb(); }, error))
    return false;
  fds_.push_back(fd);
  return true;
}

bool DaemonImpl::start(std::string* error) {
  plant::Options o;
  o.log = log_sink_;
  o.environment = this;
  if (config_.state_file) {
    stored_ = load_state(*config_.state_file, log_);
    std::string why;
    state_kept_ = prepare_folder_of(*config_.state_file, &why);
    if (!state_kept_)
      log_.warn("state file " + *config_.state_file + ": " + why +
                "; the gateways' stored wake-up and SYNC values are not kept across restarts");
  }
  o.stored = stored_;
  for (const auto* file : {config_.can_log ? &*config_.can_log : nullptr,
                           config_.capture ? &config_.capture->pcapng : nullptr}) {
    std::string why;
    if (file && !prepare_folder_of(*file, &why)) {
      *error = *file + ": " + why;
      return false;
    }
  }
  if (config_.can_log && !can_log_.open(*config_.can_log, error)) return false;
  o.wire_image = config_.capture.has_value();  // the in-process DP side in the capture
  // docs/profibus.md "The line in time", docs/can-bus.md "In the plant": the line and the buses
  // in time in steps of 1 ms in real time.
  o.step = milliseconds(1);
  // docs/can-bus.md "In the plant": buses that only fill images, at the plant's wakes and at
  // least every 10 ms (before each master cycle).
  o.image_bus_step = milliseconds(10);
  // A cycle the line step passed over starts at its own time; one the host held back by more
  // than the host-stall tolerance (at least 50 ms) starts late (master.host_stall_ms 0).
  o.line_catch_up = o.step + std::max(clock_.tolerance(), Duration(milliseconds(50)));
  plant_ = plant::Plant::build(config_, std::move(o), loop_.now(), error);
  if (!plant_) return false;
  plant_timer_ = std::make_unique<DeadlineTimer>(loop_, [this] { plant_->advance(sim_now()); });
  stall_flush_ = std::make_unique<DeadlineTimer>(loop_, [this] {
    stall_log_.flush(loop_.now());
    stall_flush_->arm(stall_log_.next_flush(), loop_.now());
  });
  links_.resize(plant_->gateways().size());
  for (auto& g : plant_->gateways())
    if (const auto it = link_of_.find(g->name()); it != link_of_.end())
      links_[g->index()] = it->second;
  link_of_.clear();
  plant_->add_tap(this);
  plant_->add_tap(&can_log_tap_);
  if (config_.capture) start_capture();
  if (!start_exports(error)) return false;
  for (auto& g : plant_->gateways()) {
    const int fd = g->channel().poll_fd();
    if (fd < 0) continue;
    Watched w;
    w.gateway = g->index();
    w.link = dynamic_cast<can::SocketcandClientChannel*>(&g->channel());
    const std::size_t k = watched_.size();
    if (w.link)
      w.timer = std::make_unique<DeadlineTimer>(loop_, [this, k] {
        watched_[k].link->advance(loop_.now());
        plant_->receive(watched_[k].gateway, sim_now());  // shows the state
        rearm_link(watched_[k]);
      });
    watched_.push_back(std::move(w));
    if (!watch(
            fd,
            [this, k] {
              plant_->receive(watched_[k].gateway, sim_now());
              rearm_link(watched_[k]);
            },
            error))
      return false;
  }
  check_stored();
  if (config_.profibus && !start_line(error)) return false;
  if (!start_modbus(error)) return false;
  if (config_.http_listen && !start_http(error)) return false;
  plant_->on_cycle([this](Time now) { after_cycle(now); });
  deferred_ = loop_.add_deferred([this] { return after_dispatch(); });
  rearm_plant();
  if (plant_->master_runs())
    log_.info("master " + std::to_string(config_.master_address) + ": cycle " +
              std::to_string(config_.cycle_ms) + " ms, " + stations());
  return true;
}

// docs/capture.md: every CAN frame, DP telegram and operator note into pcapng files, written by
// the capture's own thread (the event loop only queues). Time: the plant's CLOCK_MONOTONIC plus
// CLOCK_REALTIME − CLOCK_MONOTONIC taken once, so a wall-clock step never reorders packets.
void DaemonImpl::start_capture() {
  const auto& c = *config_.capture;
  capture::PcapngTapOptions o;
  o.writer.path = c.pcapng;
  o.writer.max_bytes = c.max_bytes();
  o.writer.files = c.files;
  o.writer.application = "candp2d";
  o.profibus = c.profibus_linktype == config::CaptureProfibusLinktype::ProfibusDl
                   ? capture::ProfibusLinktype::ProfibusDl
                   : capture::ProfibusLinktype::WiresharkUpperPdu;
  o.wall_offset = EventLoop::wall_now() - EventLoop::monotonic_now();
  for (const auto& b : config_.buses) o.can_bitrates.push_back(b.timed_bitrate.value_or(0));
  pcapng_ = std::make_unique<capture::PcapngTap>(o, log_sink_);
  plant_->add_tap(pcapng_.get());
  pcapng_->watch_bus_errors(*plant_);
  log_.info("capture: " + c.pcapng +
            (c.max_mb ? ", ring of " + (c.files ? std::to_string(c.files) : std::string("all")) +
                            " files of " + std::to_string(c.max_mb) + " MB"
                      : std::string()));
}

bool DaemonImpl::start_exports(std::string* error) {
  for (auto& b : plant_->buses()) {
    const auto& cfg = b->config();
    if (!b->virtual_bus() || !cfg.socketcand_listen) continue;
    auto e = std::make_unique<Export>();
    e->bus = b.get();
    e->endpoint = b->virtual_bus()->endpoint("socketcand:" + cfg.channel);
    e->endpoint->set_tx_queue(can::kSocketcandTxQueue);
    can::SocketcandServer::Options o;
    o.host = cfg.socketcand_listen->host;
    o.port = cfg.socketcand_listen->port;
    o.channel = cfg.channel;
    o.max_clients = cfg.socketcand_max_clients;
    o.idle_timeout = seconds(cfg.socketcand_idle_timeout_s);
    std::string err;
    e->server = can::SocketcandServer::listen(o, *e->endpoint, log_sink_, &err);
    if (!e->server) {
      *error = "bus \"" + cfg.name + "\" (" + cfg.json_path + ".socketcand): " + err;
      return false;
    }
    Export* ep = e.get();
    ep->timer = std::make_unique<DeadlineTimer>(loop_, [this, ep] {
      ep->server->advance(EventLoop::wall_now());
      rearm_export(*ep);
    });
    for (int fd : ep->server->poll_fds())
      if (!watch(
              fd,
              [this, ep, fd] {
                // Frames the clients send enter the bus now (plant/plant.hpp set_now).
                plant_->set_now(sim_now());
                ep->server->on_readable(fd, EventLoop::wall_now());
                rearm_export(*ep);
              },
              error))
        return false;
    log_.info("bus " + cfg.name + ": socketcand export on " + cfg.socketcand_listen->host + ":" +
              std::to_string(ep->server->port()) + ", bus name \"" + cfg.channel + "\"");
    exports_.push_back(std::move(e));
  }
  return true;
}

bool DaemonImpl::start_line(std::string* error) {
  if (auto* line = plant_->slave_line()) {
    slave_port_ =
        profibus_line::SlaveLinePort::open(*config_.profibus, *line, loop_, log_sink_, error);
    if (!slave_port_) return false;
    log_.info("PROFIBUS line " + slave_port_->describe() + ": " + stations() +
              " answer an external master");
  } else if (auto* mline = plant_->master_line()) {
    master_port_ =
        profibus_line::MasterLinePort::open(*config_.profibus, *mline, loop_, log_sink_, error);
    if (!master_port_) return false;
    log_.info("PROFIBUS line " + master_port_->describe() + ": master " +
              std::to_string(config_.master_address) + " drives " +
              std::to_string(config_.gateways.size() + config_.slaves.size()) +
              " remote station(s)");
  }
  return true;
}

bool DaemonImpl::start_modbus(std::string* error) {
  faces_ = modbus::make_faces(*plant_, [this](std::size_t g) { return bitrate(g); });
  map_ = std::make_unique<modbus::ProcessImageMap>(plant_->master().image(), faces_.gateway_list(),
                                                   faces_.drive_list(), faces_.field_list());
  map_->set_host_stalls([this] { return clock_.stalls(); });
  map_->set_outputs_read_only(plant_->slave_line() != nullptr);
  std::string e;
  modbus_ = modbus::ModbusServer::listen({.host = config_.modbus_listen.host,
                                          .port = config_.modbus_listen.port,
                                          .max_clients = config_.modbus_max_clients,
                                          .idle_timeout = seconds(config_.modbus_idle_timeout_s),
                                          .now = [this] { return sim_now(); }},
                                         loop_, *map_, log_sink_, &e);
  if (!modbus_) {
    *error = "Modbus/TCP ($.modbus.listen): " + e;
    return false;
  }
  return true;
}

bool DaemonImpl::start_http(std::string* error) {
  const auto& at = *config_.http_listen;
  if (at.host.rfind("127.", 0) != 0)
    log_.warn("http.listen " + at.to_string() +
              ": not a loopback address; the status page and API are readable from the network");
  monitors_ = std::make_unique<http::BusMonitors>(plant_->buses().size());
  plant_->add_tap(monitors_.get());
  // The Modbus server's figures, handed to the HTTP face (which reads no other face).
  std::function<http::ModbusFigures()> modbus_figures;
  if (modbus_)
    modbus_figures = [m = modbus_.get()] {
      const auto& st = m->stats();
      return http::ModbusFigures{st.requests, st.exceptions, m->client_count(),
                                 st.clients_accepted};
    };
  auto sources = http::make_sources(*plant_, monitors_.get(), std::move(modbus_figures),
                                    [this](std::size_t g) { return bitrate(g); });
  sources.host_stalls = [this] { return clock_.stalls(); };
  status_model_ = std::make_unique<http::StatusModel>(std::move(sources));
  std::string e;
  http_ = http::HttpServer::listen(
      {.host = at.host,
       .port = at.port,
       .max_clients = config_.http_max_clients,
       .idle_timeout = seconds(config_.http_idle_timeout_s),
       .cycle = milliseconds(config_.cycle_ms),
       .next_cycle = [this]() -> std::optional<Time> { return plant_->next_cycle(); },
       .now = [this] { return sim_now(); }},
      loop_, *status_model_, log_sink_, &e);
  if (!http_) {
    *error = "HTTP ($.http.listen): " + e;
    return false;
  }
  return true;
}

// ------------------------------------------------------------------------------------- time

// After every dispatched event: frames between in-process endpoints, then the plant's timer.
bool DaemonImpl::after_dispatch() {
  const bool work = plant_->deliver(sim_now());
  // The export endpoints only send (frames for clients come through the tap): discard their
  // queues.
  for (auto& e : exports_)
    while (e->endpoint->receive()) {
    }
  rearm_plant();
  return work;
}

void DaemonImpl::rearm_plant() {
  const Time now = sim_now();
  due_ = plant_->next_deadline();
  if (due_) due_ = std::max(*due_, now);
  plant_timer_->arm(due_, now);
}

Time DaemonImpl::sim_now() {
  const Time loop_now = loop_.now();
  Duration stall{0};
  const Time now = clock_.now(loop_now, due_, &stall);
  if (stall > Duration(0)) {
    const auto& st = clock_.stalls();
    auto ms = [](Duration d) { return std::to_string(d.count() / 1000); };
    stall_log_.log(loop_now, "stall", LogLevel::Warn,
                   "host stall: the loop woke " + ms(stall) + " ms late (master.host_stall_ms " +
                       ms(clock_.tolerance()) + "); the simulated world did not see it (" +
                       std::to_string(st.count) + " stall(s), " + ms(st.total) + " ms in all)");
    stall_flush_->arm(stall_log_.next_flush(), loop_now);
  }
  return now;
}

// The socketcand export's idle timeouts run on the wall clock its on_readable() is given.
void DaemonImpl::rearm_export(Export& e) {
  e.timer->arm(e.server->next_deadline(), EventLoop::wall_now());
}

// A socketcand client channel's reconnection timer (can/socketcand_client.hpp).
void DaemonImpl::rearm_link(Watched& w) {
  if (w.link) w.timer->arm(w.link->next_deadline(), loop_.now());
}

void DaemonImpl::after_cycle(Time now) {
  // The SocketCAN interfaces' bit rates against the gateways' accepted Set_Prm byte 8.
  for (const auto& g : std::as_const(*plant_).gateways()) {
    const auto& link = links_[g->index()];
    if (!link) continue;
    const auto& prm = std::as_const(*g).gateway().user_prm();
    link->supervisor->update(link->member, prm ? gw::bitrate_bps(prm->bitrate_index) : std::nullopt,
                             clock_.to_loop(now));  // the interface's real edge
  }
  if (http_) http_->after_cycle(now);
  check_stored();
}

void DaemonImpl::check_stored() {
  if (!config_.state_file || !state_kept_) return;
  auto now = plant_->stored();
  if (now == stored_) return;
  stored_ = std::move(now);
  std::string error;
  if (!save_state(*config_.state_file, stored_, &error)) log_.error("state file: " + error);
}

// ------------------------------------------------------------------------------ the rest

std::string DaemonImpl::listening() const {
  std::string out = "modbus " + config_.modbus_listen.host + ":" + std::to_string(modbus_port());
  if (http_) out += ", http " + config_.http_listen->host + ":" + std::to_string(http_->port());
  for (const auto& e : exports_)
    out += ", bus " + e->bus->name() + " socketcand " + e->bus->config().socketcand_listen->host +
           ":" + std::to_string(e->server->port());
  if (slave_port_) out += ", profibus " + slave_port_->describe();
  if (master_port_) out += ", profibus " + master_port_->describe();
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
  if (plant_timer_) plant_timer_->disarm();
  if (deferred_) loop_.remove_deferred(deferred_);
  deferred_ = 0;
  check_stored();
  std::uint64_t n = 0;
  for (const auto& s : plant_->master().slaves()) n += s.data_exchanges;
  log_.info("shut down after " + std::to_string(n) + " Data_Exchange cycles");
  if (pcapng_) {
    plant_->remove_tap(pcapng_.get());
    pcapng_->unwatch_bus_errors(*plant_);
    const auto st = pcapng_->stats();
    pcapng_.reset();  // writes what is queued and closes the file
    log_.info("capture: " + std::to_string(st.packets) + " packets written" +
              (st.dropped ? ", " + std::to_string(st.dropped) + " dropped" : std::string()) +
              (st.stopped ? " (stopped by a write error)" : ""));
  }
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

}  // namespace candp2::daemon
