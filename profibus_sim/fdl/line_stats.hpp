// What a PROFIBUS analyser counts on a line (docs/profibus.md "Line statistics"): per station lost,
// syncs, repeats, repeats_max, illegals and diagnostics, a live list and the token rotation — made
// from the telegrams alone, as they are on the wire, so that the same code counts for the
// in-process timed line (plant/timed_line.hpp), candp2d in profibus.role "master" and
// `candp2 sniff --stats` on a foreign line. The names and meanings are defined here once
// (kStationCounters); every face iterates them. Pure: bytes and their time in, counters out.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "common/time.hpp"

namespace candp2::fdl {

struct Telegram;

// One station's counters. They start at 0 and only grow (a fault never resets them).
struct StationCounters {
  std::uint64_t lost = 0;         // dropped out of data exchange (ProfiTrace "Lost")
  std::uint64_t syncs = 0;        // parameterizations started: Set_Prm requests (not repeats)
  std::uint64_t repeats = 0;      // requests repeated because no valid answer came
  std::uint64_t repeats_max = 0;  // the most repeats in one token rotation (no token: one request)
  std::uint64_t illegals = 0;     // telegrams that were not a valid answer to the master
  std::uint64_t diagnostics = 0;  // Slave_Diag requests answered

  friend bool operator==(const StationCounters&, const StationCounters&) = default;
};

// The one table of the per-station counters (public names, docs/profibus.md "Line statistics"):
// replay's expect_line, GET /api/v1/status, /metrics, the Modbus line block, the Python package
// and `candp2 sniff --stats` all iterate it. `analyser` names the same figure in ProfiTrace /
// PB-INspektor terms.
struct StationCounterField {
  std::string_view name;
  std::uint64_t StationCounters::*member;
  std::string_view meaning;
  bool counter = true;  // a Prometheus counter (false: a gauge, the highest value seen)
};
inline constexpr StationCounterField kStationCounters[] = {
    {"lost", &StationCounters::lost,
     "times the station dropped out of data exchange: a Data_Exchange abandoned without a valid "
     "answer after the repeats, or the master parameterizing it again"},
    {"syncs", &StationCounters::syncs, "parameterizations started (Set_Prm requests, not repeats)"},
    {"repeats", &StationCounters::repeats, "requests repeated because no valid answer came"},
    {"repeats_max", &StationCounters::repeats_max, "the most repeats in one bus cycle", false},
    {"illegals", &StationCounters::illegals,
     "illegal telegrams: wrong FCS, parity, delimiter or length where its answer was due, or "
     "an answer the master did not expect"},
    {"diagnostics", &StationCounters::diagnostics, "Slave_Diag requests answered"},
};
inline constexpr std::size_t kStationCounterCount = std::size(kStationCounters);
const StationCounterField* station_counter(std::string_view name);

// An address in the live list.
enum class Live : std::uint8_t {
  None,     // neither configured nor heard
  Ok,       // configured and answering
  Missing,  // configured but not answering (never yet, or lost since)
  Phantom,  // answering but not configured
};
std::string_view to_string(Live l);

// Rotation times: the token rotation an analyser sees on the line (from one token of the master
// to its next), the bus cycle the in-process line measures (plant/timed_line.hpp). The one type
// for both, with its one update.
struct RotationTimes {
  std::uint64_t count = 0;
  Duration last{0}, min{0}, max{0}, sum{0};
  Duration mean() const {
    return count ? Duration(sum.count() / static_cast<std::int64_t>(count)) : Duration(0);
  }
  void add(Duration d) {
    last = d;
    min = count ? std::min(min, d) : d;
    max = std::max(max, d);
    sum += d;
    ++count;
  }
};

inline constexpr std::size_t kStations = 127;  // addresses 0..126

class LineStatistics {
 public:
  // A station the master is configured for (the plant knows them). Without any, the configured
  // stations are learnt from the line: those the master sends DP services to (a sniffer).
  void configure(std::uint8_t address);
  // One telegram as it is on the wire, stamped with the time its first character starts. Bytes
  // that do not decode are an illegal telegram.
  // `decoded`: the telegram the bytes are, when the caller built them (no decoding again).
  void observe(std::span<const std::uint8_t> bytes, Time start, const Telegram* decoded = nullptr);
  // A telegram the receiver dropped before its bytes were whole (a parity error, a gap).
  void observe_illegal(Time start);
  // A master that passes no token and knows its retries (candp2d in role master) tells that the
  // telegram it sends next is a new request, not a repeat, even with the same bytes (FDL_Status
  // asked again): a request still unanswered was given up. On a line with tokens the token
  // between them says so; a sniffer of a tokenless master cannot know.
  void new_request();

  const StationCounters& station(std::uint8_t address) const {
    return stats_.at(address % kStations);
  }
  Live live(std::uint8_t address) const;
  // Illegal telegrams no station could be blamed for (no answer was due).
  std::uint64_t illegals_unattributed() const { return unattributed_; }
  // Valid telegrams seen (all kinds).
  std::uint64_t telegrams() const { return telegrams_; }
  const RotationTimes& rotation() const { return rotation_; }
  // Addresses with any counter or a live-list entry, ascending.
  std::vector<std::uint8_t> stations() const;
  bool configured(std::uint8_t address) const { return configured_.at(address % kStations); }

 private:
  struct Outstanding {
    std::uint8_t da = 0;
    std::vector<std::uint8_t> bytes;
    bool diag = false;           // a Slave_Diag request
    bool data_exchange = false;  // a Data_Exchange request (SRD to the default SAP)
    bool answered = false;       // a valid answer came
  };
  void illegal(Time start);
  void close_unanswered(const Outstanding& o);
  struct RequestKind {
    bool dp_service = false, set_prm = false, diag = false, data_exchange = false;
    bool answer_expected = true;
  };
  void on_request(std::span<const std::uint8_t> bytes, std::uint8_t da, RequestKind k);
  void drop_out(std::uint8_t da);
  void clear_outstanding();
  void on_token(std::uint8_t sa, Time start);

  std::array<StationCounters, kStations> stats_{};
  std::array<std::uint32_t, kStations> cycle_repeats_{};
  std::array<bool, kStations> configured_{};
  std::array<bool, kStations> live_{};
  std::array<bool, kStations> exchanging_{};  // its last Data_Exchange was answered
  std::array<bool, kStations> heard_{};
  bool told_ = false;  // configure() was called: no learning
  std::optional<Outstanding> outstanding_;
  std::vector<std::uint8_t> spare_;     // the last request's buffer, reused
  std::vector<std::uint8_t> repeated_;  // stations with cycle_repeats_ > 0
  std::uint64_t unattributed_ = 0, telegrams_ = 0;
  std::optional<std::uint8_t> master_;  // the first token's sender
  std::optional<Time> last_token_;
  RotationTimes rotation_;
};

}  // namespace candp2::fdl
