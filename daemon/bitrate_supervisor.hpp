// The CAN bit rate of one SocketCAN interface versus the gateways on it (docs/transports.md, "Bit
// rate"). The real CAN-DP/2 sets its controller from Set_Prm byte 8 (manual §5.1.2, emulator-spec
// §1.1); candp2d either checks the interface against it ("bitrate": "check") or sets it ("apply",
// CAP_NET_ADMIN: down, bit rate, up, through can::CanLink).
//
// The daemon calls update() after every master cycle with each gateway's accepted bit rate (a pure
// accessor of the gateway, Gateway::user_prm()); netlink is touched only when a gateway's bit rate
// changed and every 5 s in check mode (the interface may be reconfigured behind candp2d's back).
// Netlink requests are synchronous and quick (a local kernel round trip): acceptable in the one
// event loop. The interface is reached through LinkOps so that the rules are tested without CAN.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "can/can_link.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "modbus/modbus_map.hpp"

namespace candp2::daemon {

class LinkOps {
 public:
  virtual ~LinkOps() = default;
  virtual std::optional<can::BitTiming> bittiming() = 0;
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
  modbus::BitrateStatus status(std::size_t gateway) const;
  std::optional<std::uint32_t> interface_bitrate() const { return interface_bitrate_; }

 private:
  void apply(std::size_t gateway);
  void read_interface();
  void report(std::size_t gateway);

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
  std::optional<std::uint32_t> interface_bitrate_;
  bool said_virtual_ = false;
  std::optional<Time> next_check_;
};

}  // namespace candp2::daemon
