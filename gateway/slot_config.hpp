// Chk_Cfg → gateway slots (manual §5.2, §5.3.2, §6.4.2, §7; docs/slots.md "Chk_Cfg slots",
// docs/page-mode.md "Segments"). Pure: the decoded configuration or the Cfg fault the real gateway
// reports (diag 3E slot code).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <variant>
#include <vector>

#include "can/frame.hpp"
#include "gateway/page/page_format.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::gw {

// Cfg fault codes, diag byte 10 after 0x3E (manual §3.4.2 list; 7-10 docs/slots.md "Chk_Cfg slots"
// additions).
enum CfgCode : std::uint8_t {
  kCfgWrongIoType = 1,
  kCfgWrongUnit = 2,
  kCfgWrongLength = 3,
  kCfgIdentifierMissing = 4,
  kCfgFormatMissing = 5,
  kCfgWrongIdentifier = 6,
  kCfgLimitsExceeded = 7,
  kCfgCommWindow = 8,
  kCfgPageLayout = 9,
  kCfgNoOutput = 10,
};
std::string_view cfg_code_text(std::uint8_t code);

// manual §2.2 and GSD: Max_Module 48, Max_Input_Len 244, Max_Output_Len 244, Max_Data_Len 300.
inline constexpr std::size_t kMaxSlots = 48;
inline constexpr std::size_t kMaxInputLen = 244;
inline constexpr std::size_t kMaxOutputLen = 244;
inline constexpr std::size_t kMaxDataLen = 300;
inline constexpr std::size_t kCommWindowLen = 16;         // manual §5.3.1
inline constexpr std::uint16_t kCommWindowIdHigh = 0xFF;  // comment bytes FF EF (manual §5.3.2)
inline constexpr std::uint16_t kCommWindowIdLow = 0xEF;
inline constexpr std::uint32_t kDummyTxId = 0x07F8;         // manual §5.1.4: output without CAN id
inline constexpr std::uint32_t kIdBit29 = page::kIdFlag29;  // manual §5.2.1: flags a 29-bit id
inline constexpr std::size_t kSegmentLen = page::kSegmentLen;  // manual table 6.4.1

enum class SlotKind : std::uint8_t { Rx, Tx, CwIn, CwOut, SegmentIn, SegmentOut };
std::string_view to_string(SlotKind k);

struct Slot {
  std::size_t index = 0;  // slot number (GSD Module_Offset 0)
  SlotKind kind = SlotKind::Rx;
  std::size_t offset = 0;    // byte offset in the DP input (Rx/CwIn/SegmentIn) or output image
  std::size_t length = 0;    // bytes in the DP image (incl. the counter byte)
  std::size_t data_len = 0;  // CAN data bytes (length without the Rx/Tx-Counter byte)
  bool counter = false;      // the last byte is the Rx- or Tx-Counter
  bool consistent = false;
  std::optional<can::Ident> id;  // none for the 0x07F8 dummy, CW and segments
  std::uint8_t form = 0;
  std::uint16_t cycle_ms = 0;    // 0 = no cyclic send
  std::uint16_t cw_sync_ms = 0;  // CW comment bytes 4-5; 0 = not given
  std::vector<std::uint8_t> comment;

  bool is_input() const {
    return kind == SlotKind::Rx || kind == SlotKind::CwIn || kind == SlotKind::SegmentIn;
  }
};

struct SlotConfig {
  std::vector<Slot> slots;
  std::size_t input_len = 0;
  std::size_t output_len = 0;
  std::optional<std::size_t> cw_in;   // slot index
  std::optional<std::size_t> cw_out;  // slot index
  bool page_mode = false;
};

std::variant<SlotConfig, dp::CfgFault> decode_slots(std::span<const std::uint8_t> cfg,
                                                    const UserPrm& prm);

// Parses a SIMATIC comment field ("02,89,B8" / "FF EF 00 00 00" / "03,09,B8,"): hex bytes separated
// by commas or spaces. Returns nullopt and sets *error for malformed text.
std::optional<std::vector<std::uint8_t>> parse_comment(std::string_view text, std::string* error);

}  // namespace candp2::gw
