#include "plant/plant.hpp"

#include <algorithm>
#include <cstdio>

#include "gateway/line_limits.hpp"
#include "gsd/gsd.hpp"
#include "plant/master_line.hpp"
#include "plant/slave_line.hpp"
#include "plant/timed_line.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"

namespace candp2::plant {

using config::BusType;

namespace {
constexpr std::string_view kGatewayPrefix = "gw:";  // endpoint names on a virtual bus
constexpr std::string_view kDrivePrefix = "drive:";
}  // namespace

const std::string& BusUnit::interface() const {
  if (cfg_->type == BusType::SocketCan) return cfg_->interface;
  return cfg_->channel.empty() ? cfg_->name : cfg_->channel;
}

// ------------------------------------------------------------------------------- gateway unit

void GatewayUnit::send(const can::Frame& frame) {
  // Virtual buses tap every frame themselves. On SocketCAN and socketcand buses the first
  // gateway's channel taps what it sends and receives: it receives what the other gateways on
  // that bus send (separate sockets/connections), so every frame is seen once.
  if (!faults_.pass_tx()) return;  // forced bus-off: dropped, counted (docs/faults.md)
  if (logs_bus_) plant_->tap_can(*bus_, frame, sender_, plant_->now_);
  channel_->send(frame);
}

// ---------------------------------------------------------------------------------- assembly

Plant::Plant(const config::DaemonConfig& config, Options options, Time now)
    : config_(config),
      options_(std::move(options)),
      log_sink_(options_.log),
      log_(options_.log, "plant"),
      now_(now),
      period_(milliseconds(config.cycle_ms)) {}

Plant::~Plant() = default;

std::unique_ptr<Plant> Plant::build(const config::DaemonConfig& config, Options options, Time now,
                                    std::string* error) {
  std::unique_ptr<Plant> p(new Plant(config, std::move(options), now));
  std::string e;
  if (!p->build_parts(&e)) {
    if (error) *error = e;
    return nullptr;
  }
  return p;
}

bool Plant::build_parts(std::string* error) {
  const bool line = config_.profibus && !options_.ignore_profibus;
  // docs/profibus.md "The line in time": on a timed line a lost station is parameterized again
  // after retry_ms; on the ideal line at once, as it always was.
  const bool timed = config_.line && !line;  // the in-process master's line
  master_ = std::make_unique<dp::DpMaster>(
      dp::MasterOptions{.address = config_.master_address,
                        .retry_delay = milliseconds(config_.retry_ms),
                        .lost_waits_retry = timed,
                        .parameterize_in_one_go = timed},
      log_sink_);
  if (timed) {
    timed_line_ = std::make_unique<TimedLine>(config_.line->baud, config_.line->params,
                                              config_.master_address, now_, log_sink_);
    timed_line_->set_step(options_.step);
    if (options_.wire_image)
      timed_line_->set_tap([this](std::span<const std::uint8_t> t, bool /*from_master*/, Time at) {
        tap_in_process(t, at, config_.line->baud);
      });
  }
  for (const auto& bc : config_.buses)
    if (!add_bus(bc, error)) return false;
  if (line && config_.profibus->role == config::ProfibusRole::Master) {
    // docs/profibus.md role master: the gateways are remote stations on the line; nothing local.
    if (!add_remote_stations(error)) return false;
  } else {
    if (line) {
      // docs/profibus.md role slaves: the gateways answer an external master over FDL; the
      // built-in master does not cycle.
      slave_line_ = std::make_unique<SlaveLine>(*config_.profibus, master_->image(), log_sink_);
      slave_line_->set_tap(
          [this](std::span<const std::uint8_t> t, bool ours, Time at) { tap_line(t, ours, at); });
      master_cycles_ = false;
    }
    for (const auto& gc : config_.gateways)
      if (!add_gateway(gc, error)) return false;
    for (const auto& sc : config_.slaves)
      if (!add_slave(sc, error)) return false;
  }
  for (const auto& dc : config_.drives)
    if (!add_drive(dc, error)) return false;
  next_cycle_ = options_.first_cycle_at_start ? now_ : now_ + period_;
  cycle_stats_.start(period_);
  return true;
}

bool Plant::add_bus(const config::BusConfig& cfg, std::string* /*error*/) {
  auto b = std::make_unique<BusUnit>();
  b->cfg_ = &cfg;
  b->index_ = static_cast<std::uint16_t>(buses_.size());
  if (cfg.type == BusType::Virtual) {
    b->vbus_ = std::make_unique<can::VirtualBus>();
    b->vbus_->count_changes_in(&bus_changes_);
    b->vbus_->use_clock(&now_);  // the plant's time, without a walk over the buses each step
    b->vbus_->set_now(now_);
    // docs/can-bus.md "The bus in time": with a bit rate the bus is timed from the plant's start.
    if (cfg.timed_bitrate) {
      b->vbus_->set_bitrate(*cfg.timed_bitrate, now_);
      const std::size_t i = timed_buses_.size();
      timed_buses_.push_back(b->vbus_.get());
      bus_deadlines_.resize(timed_buses_.size());
      b->vbus_->on_deadline_moved([this, i] { bus_deadlines_.moved(i); });
    }
    BusUnit* bus = b.get();
    // docs/can-bus.md "Performance": the frames that ended on a bus in time reached the gateways
    // that now hold frames; the sender has nothing to take and its state stood still.
    b->vbus_->on_changed([this, bus](bool state) {
      for (const auto& [g, endpoint] : bus->gateways_)
        if (state || endpoint->pending() > 0) mark_delivery(g);
    });
    b->vbus_->add_tap([this, bus](const can::Frame& f, Time t, std::string_view sender) {
      tap_can(*bus, f, sender, t);
    });
  }
  buses_.push_back(std::move(b));
  return true;
}

bool Plant::add_gateway(const config::GatewayConfig& cfg, std::string* error) {
  auto g = std::make_unique<GatewayUnit>();
  g->plant_ = this;
  g->cfg_ = &cfg;
  g->index_ = gateways_.size();
  to_deliver_.resize(g->index_ / 64 + 1);  // its engine may send while it is built
  g->sender_ = std::string(kGatewayPrefix) + cfg.name;
  g->bus_ = bus(cfg.bus);
  if (!g->bus_) {
    *error = "gateway \"" + cfg.name + "\": unknown bus \"" + cfg.bus + "\"";
    return false;
  }
  const auto& b = g->bus_->config();
  if (b.type == BusType::Virtual) {
    auto ep = g->bus_->virtual_bus()->endpoint(g->sender_);
    ep->set_tx_queue(can::kGatewayTxQueue);
    g->bus_->gateways_.push_back({g->index_, ep.get()});
    g->endpoint_ = ep.get();
    g->channel_ = std::move(ep);
  } else {
    if (!options_.environment) {
      *error = "gateway \"" + cfg.name + "\" on bus \"" + b.name + "\" (" + b.json_path + "): a " +
               std::string(config::to_string(b.type)) + " bus needs the daemon";
      return false;
    }
    std::string e;
    g->channel_ = options_.environment->open_channel(b, cfg, &e);
    if (!g->channel_) {
      *error = "gateway \"" + cfg.name + "\" on bus \"" + b.name + "\" (" + b.json_path + "): " + e;
      return false;
    }
    g->logs_bus_ = std::none_of(gateways_.begin(), gateways_.end(),
                                [&](const auto& other) { return other->bus_ == g->bus_; });
  }
  gw::GatewayOptions o;
  o.address = cfg.address;
  o.name = cfg.name;
  o.cia301_bootup = cfg.cia301_bootup;
  o.stored_wakeup_s = cfg.stored_wakeup_s;
  o.stored_sync_ms = cfg.stored_sync_ms;
  if (const auto it = options_.stored.find(cfg.dp_address()); it != options_.stored.end()) {
    o.stored_wakeup_s = it->second.wakeup_s;
    o.stored_sync_ms = it->second.sync_ms;
  }
  o.log = log_sink_;
  g->gateway_ = std::make_unique<gw::Gateway>(o, static_cast<can::FrameSink&>(*g), now_);
  if (slave_line_)
    slave_line_->add(g->gateway_->dp(), config::slave_parameters(cfg), cfg.name);
  else
    add_in_process(g->gateway_->dp(), config::slave_parameters(cfg), g->gateway_->address(),
                   config_.line ? gw::max_tsdr_bits(config_.line->baud) : std::nullopt, g.get());
  log_.info("gateway " + cfg.name + ": DP address " + std::to_string(g->gateway_->address()) +
            ", " + std::to_string(cfg.slots.size()) + " slots, bus " + b.name + " (" +
            std::string(config::to_string(b.type)) + ")");
  senders_.emplace(g->sender_, std::pair{SenderKind::Gateway, g->index()});
  if (g->endpoint_)
    g->bus_->known_senders_.push_back({g->endpoint_->name(), sender_of(g->endpoint_->name())});
  gateways_.push_back(std::move(g));
  gateway_deadlines_.resize(gateways_.size());
  mark_delivery(gateways_.size() - 1);  // nothing delivered to it yet
  return true;
}

bool Plant::add_drive(const config::DriveConfig& cfg, std::string* error) {
  BusUnit* b = bus(cfg.bus);
  if (!b || !b->virtual_bus()) {
    *error = "drive \"" + cfg.name + "\": bus \"" + cfg.bus + "\" is not a virtual bus";
    return false;
  }
  auto d = std::make_unique<DriveUnit>();
  d->cfg_ = &cfg;
  d->endpoint_ = b->virtual_bus()->endpoint(std::string(kDrivePrefix) + cfg.name);
  d->endpoint_->set_tx_queue(can::kDriveTxQueue);
  drive::UnitekDrive::Options o;
  o.rx_id = cfg.rx_id;
  o.tx_id = cfg.tx_id;
  o.name = cfg.name;
  drive::ParameterStore* store =
      options_.environment ? options_.environment->drive_store(cfg) : nullptr;
  try {
    d->drive_ = std::make_unique<faults::FaultyDrive>(o, log_sink_, store);
  } catch (const std::exception& e) {
    *error = "drive \"" + cfg.name + "\" (" + cfg.json_path + "): " + e.what();
    return false;
  }
  char ids[64];
  std::snprintf(ids, sizeof ids, "Rx ID 0x%03X, Tx ID 0x%03X", static_cast<unsigned>(cfg.rx_id),
                static_cast<unsigned>(cfg.tx_id));
  log_.info("drive " + cfg.name + ": Unitek on bus " + cfg.bus + ", " + ids);
  senders_.emplace(std::string(d->endpoint_->name()), std::pair{SenderKind::Drive, drives_.size()});
  b->known_senders_.push_back({d->endpoint_->name(), sender_of(d->endpoint_->name())});
  drives_.push_back(std::move(d));
  return true;
}

bool Plant::add_slave(const config::SlaveConfig& cfg, std::string* error) {
  auto u = std::make_unique<SlaveUnit>();
  u->cfg_ = &cfg;
  u->index_ = slaves_.size();
  std::string e;
  u->slave_ = gsd_slave::GsdSlave::create(cfg.setup(log_sink_), &e);
  if (!u->slave_) {
    *error = "slave \"" + cfg.name + "\" (" + cfg.json_path + "): " + e;
    return false;
  }
  if (slave_line_)
    slave_line_->add(u->slave_->dp(), config::slave_parameters(cfg), cfg.name);
  else
    add_in_process(
        u->slave_->dp(), config::slave_parameters(cfg), cfg.address,
        config_.line && cfg.model ? gsd::max_tsdr(*cfg.model, config_.line->baud) : std::nullopt);
  log_.info("slave " + cfg.name + ": DP address " + std::to_string(cfg.address) + ", " +
            gsd::to_utf8(u->slave_->profile().model) + ", " +
            std::to_string(u->slave_->input_length()) + " input and " +
            std::to_string(u->slave_->output_length()) + " output bytes");
  slaves_.push_back(std::move(u));
  return true;
}

namespace {
// The link to a gateway on the line in time: it marks the gateway touched before each request.
class TouchingLink final : public dp::SlaveLink {
 public:
  TouchingLink(dp::SlaveLink& inner, GatewayUnit& unit) : inner_(inner), unit_(unit) {}
  std::uint8_t address() const override { return inner_.address(); }
  void request(dp::Request req, Time now, dp::Completion done) override {
    unit_.gateway();  // touched
    inner_.request(std::move(req), now, std::move(done));
  }

