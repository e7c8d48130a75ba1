// What the CAN-DP/2 makes of one Chk_Cfg entry on its own: the reading `candp2 gsd` shows for each
// module line of a GSD and checks it by (docs/gsd.md, manual §7), and `candp2 validate` warns
// about (docs/slots.md "Chk_Cfg slots"). Every answer comes from gw::decode_slots, the slot rules
// the emulated gateway applies (manual §5.2, §5.3.2, §6.4, §7; docs/page-mode.md "Segments"), so a
// module check and the gateway can never disagree. Pure: bytes in, text out.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "gateway/slot_config.hpp"
#include "gateway/user_prm.hpp"

namespace candp2::gw {

// gw::decode_slots applied to a small configuration around the entry, because a single entry is
// rarely a valid configuration on its own (manual §5.1.4: at least one output; §5.3.2: the
// Communication Window needs both directions; table 6.4.1: Page-Mode segments). The contexts are
// tried in this order and the first one the gateway accepts describes the entry:
//   1. default parameters, the entry, then the manual §5.1.4 dummy output (83 00 07 F8 00);
//   2. the same with Rx-/Tx-Counter on (a 9-byte slot, manual §5.1.2), the dummy 2 bytes long
//      (83 01 07 F8 00: with the counter on, 1 byte would be the counter alone);
//   3./4. Communication Window flag on, the entry, then a CW input / CW output (manual §5.3.2);
//   5. Page-Mode on, a 32-byte input and a 32-byte output segment, then the entry (as the last
// segment of its direction, which may be shorter; manual table 6.4.1,
// docs/page-mode.md "Segments"). When none accepts, the fault of context 1 is the answer.
struct EntryReading {
  std::optional<Slot> slot;                    // the gateway's reading when a context accepted it
  std::string condition;                       // "" or e.g. "Page-Mode on" (contexts 2..5)
  std::optional<std::uint16_t> ignored_cycle;  // cycle bytes on an input
                                               // (docs/slots.md "Chk_Cfg slots")
  std::optional<std::uint8_t> fault_code;      // Cfg fault code of context 1 when rejected
  std::string text;                            // "Rx 11-bit ID 0x181, 8 bytes, form 0x00" or ""
  std::optional<std::string> problem;  // "Cfg fault code 3: wrong length (...)" when rejected
};
// `entry`: the bytes of one identifier entry (identifier, length bytes, manufacturer bytes), as
// dp::decode_chk_cfg delimits it.
EntryReading read_cfg_entry(std::span<const std::uint8_t> entry);

// "Tx 11-bit ID 0x203, 6 bytes, form 0x00, cycle 100 ms" for a slot of gw::decode_slots.
std::string describe_slot(const Slot& s);

// The cycle an input slot's comment bytes carry although the gateway ignores it
// (docs/slots.md "Chk_Cfg slots": "cycle bytes on an input slot are ignored, the validator warns"):
// the same length and comment bytes decoded by gw::decode_slots as an output slot. nullopt for
// other slots, for no cycle bytes and for cycle 0.
std::optional<std::uint16_t> ignored_input_cycle(const Slot& s, const UserPrm& prm);

}  // namespace candp2::gw
