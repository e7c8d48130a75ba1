// The PROFIBUS line in time (docs/profibus.md "The line in time"): bit times, the length of each
// telegram type on the wire, the bus parameters with their default profile per rate and the
// rules a configuration tool checks, the idle times TID1/TID2, and the bus cycle a single master
// needs for its stations. One arithmetic for the timed line in the plant (plant/timed_line.hpp)
// and for `candp2 validate`'s prediction. Pure: numbers in, numbers out.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/line_physics.hpp"
#include "common/time.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

// The line's physics (common/line_physics.hpp): 11 bits a character, TSYN, the least min_TSDR,
// the rates, bit times in microseconds.
using phy::bits_to_time;
using phy::is_line_rate;
using phy::kBitsPerChar;
using phy::kLineRates;
using phy::kMinTsdrBits;
using phy::kTsynBits;
using phy::time_to_bits;

// The characters a telegram occupies: SD1 6, SD2 9 + `data_unit` (the SAP bytes and data, 1..246),
// SD3 14, SD4 3, SC 1.
std::size_t telegram_chars(Kind kind, std::size_t data_unit = 0);
inline std::uint64_t telegram_bits(Kind kind, std::size_t data_unit = 0) {
  return kBitsPerChar * telegram_chars(kind, data_unit);
}

// The bus parameters of a DP line (IEC 61158-4-3 / EN 50170 vol. 2), all times in bit times.
struct BusParameters {
  std::uint32_t slot_time_bits = 100;  // TSL: how long the master waits for an answer to start
  std::uint32_t min_tsdr_bits = kMinTsdrBits;  // min_TSDR: the earliest a station may answer
  std::uint32_t max_tsdr_bits = 60;            // max_TSDR: the latest a station may answer
  std::uint32_t tset_bits = 1;                 // Tset: setup time
  std::uint32_t tqui_bits = 0;                 // Tqui: quiet time of a repeater/driver switching
  std::uint32_t gap_factor = 10;               // G: the GAP is looked after every G token rotations
  std::uint32_t hsa = 126;                     // HSA: the highest station address on the line
  std::uint32_t retry_limit = 1;               // max_retry_limit
  std::uint32_t ttr_bits = 65535;              // TTR: target rotation time
  friend bool operator==(const BusParameters&, const BusParameters&) = default;
};

// The DP default profile at `baud` (docs/profibus.md "The line in time": the default bus parameter
// table configuration tools use); nullopt for a rate that is not a DP rate.
std::optional<BusParameters> default_bus_parameters(std::uint32_t baud);

// One broken rule: the parameter's key (as in the configuration) and what is expected.
struct BusParameterProblem {
  std::string key;
  std::string message;
};
// The one rule set of a line's bus parameters (docs/profibus.md "Bus parameters"), for the line
// in time ($.master.bus_parameters) and the serial line ($.profibus) alike, as IEC 61158-4-3 and
// the configuration tools give them: max_TSDR + 15 <= TSL <= 16383; 35 + 2 Tset + Tqui <=
// max_TSDR <= 1023; 11 <= min_TSDR <= max_TSDR and <= 255 (Set_Prm byte 3); retry limit 1..15;
// GAP factor 1..100; HSA 1..126; TTR 256..16776960. One problem per broken rule, its text the
// same wherever the parameter was given.
inline constexpr std::uint32_t kMaxMinTsdrBits = 255;  // Set_Prm byte 3
inline constexpr std::uint32_t kMaxRetryLimit = 15;
std::vector<BusParameterProblem> check_bus_parameters(const BusParameters& p);

// TSM = 2 + 2 Tset + Tqui (safety margin); TID1 = max(TSYN + TSM, min_TSDR): the idle after a
// response or acknowledgement; TID2 = max(TSYN + TSM, max_TSDR): after a telegram that gets no
// answer (SDN, a token).
std::uint32_t tsm_bits(const BusParameters& p);
std::uint32_t tid1_bits(const BusParameters& p);
std::uint32_t tid2_bits(const BusParameters& p);

// One station in the cycle: its Data_Exchange's output and input bytes and its TSDR.
struct CycleStation {
  std::size_t outputs = 0;
  std::size_t inputs = 0;
  std::uint32_t tsdr_bits = kMinTsdrBits;
};
// The Data_Exchange telegrams of one station: the request (SD1 without outputs, else SD3 with 8
// bytes, else SD2) and the answer (SC without inputs, else SD3/SD2).
std::uint64_t data_exchange_request_bits(std::size_t outputs);
std::uint64_t data_exchange_response_bits(std::size_t inputs);
// The bits of one message cycle of any service: the idle before the request (TID1), the request,
// the station's TSDR, the answer.
std::uint64_t message_bits(const BusParameters& p, std::uint64_t request_bits,
                           std::uint32_t tsdr_bits, std::uint64_t answer_bits);
// A station's Data_Exchange message cycle.
std::uint64_t message_cycle_bits(const BusParameters& p, const CycleStation& s);
// The retries of an unanswered Data_Exchange: retry_limit times the request and the slot time
// after it, before the master gives the station up and comes back.
std::uint64_t retry_bits(const BusParameters& p, std::size_t outputs);
// The token the master passes to itself: TID1 after the last answer is already counted, so the
// token's own characters and the TID2 after it.
std::uint64_t token_bits(const BusParameters& p);
// The GAP request: one Request FDL Status to an address nobody answers (after the TID1 of the last
// answer, counted there) and the slot time after it, when the token follows at once; made once
// every gap_factor rotations.
std::uint64_t gap_poll_bits(const BusParameters& p);

struct CyclePrediction {
  std::uint64_t bits = 0;        // one rotation in Data_Exchange, GAP share included (mean)
  std::uint64_t worst_bits = 0;  // a rotation that carries a GAP request
  Duration mean{0};
  Duration worst{0};
};
// The bus cycle of a single master with `stations` in Data_Exchange (docs/profibus.md
// "The line in time"); `gap` false when no address above the master up to HSA is free.
CyclePrediction predict_cycle(std::uint32_t baud, const BusParameters& p,
                              const std::vector<CycleStation>& stations, bool gap = true);

}  // namespace candp2::fdl
