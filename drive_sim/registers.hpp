// The Unitek DS/BAMOCAR REGID register list: one row per REGID 0x00..0xFF with access type, data
// width and default value, as printed in the register list of the Unitek short description FW 378
// (the table "RegNr Typ Hex value Decimal Label (intern name) Description" at its end). Pure data,
// no behaviour.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace candp2::drive {

// The list's "Typ" column: RO read-only actual value, RW parameter (saved by the EEPROM write
// 0x84), SP special/volatile set point, FN function trigger, UK unknown.
enum class Access : std::uint8_t { RO, RW, SP, FN, UK };

// The width follows the printed default: 4 hex digits = 16-bit, 8 hex digits = 32-bit
// (Unitek CAN manual "DLC-Bits": 16-bit data travels in 3/4-byte frames, 32-bit in 5/6-byte ones).
enum class Width : std::uint8_t { W16 = 16, W32 = 32 };

struct RegisterInfo {
  std::uint8_t regid;
  Access access;
  Width width;
  std::uint32_t default_value;   // zero-extended for 16-bit registers
  std::string_view name;         // the list's "(intern name)", truncated as printed
  std::string_view label;        // the list's "Label" (NDrive display name)
  std::string_view description;  // the list's "Description"
  std::uint16_t source_line;     // line of this row in the list (the citation)
};

// All 256 rows, indexed by REGID.
std::span<const RegisterInfo, 256> register_table();
inline const RegisterInfo& register_info(std::uint8_t regid) {
  return register_table()[regid];
}

std::string_view to_string(Access access);

// REGIDs the simulator gives a meaning to. Names follow the register list's intern names.
namespace reg {
inline constexpr std::uint8_t kIActual = 0x20;          // I_IST
inline constexpr std::uint8_t kSpeedActual = 0x30;      // SPEED_ACTUAL, ±32767 = ±100 %
inline constexpr std::uint8_t kSpeedCmd = 0x31;         // SPEED_CMD (manual example 3)
inline constexpr std::uint8_t kSpeedRef = 0x32;         // SPEED_REF, command after ramp
inline constexpr std::uint8_t kSpeedLimit = 0x34;       // SPEED_LIMIT
inline constexpr std::uint8_t kAccRamp = 0x35;          // SPEED_DELTAMA accel (manual example 6)
inline constexpr std::uint8_t kRead = 0x3D;             // READ (manual examples 8, 10)
inline constexpr std::uint8_t kSpeedClipNeg = 0x3E;     // SPEED_CLIP_NE
inline constexpr std::uint8_t kSpeedClipPos = 0x3F;     // SPEED_CLIP_PO
inline constexpr std::uint8_t kStatus = 0x40;           // STATUS / KERN_STATUS (example 8)
inline constexpr std::uint8_t kMode = 0x51;             // MODE (examples 2, 9)
inline constexpr std::uint8_t kStatusMask = 0x52;       // STATUS_MASK (example 9-1)
inline constexpr std::uint8_t kCanIdRx = 0x68;          // CAN_ID_RX (example 1)
inline constexpr std::uint8_t kCanIdTx = 0x69;          // CAN_ID_TX
inline constexpr std::uint8_t kPosActual = 0x6D;        // POS_ACTUAL
inline constexpr std::uint8_t kPosDest = 0x6E;          // POS_DEST (example 4)
inline constexpr std::uint8_t kPosError = 0x70;         // POS_ERR
inline constexpr std::uint8_t kPosRefOffset = 0x72;     // POS_REF_OFFSE
inline constexpr std::uint8_t kRefStart = 0x78;         // FUN_REF_START (example 12)
inline constexpr std::uint8_t kPosWindow = 0x79;        // POS_WINDOW
inline constexpr std::uint8_t kParaRead = 0x83;         // FUN_PARAREAD
inline constexpr std::uint8_t kParaWrite = 0x84;        // FUN_PARAWRITE, EEPROM write (example 7)
inline constexpr std::uint8_t kErrCancel = 0x8E;        // FUN_ERRCANCEL
inline constexpr std::uint8_t kErrBitmap = 0x8F;        // ERR_BITMAP1 (example 9.2)
inline constexpr std::uint8_t kTorqueCmd = 0x90;        // TORQUE_SETPOI (example 5)
inline constexpr std::uint8_t kPosCommand = 0x91;       // POS_COMMAND
inline constexpr std::uint8_t kTorqueOut = 0xA0;        // TORQUE_OUT
inline constexpr std::uint8_t kSpeedActualFilt = 0xA8;  // SPEED_ACTUAL_ (filtered)
inline constexpr std::uint8_t kEmergencyRamp = 0xC7;    // R-Lim: emergency/limit-switch ramp
inline constexpr std::uint8_t kSpeedRpmMax = 0xC8;      // SPEED_RPM_MAX: rpm at 100 % speed
inline constexpr std::uint8_t kDefineDac = 0xDC;        // DEFINE_DAC (FW 378 note 3)
inline constexpr std::uint8_t kReady = 0xE2;            // O_BT_B, device ready (example 11)
inline constexpr std::uint8_t kGo = 0xE3;               // O_GO, internal run
inline constexpr std::uint8_t kLimitPlus = 0xE4;        // I_END1
inline constexpr std::uint8_t kLimitMinus = 0xE5;       // I_END2
inline constexpr std::uint8_t kEnableInput = 0xE8;      // I_FRG, hardware enable (example 11)
inline constexpr std::uint8_t kDecRamp = 0xED;          // SPEED_DELTAMA decel (example 11)
inline constexpr std::uint8_t kNoFault = 0xEF;          // O_NOFAULT
inline constexpr std::uint8_t kBrake = 0xF2;            // VO_BRAKE
inline constexpr std::uint8_t kInTolerance = 0xF4;      // VO_TOLER (example 12)
inline constexpr std::uint8_t kLessN0 = 0xF5;           // VO_Less_N0, speed < 1 %
}  // namespace reg

}  // namespace candp2::drive
