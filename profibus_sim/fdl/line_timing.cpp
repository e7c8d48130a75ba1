// The PROFIBUS line in time (docs/profibus.md "The line in time").
#include "profibus_sim/fdl/line_timing.hpp"

#include <algorithm>

namespace candp2::fdl {

std::size_t telegram_chars(Kind kind, std::size_t data_unit) {
  switch (kind) {
    case Kind::SD1:
      return 6;  // SD1 DA SA FC FCS ED
    case Kind::SD2:
      return 9 + data_unit;  // SD2 LE LEr SD2 DA SA FC DU FCS ED
    case Kind::SD3:
      return 6 + kSd3DataLen;  // SD3 DA SA FC DU(8) FCS ED
    case Kind::SD4:
      return 3;  // SD4 DA SA
    case Kind::SC:
      return 1;
  }
  return 0;
}

namespace {
// The DP default bus parameters, one row for each of kLineRates in its order (docs/profibus.md
// "Default bus parameters"): slot, min_TSDR, max_TSDR, Tset, Tqui, GAP, HSA, retry limit, TTR.
constexpr std::array<BusParameters, kLineRates.size()> kDefaults = {{
    {100, 11, 60, 1, 0, 10, 126, 1, 65535},     // 9600
    {100, 11, 60, 1, 0, 10, 126, 1, 65535},     // 19200
    {640, 11, 400, 95, 0, 10, 126, 1, 65535},   // 45450
    {100, 11, 60, 1, 0, 10, 126, 1, 65535},     // 93750
    {100, 11, 60, 1, 0, 10, 126, 1, 65535},     // 187500
    {200, 11, 100, 1, 0, 10, 126, 1, 65535},    // 500000
    {300, 11, 150, 1, 0, 10, 126, 1, 65535},    // 1500000
    {400, 11, 250, 4, 3, 10, 126, 2, 65535},    // 3000000
    {600, 11, 450, 8, 6, 10, 126, 3, 65535},    // 6000000
    {1000, 11, 800, 16, 9, 10, 126, 4, 65535},  // 12000000
}};
}  // namespace

std::optional<BusParameters> default_bus_parameters(std::uint32_t baud) {
  for (std::size_t i = 0; i < kLineRates.size(); ++i)
    if (kLineRates[i] == baud) return kDefaults[i];
  return std::nullopt;
}

std::vector<BusParameterProblem> check_bus_parameters(const BusParameters& p) {
  std::vector<BusParameterProblem> out;
  auto rule = [&](bool ok, const char* key, std::string message) {
    if (!ok) out.push_back({key, std::move(message)});
  };
  const std::uint64_t tsdr_floor = 35 + 2ull * p.tset_bits + p.tqui_bits;
  rule(p.slot_time_bits >= p.max_tsdr_bits + 15ull && p.slot_time_bits <= 16383, "slot_time_bits",
       "slot time " + std::to_string(p.slot_time_bits) +
           " bit times: expected max_tsdr_bits + 15 (" + std::to_string(p.max_tsdr_bits + 15ull) +
           ") .. 16383");
  rule(p.max_tsdr_bits >= tsdr_floor && p.max_tsdr_bits <= 1023, "max_tsdr_bits",
       "max_TSDR " + std::to_string(p.max_tsdr_bits) +
           " bit times: expected 35 + 2 tset_bits + tqui_bits (" + std::to_string(tsdr_floor) +
           ") .. 1023");
  // Set_Prm byte 3 carries min_TSDR to the stations: one byte.
  const bool tsdr_byte = p.max_tsdr_bits > kMaxMinTsdrBits;
  rule(p.min_tsdr_bits >= kMinTsdrBits && p.min_tsdr_bits <= p.max_tsdr_bits &&
           p.min_tsdr_bits <= kMaxMinTsdrBits,
       "min_tsdr_bits",
       "min_TSDR " + std::to_string(p.min_tsdr_bits) + " bit times: expected " +
           std::to_string(kMinTsdrBits) + " .. " +
           (tsdr_byte ? std::to_string(kMaxMinTsdrBits) + " (Set_Prm byte 3)"
                      : "max_tsdr_bits (" + std::to_string(p.max_tsdr_bits) + ")"));
  rule(p.retry_limit >= 1 && p.retry_limit <= kMaxRetryLimit, "retry_limit",
       "retry limit " + std::to_string(p.retry_limit) + ": expected 1 .. " +
           std::to_string(kMaxRetryLimit) +
           (p.retry_limit == 0 ? " (a master repeats an unanswered request at least once: write 1 "
                                 "for the fewest repeats)"
                               : ""));
  rule(p.gap_factor >= 1 && p.gap_factor <= 100, "gap_factor",
       "GAP factor " + std::to_string(p.gap_factor) + ": expected 1 .. 100");
  rule(p.hsa >= 1 && p.hsa <= 126, "hsa", "HSA " + std::to_string(p.hsa) + ": expected 1 .. 126");
  rule(p.ttr_bits >= 256 && p.ttr_bits <= 16776960, "ttr_bits",
       "TTR " + std::to_string(p.ttr_bits) + " bit times: expected 256 .. 16776960");
  return out;
}

std::uint32_t tsm_bits(const BusParameters& p) {
  return 2 + 2 * p.tset_bits + p.tqui_bits;
}
std::uint32_t tid1_bits(const BusParameters& p) {
  return std::max<std::uint32_t>(kTsynBits + tsm_bits(p), p.min_tsdr_bits);
}
std::uint32_t tid2_bits(const BusParameters& p) {
  return std::max<std::uint32_t>(kTsynBits + tsm_bits(p), p.max_tsdr_bits);
}

namespace {
std::uint64_t data_bits(std::size_t n, Kind empty) {
  if (n == 0) return telegram_bits(empty);
  if (n == kSd3DataLen) return telegram_bits(Kind::SD3);
  return telegram_bits(Kind::SD2, n);
}
}  // namespace

std::uint64_t data_exchange_request_bits(std::size_t outputs) {
  return data_bits(outputs, Kind::SD1);
}
std::uint64_t data_exchange_response_bits(std::size_t inputs) {
  return data_bits(inputs, Kind::SC);
}

std::uint64_t message_bits(const BusParameters& p, std::uint64_t request_bits,
                           std::uint32_t tsdr_bits, std::uint64_t answer_bits) {
  return tid1_bits(p) + request_bits + tsdr_bits + answer_bits;
}

std::uint64_t message_cycle_bits(const BusParameters& p, const CycleStation& s) {
  return message_bits(p, data_exchange_request_bits(s.outputs), s.tsdr_bits,
                      data_exchange_response_bits(s.inputs));
}

std::uint64_t retry_bits(const BusParameters& p, std::size_t outputs) {
  return p.retry_limit * (data_exchange_request_bits(outputs) + p.slot_time_bits);
}

std::uint64_t token_bits(const BusParameters& p) {
  return telegram_bits(Kind::SD4) + tid2_bits(p);
}

std::uint64_t gap_poll_bits(const BusParameters& p) {
  return telegram_bits(Kind::SD1) + p.slot_time_bits;
}

CyclePrediction predict_cycle(std::uint32_t baud, const BusParameters& p,
                              const std::vector<CycleStation>& stations, bool gap) {
  std::uint64_t bits = token_bits(p);
  for (const auto& s : stations) bits += message_cycle_bits(p, s);
  CyclePrediction c;
  const std::uint64_t g = gap ? gap_poll_bits(p) : 0;
  const std::uint32_t factor = std::max<std::uint32_t>(p.gap_factor, 1);
  c.bits = bits + (g + factor / 2) / factor;
  c.worst_bits = bits + g;
  c.mean = bits_to_time(baud, c.bits);
  c.worst = bits_to_time(baud, c.worst_bits);
  return c;
}

}  // namespace candp2::fdl