 private:
  dp::SlaveLink& inner_;
  GatewayUnit& unit_;
};
}  // namespace

void Plant::add_in_process(dp::DpSlave& slave, dp::SlaveParameters params, std::uint8_t address,
                           std::optional<std::uint32_t> max_tsdr, GatewayUnit* unit) {
  if (timed_line_) return add_timed(slave, std::move(params), address, max_tsdr, unit);
  if (!options_.wire_image) {
    master_->add_slave(slave, std::move(params));
    return;
  }
  auto inner = std::make_unique<dp::InProcessLink>(slave);
  auto wire = std::make_unique<fdl::WireImageLink>(
      *inner, [this](std::span<const std::uint8_t> telegram, bool /*from_master*/, Time t) {
        tap_in_process(telegram, t);
      });
  master_->add_slave(*wire, std::move(params));
  wire_links_[address] = wire.get();
  links_.push_back(std::move(inner));
  links_.push_back(std::move(wire));
}

void Plant::add_timed(dp::DpSlave& slave, dp::SlaveParameters params, std::uint8_t /*address*/,
                      std::optional<std::uint32_t> max_tsdr, GatewayUnit* unit) {
  // A master writes the line's min_TSDR into every Set_Prm (byte 3, IEC 61158-6-3); the station
  // answers no earlier (docs/profibus.md "The line in time").
  if (params.prm.size() > 3)
    params.prm[3] = static_cast<std::uint8_t>(std::min(config_.line->params.min_tsdr_bits, 255u));
  std::unique_ptr<dp::SlaveLink> inner = std::make_unique<dp::InProcessLink>(slave);
  // A request reaching a gateway changes what it waits for (GatewayUnit::touched()).
  if (unit) {
    links_.push_back(std::move(inner));
    inner = std::make_unique<TouchingLink>(*links_.back(), *unit);
  }
  master_->add_slave(timed_line_->add_station(*inner, slave, max_tsdr), std::move(params));
  links_.push_back(std::move(inner));
}

void Plant::restarted(std::uint8_t address) {
  if (timed_line_) timed_line_->restarted(address);
  if (const auto it = wire_links_.find(address); it != wire_links_.end())
    static_cast<fdl::WireImageLink*>(it->second)->reset();
}

bool Plant::add_remote_stations(std::string* /*error*/) {
  master_line_ = std::make_unique<MasterLine>(*config_.profibus, config_.master_address, log_sink_);
  master_line_->set_tap(
      [this](std::span<const std::uint8_t> t, bool ours, Time at) { tap_line(t, ours, at); });
  // docs/profibus.md role master: gateways and generic slaves are remote stations alike.
  for (const auto& gc : config_.gateways) {
    master_->add_slave(master_line_->station(gc.dp_address()), config::slave_parameters(gc));
    master_line_->add_remote(gc.dp_address(), gc.name);
  }
  for (const auto& sc : config_.slaves) {
    master_->add_slave(master_line_->station(sc.address), config::slave_parameters(sc));
    master_line_->add_remote(sc.address, sc.name);
  }
  return true;
}

// -------------------------------------------------------------------------------- inspection

BusUnit* Plant::bus(std::string_view name) {
  for (auto& b : buses_)
    if (b->name() == name) return b.get();
  return nullptr;
}

GatewayUnit* Plant::gateway(std::string_view name) {
  for (auto& g : gateways_)
    if (g->name() == name) return g.get();
  return nullptr;
}

GatewayUnit* Plant::gateway_at(std::uint8_t dp_address) {
  for (auto& g : gateways_)
    if (g->gateway_->address() == dp_address) return g.get();
  return nullptr;
}

SlaveUnit* Plant::slave(std::string_view name) {
  for (auto& sl : slaves_)
    if (sl->name() == name) return sl.get();
  return nullptr;
}

SlaveUnit* Plant::slave_at(std::uint8_t dp_address) {
  for (auto& sl : slaves_)
    if (sl->config().address == dp_address) return sl.get();
  return nullptr;
}

DriveUnit* Plant::drive(std::string_view name) {
  for (auto& d : drives_)
    if (d->name() == name) return d.get();
  return nullptr;
}

std::map<std::uint8_t, StoredValues> Plant::stored() const {
  std::map<std::uint8_t, StoredValues> out;
  for (const auto& g : gateways_)
    out[g->gateway_->address()] = {g->gateway_->stored_wakeup_s(), g->gateway_->stored_sync_ms()};
  return out;
}

const fdl::LineStatistics* Plant::line_statistics() const {
  if (timed_line_) return &timed_line_->statistics();
  return master_line_ ? &master_line_->statistics() : nullptr;
}

}  // namespace candp2::plant
