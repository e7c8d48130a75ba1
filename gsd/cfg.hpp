// Module configuration bytes (the Chk_Cfg identifier bytes a GSD Module line lists).
//
// PROFIBUS-DP identifier formats (IEC 61158-6-3, Chk_Cfg; manual §7 quotes them):
//  - general format (bits 5-4 != 00): bits 5-4 = 01 input / 10 output / 11 input+output,
//    bit 6 word structure, bit 7 consistency over the whole length, bits 3-0 = length-1;
//  - special format (bits 5-4 == 00): bits 7-6 = 00 no data / 01 one input length byte follows /
//    10 one output length byte follows / 11 an output and then an input length byte follow;
//    bits 3-0 = number m of manufacturer-specific bytes (0..14) that follow the length bytes.
//    A length byte: bit 7 consistency, bit 6 word structure, bits 5-0 = count-1.
// Pure functions; no dependency on the gateway library.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace candp2::gsd {

struct CfgEntry {
  bool special = false;    // special identifier format
  std::size_t offset = 0;  // index of the identifier byte in the config bytes
  std::size_t size = 0;    // bytes the entry occupies in the config bytes
  std::uint8_t identifier = 0;
  bool input = false, output = false;
  std::size_t input_len = 0, output_len = 0;  // in bytes (words already doubled)
  bool input_words = false, output_words = false;
  bool input_consistent = false, output_consistent = false;
  std::vector<std::uint8_t> manufacturer;  // special format: the m manufacturer bytes
};

struct CfgDecode {
  std::vector<CfgEntry> entries;
  std::size_t input_len = 0, output_len = 0;  // totals over all entries
  std::optional<std::string> error;           // first malformed byte, decoding stopped there
};

CfgDecode decode_config(std::span<const std::uint8_t> config);

// "input 16 bytes consistent, manufacturer bytes FF EF 00 00 00"
std::string describe(const CfgEntry& e);

// CAN-DP/2 meaning of an entry (manual §5.2, §5.3, §6.4, §7; emulator-spec §2, §6.1): slot kind,
// CAN identifier, form byte, cycle, or the Cfg fault code the gateway would report.
inline constexpr std::int64_t kCanDp2Ident = 0x04A4;  // manual §4: Ident_Number of the CAN-DP/2

struct CanDp2Slot {
  std::string text;                    // "Rx 11-bit ID 0x181, form 0x00"
  std::optional<std::string> problem;  // why the gateway would reject it (Cfg fault code)
};
CanDp2Slot describe_candp2(const CfgEntry& e);

// A module line holding the single byte 0x00 is the configuration tools' "universal module":
// type, length and comment bytes are entered in the tool (manual §5.2, §7).
bool is_universal_module(std::span<const std::uint8_t> config);

}  // namespace candp2::gsd
