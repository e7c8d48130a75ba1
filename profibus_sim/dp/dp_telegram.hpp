// PROFIBUS-DP (DP-V0, EN 50170 / IEC 61158) telegram contents as the slave sees them:
// the standard part of Set_Prm, the Chk_Cfg identifier bytes, the Slave_Diag header.
// Pure decode/encode, no I/O. Names follow the standard's abbreviations.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace candp2::dp {

// ---- Set_Prm (SAP 61) ----------------------------------------------------------------------
inline constexpr std::size_t kPrmStdLen = 7;  // Station_Status, WD_Fact_1, WD_Fact_2, min_TSDR,
                                              // Ident_Number high/low, Group_Ident

// Station_Status bits of the Set_Prm telegram (EN 50170 vol. 2, DDLM_Set_Prm).
inline constexpr std::uint8_t kPrmWdOn = 0x08;
inline constexpr std::uint8_t kPrmFreezeReq = 0x10;
inline constexpr std::uint8_t kPrmSyncReq = 0x20;
inline constexpr std::uint8_t kPrmUnlockReq = 0x40;
inline constexpr std::uint8_t kPrmLockReq = 0x80;

struct PrmStd {
  std::uint8_t station_status = 0;
  std::uint8_t wd_fact_1 = 1;
  std::uint8_t wd_fact_2 = 1;
  std::uint8_t min_tsdr = 0;
  std::uint16_t ident_number = 0;
  std::uint8_t group_ident = 0;

  bool wd_on() const { return station_status & kPrmWdOn; }
  bool freeze_req() const { return station_status & kPrmFreezeReq; }
  bool sync_req() const { return station_status & kPrmSyncReq; }
  // Watchdog time: 10 ms × WD_Fact_1 × WD_Fact_2 (docs/dp-slave.md).
  std::uint32_t watchdog_ms() const { return 10u * wd_fact_1 * wd_fact_2; }
};

// Needs at least kPrmStdLen bytes.
std::optional<PrmStd> decode_prm_std(std::span<const std::uint8_t> telegram);
void encode_prm_std(const PrmStd& p, std::span<std::uint8_t> out);  // writes 7 bytes
// The telegram as a class 1 master sends it to parameterize a slave: Lock_Req = 1, Unlock_Req = 0
// whatever the configured Station_Status says (IEC 61158-6-3; docs/dp-slave.md "Lock").
std::vector<std::uint8_t> with_lock_req(std::span<const std::uint8_t> telegram);

// ---- Chk_Cfg (SAP 62) identifier bytes --------------------------------------------------------
// Special identifier format (bits 5-4 = 00): bits 7-6 = 00 empty / 01 input / 10 output /
// 11 output+input, bits 3-0 = number of manufacturer ("comment") bytes; then one length byte per
// direction (output first) with bit7 consistency, bit6 word unit, bits 5-0 = count-1; then the
// manufacturer bytes. An empty slot (00) has no length byte.
// General identifier format (bits 5-4 != 00): bit7 consistency, bit6 word unit, bits 5-4 =
// 01 input / 10 output / 11 input+output, bits 3-0 = count-1; no manufacturer bytes.
enum class CfgIo : std::uint8_t { Empty, Input, Output, InputOutput };

struct CfgEntry {
  std::size_t offset = 0;  // position of the identifier byte in the Chk_Cfg data
  bool special = false;    // special identifier format
  CfgIo io = CfgIo::Empty;
  bool consistent = false;    // consistency over the whole length
  bool words = false;         // unit = word (2 bytes)
  std::uint8_t count = 0;     // number of units (1..64); for InputOutput the output count
  std::uint8_t in_count = 0;  // InputOutput only: the input count
  bool in_words = false;
  std::vector<std::uint8_t> manufacturer;  // the comment bytes (special format only)

  std::size_t out_bytes() const;
  std::size_t in_bytes() const;
  friend bool operator==(const CfgEntry&, const CfgEntry&) = default;
};

struct CfgDecodeError {
  std::size_t slot = 0;    // index of the entry that is truncated
  std::size_t offset = 0;  // byte offset where data ran out
  std::string message;
};

