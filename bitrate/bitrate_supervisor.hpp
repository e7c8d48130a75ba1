// The CAN bit rate of one SocketCAN interface versus the gateways on it (docs/transports.md, "Bit
// rate"). The real CAN-DP/2 sets its controller from Set_Prm byte 8 (manual §5.1.2,
// docs/dp-slave.md "User parameters"); candp2d either checks the interface against it ("bitrate":
// "check") or sets it ("apply", CAP_NET_ADMIN: down, bit rate, restart-ms, up, through
// can::CanLink).
//
// The daemon calls update() after every master cycle with each gateway's accepted bit rate (a pure
// accessor of the gateway, Gateway::user_prm()); netlink is touched only when a gateway's bit rate
// changed and every 5 s after that (the interface may be reconfigured, taken down or brought up
// behind candp2d's back). The Set_Prm bit rate is known only after the master's first Set_Prm: an
// interface that is down at start (as after boot, perhaps without any bit timing) is configured
// ("apply") or reported with the command that configures it ("check") at that moment
// (docs/transports.md "Down interfaces"). Netlink requests are synchronous and quick (a local
// kernel round trip): acceptable in the one event loop. The interface is reached through LinkOps
// so that the rules are tested without CAN.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "can/can_link.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "station/status.hpp"

namespace candp2::bitrate {

using BitrateStatus = station::BitrateStatus;  // docs/transports.md "Bit rate"

class LinkOps {
 public:
  virtual ~LinkOps() = default;
  // nullopt: the interface does not exist (any more).
  virtual std::optional<can::LinkInfo> info() = 0;
  virtual std::optional<can::LinkError> set_bitrate(std::uint32_t bitrate,
                                                    std::optional<std::uint32_t> restart_ms) = 0;
};
// The real interface (libsocketcan).
std::unique_ptr<LinkOps> netlink_ops(const std::string& interface);

class BitrateSupervisor {
 public:
  static constexpr Duration kCheckInterval = seconds(5);

  BitrateSupervisor(std::string interface, config::BitrateMode mode,
                    std::optional<std::uint32_t> restart_ms, std::unique_ptr<LinkOps> ops,
                    LogSink* log);

  // One gateway on this interface; returns its index for update()/status().
  std::size_t add_gateway(std::string name);
  // The gateway's accepted Set_Prm bit rate (bit/s), nullopt while it has none.
  void update(std::size_t gateway, std::optional<std::uint32_t> bitrate, Time now);
  BitrateStatus status(std::size_t gateway) const;
  std::optional<std::uint32_t> interface_bitrate() const { return interface_bitrate_; }

 private:
  void apply(std::size_t gateway);
  void read_interface();
  void report(std::size_t gateway);
  void report_link();
  void report_all() {
    report_link();
    for (std::size_t i = 0; i < members_.size(); ++i) report(i);
  }
  bool is_controller() const { return link_ && link_->controller; }
  std::string command(std::uint32_t bitrate) const;

  struct Member {
    std::string name;
    std::optional<std::uint32_t> bitrate;
    std::optional<bool> reported_mismatch;  // what the log said last
  };
  std::string interface_;
  config::BitrateMode mode_;
  std::optional<std::uint32_t> restart_ms_;
  std::unique_ptr<LinkOps> ops_;
  Logger log_;
  std::vector<Member> members_;
  std::optional<can::LinkInfo> link_;  // the last read
  std::optional<std::uint32_t> interface_bitrate_;
  bool said_virtual_ = false;
  std::optional<bool> reported_down_;  // what the log said last about a down interface
  std::optional<Time> next_check_;
};

}  // namespace candp2::bitrate
