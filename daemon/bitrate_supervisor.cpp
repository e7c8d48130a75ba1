#include "daemon/bitrate_supervisor.hpp"

namespace candp2::daemon {

namespace {

class NetlinkOps final : public LinkOps {
 public:
  explicit NetlinkOps(const std::string& interface) : link_(interface) {}
  std::optional<can::BitTiming> bittiming() override { return link_.bittiming(); }
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
  const auto bt = ops_->bittiming();
  interface_bitrate_ = bt ? std::optional<std::uint32_t>(bt->bitrate) : std::nullopt;
  if (!bt && !said_virtual_) {
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
    for (std::size_t i = 0; i < members_.size(); ++i) report(i);
    return;
  }
  // check: the interface may be reconfigured behind our back (ip link set ... bitrate N).
  // An interface without bit timing (vcan) stays so: not asked again (libsocketcan would print
  // "no link data found" to stderr at every request).
  if (mode_ == config::BitrateMode::Check && bitrate && !said_virtual_ &&
      (!next_check_ || now >= *next_check_)) {
    next_check_ = now + kCheckInterval;
    read_interface();
    for (std::size_t i = 0; i < members_.size(); ++i) report(i);
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
      log_.error("gateway " + m.name + ": Set_Prm bit rate " + can::format_bitrate(want) +
                 " refused: gateway " + other.name + " on the same interface uses " +
                 can::format_bitrate(*other.bitrate) + "; the interface keeps its bit rate");
      read_interface();
      return;
    }
  }
  read_interface();
  if (!interface_bitrate_) return;  // vcan: nothing to set (logged once)
  if (*interface_bitrate_ == want) {
    log_.info("bit rate " + can::format_bitrate(want) + " (Set_Prm of gateway " + m.name +
              ") already set");
    return;
  }
  if (const auto error = ops_->set_bitrate(want, restart_ms_)) {
    log_.error("gateway " + m.name + ": cannot set the bit rate " + can::format_bitrate(want) +
               " from Set_Prm: " + can::describe_link_error(interface_, *error));
  } else {
    log_.info("bit rate set to " + can::format_bitrate(want) + " from the Set_Prm of gateway " +
              m.name + " (was " + can::format_bitrate(*interface_bitrate_) + ")" +
              (restart_ms_ ? ", restart-ms " + std::to_string(*restart_ms_) : std::string()));
  }
  read_interface();
}

void BitrateSupervisor::report(std::size_t gateway) {
  Member& m = members_[gateway];
  const auto s = status(gateway);
  if (!m.bitrate || !interface_bitrate_) return;
  if (m.reported_mismatch == s.mismatch) return;
  m.reported_mismatch = s.mismatch;
  if (s.mismatch)
    log_.warn("bit rate mismatch: gateway " + m.name + " is parameterized for " +
              can::format_bitrate(s.configured) + " (Set_Prm byte 8), the interface runs at " +
              can::format_bitrate(s.interface) +
              (mode_ == config::BitrateMode::Check
                   ? " (\"bitrate\": \"check\": set it with `ip link set " + interface_ +
                         " down; ip link set " + interface_ + " type can bitrate " +
                         std::to_string(s.configured) + "; ip link set " + interface_ + " up`)"
                   : std::string()));
  else
    log_.info("bit rate " + can::format_bitrate(s.interface) + " matches gateway " + m.name);
}

modbus::BitrateStatus BitrateSupervisor::status(std::size_t gateway) const {
  const Member& m = members_.at(gateway);
  modbus::BitrateStatus s;
  s.mode = mode_ == config::BitrateMode::Apply ? 2 : 1;
  s.configured = m.bitrate.value_or(0);
  s.interface = interface_bitrate_.value_or(0);
  s.mismatch =
      m.bitrate && interface_bitrate_ && !can::bitrate_matches(*m.bitrate, *interface_bitrate_);
  return s;
}

}  // namespace candp2::daemon
