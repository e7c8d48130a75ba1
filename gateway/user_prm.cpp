#include "gateway/user_prm.hpp"

#include <algorithm>

namespace candp2::gw {

std::string_view bitrate_name(std::uint8_t index) {
  // manual table 5.1.1, as the GSD's PrmText 1 writes the rates (166k, not 166.6k).
  static constexpr std::string_view kNames[] = {"1000k", "666.6k", "500k",  "333.3k", "250k",
                                                "166k",  "125k",   "100k",  "66.6k",  "50k",
                                                "33.3k", "20k",    "12.5k", "10k"};
  static_assert(std::size(kNames) == kBitrates.size());
  return index < std::size(kNames) ? kNames[index] : "?";
}

std::string bitrate_text(std::uint8_t index) {
  if (!bitrate_bps(index)) return "?";
  auto name = bitrate_name(index);
  name.remove_suffix(1);  // the "k"
  return std::string(name) + " kbit/s";
}

std::string bitrate_text_bps(std::uint32_t bps) {
  for (std::uint8_t i = 0; i < kBitrates.size(); ++i)
    if (kBitrates[i] == bps) return bitrate_text(i);
  if (bps % 1000 == 0) return std::to_string(bps / 1000) + " kbit/s";
  return std::to_string(bps) + " bit/s";
}

std::string_view to_string(CanopenRole r) {
  switch (r) {
    case CanopenRole::None:
      return "none";
    case CanopenRole::Master:
      return "master";
    case CanopenRole::Slave:
      return "slave";
  }
  return "?";
}

std::uint8_t UserPrm::flags_byte() const {
  return static_cast<std::uint8_t>(
      (comm_window ? kFlagCommWindow : 0) | (send_rtr ? 0 : kFlagNoRtr) |
      (canopen_slave ? kFlagCanopenSlave : 0) | (canopen_master ? kFlagCanopenMaster : 0) |
      (start_frame ? kFlagStartFrame : 0) | (page_mode ? kFlagPageMode : 0));
}

std::uint8_t UserPrm::diag_byte() const {
  return static_cast<std::uint8_t>((can_diagnosis ? kDiagCanDiagnosis : 0) |
                                   (rx_counter ? kDiagRxCounter : 0) |
                                   (tx_counter ? kDiagTxCounter : 0));
}

std::variant<UserPrm, dp::PrmFault> decode_user_prm(std::span<const std::uint8_t> t) {
  using dp::PrmFault;
  if (t.size() != kSetPrmLen) {
    return PrmFault{static_cast<std::uint8_t>(std::min(t.size(), kSetPrmLen)), 0};
  }
  UserPrm p;
  // docs/dp-slave.md "User parameters" table, in telegram byte order.
  if (t[kPrmReserved7] != 0) return PrmFault{kPrmReserved7, 0x00};
  if (t[kPrmBitrate] > kBitrateMax) return PrmFault{kPrmBitrate, kBitrateDefault};
  p.bitrate_index = t[kPrmBitrate];

  const std::uint8_t flags = t[kPrmFlags];
  std::uint8_t offending = flags & kFlagsReserved;
  const bool slave = flags & kFlagCanopenSlave;
  const bool master = flags & kFlagCanopenMaster;
  // manual table 5.1.2: never CANopen-Slave and -Master together; Page-Mode only without either.
  if (slave && master)
    offending |= kFlagCanopenSlave | kFlagCanopenMaster;
  else if ((flags & kFlagPageMode) && (slave || master))
    offending |= kFlagPageMode;
  if (offending) return PrmFault{kPrmFlags, static_cast<std::uint8_t>(flags & ~offending)};
  p.comm_window = flags & kFlagCommWindow;
  p.send_rtr = !(flags & kFlagNoRtr);
  p.canopen_slave = slave;
  p.canopen_master = master;
  p.start_frame = flags & kFlagStartFrame;
  p.page_mode = flags & kFlagPageMode;

  const std::uint8_t module_id = t[kPrmModuleId];
  if (module_id < 1 || module_id > 127) return PrmFault{kPrmModuleId, 1};
  p.module_id = module_id;

  const std::uint8_t diag = t[kPrmDiagFlags];
  constexpr std::uint8_t kKnown = kDiagCanDiagnosis | kDiagRxCounter | kDiagTxCounter;
  if (diag & ~kKnown) return PrmFault{kPrmDiagFlags, static_cast<std::uint8_t>(diag & kKnown)};
  p.can_diagnosis = diag & kDiagCanDiagnosis;
  p.rx_counter = diag & kDiagRxCounter;
  p.tx_counter = diag & kDiagTxCounter;

  if (t[kPrmReserved12] != 0) return PrmFault{kPrmReserved12, 0x00};
  p.wakeup_s = t[kPrmWakeup];  // any value valid (255 = keep stored)
  p.sync_ms = static_cast<std::uint16_t>((t[kPrmSyncHigh] << 8) | t[kPrmSyncLow]);
  return p;
}

std::array<std::uint8_t, kUserPrmLen> encode_user_prm(const UserPrm& p) {
  return {0x00,
          p.bitrate_index,
          p.flags_byte(),
          p.module_id,
          p.diag_byte(),
          0x00,
          p.wakeup_s,
          static_cast<std::uint8_t>(p.sync_ms >> 8),
          static_cast<std::uint8_t>(p.sync_ms & 0xFF)};
}

std::array<std::uint8_t, kSetPrmLen> make_set_prm(const UserPrm& p, std::uint16_t watchdog_ms) {
  std::array<std::uint8_t, kSetPrmLen> t{};
  dp::PrmStd s;
  s.ident_number = kIdentNumber;
  if (watchdog_ms > 0) {
    // 10 ms × f1 × f2 >= watchdog_ms, smallest factors first.
    const unsigned units = (watchdog_ms + 9u) / 10u;
    s.station_status = dp::kPrmWdOn;
    s.wd_fact_1 = static_cast<std::uint8_t>(std::min(units, 255u));
    s.wd_fact_2 = static_cast<std::uint8_t>(std::max(1u, (units + 254u) / 255u));
  }
  dp::encode_prm_std(s, t);
  const auto user = encode_user_prm(p);
  std::copy(user.begin(), user.end(), t.begin() + dp::kPrmStdLen);
  return t;
}

}  // namespace candp2::gw
