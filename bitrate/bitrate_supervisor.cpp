#include "bitrate/bitrate_supervisor.hpp"

#include "gateway/user_prm.hpp"

namespace candp2::bitrate {

namespace {

class NetlinkOps final : public LinkOps {
 public:
  explicit NetlinkOps(const std::string& interface) : link_(interface) {}
  std::optional<can::LinkInfo> info() override { return link_.info(); }
  std::optional<can::LinkError> set_bitrate(std::uint32_t bitrate,
                                            std::optional<std::uint32_t> restart_ms) override {
    return link_.set_bitrate(bitrate, restart_ms);
  }

 private:
  can::CanLink link_;
};

}  // namespace

std::unique_ptr<LinkOps> netlink_ops(const std::string& interface) {
  return std::make_unique<NetlinkOps>(interface);
}

BitrateSupervisor::BitrateSupervisor(std::string interface, config::BitrateMode mode,
                                     std::optional<std::uint32_t> restart_ms,
                                     std::unique_ptr<LinkOps> ops, LogSink* log)
    : interface_(std::move(interface)),
      mode_(mode),
      restart_ms_(restart_ms),
      ops_(std::move(ops)),
      log_(log, "socketcan " + interface_) {}

std::size_t BitrateSupervisor::add_gateway(std::string name) {
  members_.push_back({std::move(name), std::nullopt, std::nullopt});
  return members_.size() - 1;
}

void BitrateSupervisor::read_interface() {
  link_ = ops_->info();
  interface_bitrate_ = link_ && link_->bittiming
                           ? std::optional<std::uint32_t>(link_->bittiming->bitrate)
                           : std::nullopt;
  if (link_ && !link_->controller && !said_virtual_) {
    said_virtual_ = true;
    log_.info("no bit timing (virtual interface): the bit rate is not " +
              std::string(mode_ == config::BitrateMode::Apply ? "applied" : "checked"));
  }
}

void BitrateSupervisor::update(std::size_t gateway, std::optional<std::uint32_t> bitrate,
                               Time now) {
  Member& m = members_.at(gateway);
  const bool changed = bitrate != m.bitrate;
  m.bitrate = bitrate;
  if (changed) m.reported_mismatch.reset();
  if (changed && bitrate) {
    if (mode_ == config::BitrateMode::Apply)
      apply(gateway);
    else
      read_interface();
    next_check_ = now + kCheckInterval;
    report_all();
    return;
  }
  // The interface may be reconfigured, taken down or brought up behind our back (ip link set ...).
  // An interface without bit timing (vcan) stays so: not asked again (libsocketcan would print
  // "no link data found" to stderr at every request).
  if (bitrate && !said_virtual_ && (!next_check_ || now >= *next_check_)) {
    next_check_ = now + kCheckInterval;
    read_interface();
    report_all();
  }
}

void BitrateSupervisor::apply(std::size_t gateway) {
  const Member& m = members_[gateway];
  const std::uint32_t want = *m.bitrate;
  // Another gateway on this interface holds a different bit rate: one interface has one bit rate.
  // The new Set_Prm stays accepted by the gateway (the device side does not see this), the
  // interface keeps its rate and the status block shows the mismatch.
  for (std::size_t i = 0; i < members_.size(); ++i) {
    const Member& other = members_[i];
    if (i != gateway && other.bitrate && *other.bitrate != want) {
      log_.error("gateway " + m.name + ": Set_Prm bit rate " + gw::bitrate_text_bps(want) +
                 " refused: gateway " + other.name + " on the same interface uses " +
                 gw::bitrate_text_bps(*other.bitrate) + "; the interface keeps its bit rate");
      read_interface();
      return;
    }
  }
  read_interface();
  if (!link_) {
    log_.error("gateway " + m.name + ": cannot set the bit rate " + gw::bitrate_text_bps(want) +
               " from Set_Prm: interface " + interface_ + " does not exist");
    return;
  }
  if (!link_->controller) return;  // vcan: nothing to set (logged once)
  // An interface that is up at the rate is left alone; a down one (after boot, or taken down) or
  // one without bit timing (never configured) is set and brought up.
  if (link_->up && interface_bitrate_ && can::bitrate_matches(want, *interface_bitrate_)) {
    log_.info("bit rate " + gw::bitrate_text_bps(want) + " (Set_Prm of gateway " + m.name +
              ") already set");
    return;
  }
  const std::string was =
      (interface_bitrate_ ? gw::bitrate_text_bps(*interface_bitrate_) : "no bit timing") +
      (link_->up ? "" : ", down");
  if (const auto error = ops_->set_bitrate(want, restart_ms_)) {
    log_.error("gateway " + m.name + ": cannot set the bit rate " + gw::bitrate_text_bps(want) +
               " from Set_Prm: " + can::describe_link_error(interface_, *error, command(want)));
  } else {
    log_.info("bit rate set to " + gw::bitrate_text_bps(want) + " from the Set_Prm of gateway " +
              m.name + " (was " + was + ")" +
              (restart_ms_ ? ", restart-ms " + std::to_string(*restart_ms_) : std::string()) +
              (link_->up ? std::string() : "; interface up"));
  }
  read_interface();
}

// The commands an operator runs to put the interface at `bitrate` and up, as it is now.
std::string BitrateSupervisor::command(std::uint32_t bitrate) const {
  const bool at_rate = interface_bitrate_ && can::bitrate_matches(bitrate, *interface_bitrate_);
  const bool up = link_ && link_->up;
  return can::ip_link_command(interface_, at_rate && !up ? 0 : bitrate,
                              mode_ == config::BitrateMode::Apply ? restart_ms_ : std::nullopt, up);
}

// A controller that is down (after boot, or taken down by someone) once per change: the gateways
// report bus-off (the channel's bus state) until it is up; the line says how to bring it up.
void BitrateSupervisor::report_link() {
  if (!is_controller()) return;
  const Member* with_rate = nullptr;
  for (const auto& m : members_)
    if (m.bitrate && !with_rate) with_rate = &m;
  if (!with_rate) return;  // before Set_Prm the rate to give is unknown
  const bool down = !link_->up;
  if (reported_down_ == down || (!down && !reported_down_)) {
    reported_down_ = down;
    return;
  }
  reported_down_ = down;
  if (down)
    log_.warn("interface " + interface_ + " is down" +
              (interface_bitrate_ ? std::string() : " and has no bit timing") +
              ": the gateways on it report bus-off until it is up at " +
              gw::bitrate_text_bps(*with_rate->bitrate) + " (Set_Prm of gateway " +
              with_rate->name + "): `" + command(*with_rate->bitrate) + "`");
  else
    log_.info(
        "interface " + interface_ + " is up" +
        (interface_bitrate_ ? " at " + gw::bitrate_text_bps(*interface_bitrate_) : std::string()));
}

void BitrateSupervisor::report(std::size_t gateway) {
  Member& m = members_[gateway];
  const auto s = status(gateway);
  // A down interface is reported by report_link(); its bit rate is told when it is up.
  if (!m.bitrate || !interface_bitrate_ || !link_ || !link_->up) return;
  if (m.reported_mismatch == s.mismatch) return;
  m.reported_mismatch = s.mismatch;
  if (s.mismatch)
    log_.warn("bit rate mismatch: gateway " + m.name + " is parameterized for " +
              gw::bitrate_text_bps(s.configured) + " (Set_Prm byte 8), the interface runs at " +
              gw::bitrate_text_bps(s.interface) +
              (mode_ == config::BitrateMode::Check
                   ? " (\"bitrate\": \"check\": set it with `" + command(s.configured) + "`)"
                   : std::string()));
  else
    log_.info("bit rate " + gw::bitrate_text_bps(s.interface) + " matches gateway " + m.name);
}

BitrateStatus BitrateSupervisor::status(std::size_t gateway) const {
  const Member& m = members_.at(gateway);
  BitrateStatus s;
  s.mode = mode_ == config::BitrateMode::Apply ? 2 : 1;
  s.configured = m.bitrate.value_or(0);
  s.interface = interface_bitrate_.value_or(0);
  // A controller without bit timing does not run at the Set_Prm's rate either.
  s.mismatch = m.bitrate && is_controller() &&
               (!interface_bitrate_ || !can::bitrate_matches(*m.bitrate, *interface_bitrate_));
  return s;
}

}  // namespace candp2::bitrate