struct CfgDecodeResult {
  std::vector<CfgEntry> entries;
  std::optional<CfgDecodeError> error;
};

CfgDecodeResult decode_chk_cfg(std::span<const std::uint8_t> cfg);
// Encodes entries in the special format when `special` (or manufacturer bytes present), else
// general.
std::vector<std::uint8_t> encode_chk_cfg(std::span<const CfgEntry> entries);

// Builders for the common special-format slots (manual §7): e.g. output(6, true, {0x02,0x03,0x00})
// gives 0x83 0x85 0x02 0x03 0x00.
CfgEntry special_input(std::uint8_t bytes, bool consistent, std::vector<std::uint8_t> comment);
CfgEntry special_output(std::uint8_t bytes, bool consistent, std::vector<std::uint8_t> comment);

// ---- Slave_Diag (SAP 60) -----------------------------------------------------------------------
// Station_Status_1 (manual table 3.4.3)
inline constexpr std::uint8_t kDiag1StationNonExistent = 0x01;  // master side only
inline constexpr std::uint8_t kDiag1StationNotReady = 0x02;
inline constexpr std::uint8_t kDiag1CfgFault = 0x04;
inline constexpr std::uint8_t kDiag1ExtDiag = 0x08;
inline constexpr std::uint8_t kDiag1NotSupported = 0x10;
inline constexpr std::uint8_t kDiag1InvalidSlaveResponse = 0x20;  // master side only
inline constexpr std::uint8_t kDiag1PrmFault = 0x40;
inline constexpr std::uint8_t kDiag1MasterLock = 0x80;  // master side only
// Station_Status_2 (manual table 3.4.4)
inline constexpr std::uint8_t kDiag2PrmReq = 0x01;
inline constexpr std::uint8_t kDiag2StatDiag = 0x02;
inline constexpr std::uint8_t kDiag2AlwaysOne = 0x04;
inline constexpr std::uint8_t kDiag2WdOn = 0x08;
inline constexpr std::uint8_t kDiag2FreezeMode = 0x10;
inline constexpr std::uint8_t kDiag2SyncMode = 0x20;
inline constexpr std::uint8_t kDiag2Deactivated = 0x80;
// Station_Status_3 (IEC 61158-6-3): more Ext_Diag_Data than fit into the diagnosis.
inline constexpr std::uint8_t kDiag3ExtDiagOverflow = 0x80;
// Diagnosis byte 3 before any master parameterized the slave.
inline constexpr std::uint8_t kNoMaster = 0xFF;

// The names of the station status bits (bytes 0..2) as the manual's tables 3.4.3-3.4.5 and
// IEC 61158-6-3 write them: the one table the register map, the HTTP face and the logs use. Bit 2
// of byte 1 (always 1) and the reserved bit 6 have no name.
struct DiagBitName {
  std::uint8_t byte;
  std::uint8_t mask;
  const char* name;
};
inline constexpr DiagBitName kDiagBitNames[] = {
    {0, kDiag1StationNonExistent, "Station_Non_Existent"},
    {0, kDiag1StationNotReady, "Station_Not_Ready"},
    {0, kDiag1CfgFault, "Cfg_Fault"},
    {0, kDiag1ExtDiag, "Ext_Diag"},
    {0, kDiag1NotSupported, "Not_Supported"},
    {0, kDiag1InvalidSlaveResponse, "Invalid_Slave_Response"},
    {0, kDiag1PrmFault, "Prm_Fault"},
    {0, kDiag1MasterLock, "Master_Lock"},
    {1, kDiag2PrmReq, "Prm_Req"},
    {1, kDiag2StatDiag, "Stat_Diag"},
    {1, kDiag2WdOn, "WD_On"},
    {1, kDiag2FreezeMode, "Freeze_Mode"},
    {1, kDiag2SyncMode, "Sync_Mode"},
    {1, kDiag2Deactivated, "Deactivated"},
    {2, kDiag3ExtDiagOverflow, "Ext_Diag_Overflow"},
};

}  // namespace candp2::dp
