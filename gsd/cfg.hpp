// Module configuration bytes (the Chk_Cfg identifier bytes a GSD Module line lists) and what the
// CAN-DP/2 makes of them.
//
// There is one decoder for each: the identifier formats are decoded by dp::decode_chk_cfg
// (profibus_sim/dp/dp_telegram.hpp, IEC 61158-6-3 Chk_Cfg; manual §7 quotes the formats), the
// CAN-DP/2 slot rules are applied by gw::decode_slots (gateway/slot_config.hpp, manual §5.2,
// §5.3.2, §6.4, §7; docs/slots.md "Chk_Cfg slots", docs/page-mode.md "Segments"). This header only
// wraps them for GSD modules, so the GSD module check and the gateway can never disagree.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gateway/slot_config.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::gsd {

// One identifier entry of a module's configuration bytes.
struct CfgEntry {
  dp::CfgEntry decoded;             // as dp::decode_chk_cfg decoded it
  std::vector<std::uint8_t> bytes;  // the entry's own configuration bytes
  std::size_t offset = 0;           // index of the identifier byte in the config bytes
  std::size_t size = 0;             // bytes the entry occupies (== bytes.size())

  // Views of `decoded` (lengths in bytes, words already doubled).
  bool special() const { return decoded.special; }
  bool input() const;
  bool output() const;
  std::size_t input_len() const { return decoded.in_bytes(); }
  std::size_t output_len() const { return decoded.out_bytes(); }
  const std::vector<std::uint8_t>& manufacturer() const { return decoded.manufacturer; }
};

struct CfgDecode {
  std::vector<CfgEntry> entries;
  std::size_t input_len = 0, output_len = 0;  // totals over all entries
  std::optional<std::string> error;           // a truncated entry; decoding stopped there
};

// dp::decode_chk_cfg with each entry's bytes, offsets and the totals; a truncated entry becomes
// "byte 1 (0x83): Chk_Cfg truncated: manufacturer bytes missing".
CfgDecode decode_config(std::span<const std::uint8_t> config);

// "output 4 bytes consistent, input 10 bytes consistent, manufacturer bytes FF EF 00 00 00"
std::string describe(const CfgEntry& e);

inline constexpr std::int64_t kCanDp2Ident = gw::kIdentNumber;  // manual §4: 0x04A4

// What the CAN-DP/2 makes of one module entry: gw::decode_slots applied to a small configuration
// around the entry, because a single entry is rarely a valid configuration on its own (manual
// §5.1.4: at least one output; §5.3.2: the Communication Window needs both directions; table
// 6.4.1: Page-Mode segments). The contexts are tried in this order and the first one the gateway
// accepts describes the entry:
//   1. default parameters, the entry, then the manual §5.1.4 dummy output (83 00 07 F8 00);
//   2. the same with Rx-/Tx-Counter on (a 9-byte slot, manual §5.1.2), the dummy 2 bytes long
//      (83 01 07 F8 00: with the counter on, 1 byte would be the counter alone);
//   3./4. Communication Window flag on, the entry, then a CW input / CW output (manual §5.3.2);
//   5. Page-Mode on, a 32-byte input and a 32-byte output segment, then the entry (as the last
// segment of its direction, which may be shorter; manual table 6.4.1,
// docs/page-mode.md "Segments"). When none accepts, the fault of context 1 is the answer.
struct CanDp2Slot {
  std::optional<gw::Slot> slot;                // the gateway's reading when a context accepted it
  std::string condition;                       // "" or e.g. "Page-Mode on" (contexts 2..5)
  std::optional<std::uint16_t> ignored_cycle;  // cycle bytes on an input
                                               // (docs/slots.md "Chk_Cfg slots")
  std::optional<std::uint8_t> fault_code;      // Cfg fault code of context 1 when rejected
  std::string text;                            // "Rx 11-bit ID 0x181, 8 bytes, form 0x00" or ""
  std::optional<std::string> problem;  // "Cfg fault code 3: wrong length (...)" when rejected
};
CanDp2Slot describe_candp2(const CfgEntry& e);

// "Tx 11-bit ID 0x203, 6 bytes, form 0x00, cycle 100 ms" for a slot of gw::decode_slots.
std::string describe_slot(const gw::Slot& s);

// The cycle an input slot's comment bytes carry although the gateway ignores it
// (docs/slots.md "Chk_Cfg slots": "cycle bytes on an input slot are ignored, the validator warns"):
// the same length and comment bytes decoded by gw::decode_slots as an output slot. nullopt for
// other slots, for no cycle bytes and for cycle 0.
std::optional<std::uint16_t> ignored_input_cycle(const gw::Slot& s, const gw::UserPrm& prm);

// A module line holding the single byte 0x00 is the configuration tools' "universal module":
// type, length and comment bytes are entered in the tool (manual §5.2, §7).
bool is_universal_module(std::span<const std::uint8_t> config);

}  // namespace candp2::gsd
