// Set_Prm user parameters of the CAN-DP/2 (manual §5.1.2, GSD ExtUserPrmData 1-12,
// docs/dp-slave.md "User parameters"): telegram bytes 7..15 (Max_User_Prm_Data_Len = 9). Pure
// decode/validate/encode.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::gw {

inline constexpr std::uint16_t kIdentNumber = 0x04A4;  // manual §3.4.1.5 / GSD Ident_Number
inline constexpr std::size_t kUserPrmLen = 9;          // GSD Max_User_Prm_Data_Len
inline constexpr std::size_t kSetPrmLen = 16;          // 7 standard + 9 user bytes
inline constexpr std::array<std::uint8_t, 2> kExtDiagHeader = {0x05, 0x04};  // manual table 3.4.5

// Telegram byte positions (docs/dp-slave.md "User parameters").
inline constexpr std::size_t kPrmReserved7 = 7;
inline constexpr std::size_t kPrmBitrate = 8;
inline constexpr std::size_t kPrmFlags = 9;
inline constexpr std::size_t kPrmModuleId = 10;
inline constexpr std::size_t kPrmDiagFlags = 11;
inline constexpr std::size_t kPrmReserved12 = 12;
inline constexpr std::size_t kPrmWakeup = 13;
inline constexpr std::size_t kPrmSyncHigh = 14;
inline constexpr std::size_t kPrmSyncLow = 15;

// Byte 9 flags (GSD ExtUserPrmData 2-7).
inline constexpr std::uint8_t kFlagCommWindow = 0x80;
inline constexpr std::uint8_t kFlagNoRtr =
    0x10;  // RTR-Frames: 0 = send RTR frames, 1 = don't (PrmText 3)
inline constexpr std::uint8_t kFlagCanopenSlave = 0x08;
inline constexpr std::uint8_t kFlagCanopenMaster = 0x04;
inline constexpr std::uint8_t kFlagStartFrame = 0x02;
inline constexpr std::uint8_t kFlagPageMode = 0x01;
inline constexpr std::uint8_t kFlagsReserved = 0x60;
// Byte 11 flags (GSD ExtUserPrmData 11-12, Tx-Counter added by this product's GSD).
inline constexpr std::uint8_t kDiagCanDiagnosis = 0x01;
inline constexpr std::uint8_t kDiagRxCounter = 0x02;
inline constexpr std::uint8_t kDiagTxCounter = 0x04;

inline constexpr std::uint8_t kBitrateMax = 13;
inline constexpr std::uint8_t kBitrateDefault = 6;  // 125 kbit/s, GSD default
inline constexpr std::uint8_t kWakeupKeep = 255;    // manual table 5.1.3
inline constexpr std::uint16_t kSyncKeep = 65535;   // manual table 5.1.4

// CAN bit rate for index 0..13 (manual table 5.1.1), bit/s.
inline constexpr std::array<std::uint32_t, 14> kBitrates = {1000000, 666600, 500000, 333300, 250000,
                                                            166000,  125000, 100000, 66600,  50000,
                                                            33300,   20000,  12500,  10000};

// The bit rate of index 0..13 in bit/s (manual table 5.1.1); nullopt outside the table. The one
// checked look-up of kBitrates.
inline std::optional<std::uint32_t> bitrate_bps(std::uint8_t index) {
  if (index >= kBitrates.size()) return std::nullopt;
  return kBitrates[index];
}

// The bit rates as manual table 5.1.1 (and the GSD's PrmText 1) names them: "1000k", "666.6k",
// "500k", ..., "10k"; "?" for an index outside the table.
std::string_view bitrate_name(std::uint8_t index);
// The same as text for logs, pages and reports: "666.6 kbit/s"; "?" outside the table.
std::string bitrate_text(std::uint8_t index);
// Any bit rate in bit/s (a SocketCAN interface's): a table 5.1.1 rate by its name
// ("666.6 kbit/s" for 666600), else "800 kbit/s" for whole kbit/s, else "83333 bit/s".
std::string bitrate_text_bps(std::uint32_t bps);

enum class CanopenRole : std::uint8_t { None, Master, Slave };
std::string_view to_string(CanopenRole r);

struct UserPrm {
  std::uint8_t bitrate_index = kBitrateDefault;
  bool comm_window = false;
  bool send_rtr = true;  // flag bit 4 clear
  bool canopen_slave = false;
  bool canopen_master = false;
  bool start_frame = false;
  bool page_mode = false;
  std::uint8_t module_id = 1;
  bool can_diagnosis = false;
  bool rx_counter = false;
  bool tx_counter = false;
  std::uint8_t wakeup_s = kWakeupKeep;
  std::uint16_t sync_ms = kSyncKeep;

  CanopenRole role() const {
    return canopen_master ? CanopenRole::Master
                          : (canopen_slave ? CanopenRole::Slave : CanopenRole::None);
  }
  std::uint8_t flags_byte() const;
  std::uint8_t diag_byte() const;
  friend bool operator==(const UserPrm&, const UserPrm&) = default;
};

// Validates telegram bytes 7..15 of a 16-byte Set_Prm (the standard part is the DP slave's job).
// Checks run in telegram byte order; the first faulty byte is reported with a correct value.
std::variant<UserPrm, dp::PrmFault> decode_user_prm(std::span<const std::uint8_t> telegram);

// The 9 user bytes (telegram bytes 7..15).
std::array<std::uint8_t, kUserPrmLen> encode_user_prm(const UserPrm& p);

// A whole 16-byte Set_Prm telegram: standard part with Ident 0x04A4 and the given watchdog.
std::array<std::uint8_t, kSetPrmLen> make_set_prm(const UserPrm& p, std::uint16_t watchdog_ms = 0);

}  // namespace candp2::gw
