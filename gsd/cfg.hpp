// Module configuration bytes (the Chk_Cfg identifier bytes a GSD Module line lists).
//
// The identifier formats are decoded by dp::decode_chk_cfg (profibus_sim/dp/dp_telegram.hpp,
// IEC 61158-6-3 Chk_Cfg; manual §7 quotes the formats); this header only wraps it for GSD modules.
// What one device makes of an entry is that device's business: a DeviceReader the caller passes.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

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

// One device's own reading of its module entries, for the device the caller knows (the CAN-DP/2's
// slot rules: tools/candp2/gsd_reading.hpp). The GSD library knows no device: check() and summary()
// apply the reader to every module entry of a GSD whose Ident_Number is `ident`.
struct EntryVerdict {
  std::string text;                    // the device's reading, shown by summary()
  std::optional<std::string> problem;  // set when the device rejects the entry
};
struct DeviceReader {
  std::int64_t ident = 0;  // the Ident_Number it applies to
  std::string device;      // the device as findings and summary name it: "CAN-DP/2"
  std::string rules;       // where its rules are written, cited by a finding: "manual §7, ..."
  std::function<EntryVerdict(const CfgEntry&)> read;
  bool applies(std::optional<std::int64_t> ident_number) const {
    return read && ident_number == ident;
  }
};

// A module line holding the single byte 0x00 is the configuration tools' "universal module":
// type, length and comment bytes are entered in the tool (manual §5.2, §7).
bool is_universal_module(std::span<const std::uint8_t> config);

}  // namespace candp2::gsd
