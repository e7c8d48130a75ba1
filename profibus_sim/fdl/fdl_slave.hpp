// The FDL slave front end (docs/profibus.md): one object answers, on one line, for every
// configured dp::DpSlave at its DP address. It maps FDL requests (SD1/SD2/SD3 with or without SAPs)
// onto the DP services of dp::DpSlave and builds the responses, with FCB/FCV repetition handling,
// FDL_Status, DH while new diagnosis is pending and the min_TSDR delay. Pure: a decoded request and
// the time its last character arrived in, response bytes and the earliest send time out.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "common/line_physics.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

struct SlaveFrontEndOptions {
  std::uint32_t baud = 19200;  // line bit rate: converts bit times to microseconds
  // Only answer requests from this master address (docs/profibus.md `master_address`); any
  // master when unset.
  std::optional<std::uint8_t> master_address;
  // min_TSDR before a station's Set_Prm set one (docs/profibus.md: default 11 bit times).
  std::uint8_t default_min_tsdr_bits = phy::kMinTsdrBits;
};

struct StationStats {
  std::uint64_t requests = 0;     // requests addressed to the station (broadcasts included)
  std::uint64_t responses = 0;    // responses sent (repetitions included)
  std::uint64_t repetitions = 0;  // FCB repetitions answered from the stored response
  std::uint64_t ignored = 0;      // requests addressed to it that got no answer
};

struct Reply {
  std::vector<std::uint8_t> bytes;  // the response as on the wire
  Time not_before{0};               // request end + min_TSDR bit times
  std::uint8_t station = 0;         // the answering station
};

class SlaveFrontEnd {
 public:
  explicit SlaveFrontEnd(SlaveFrontEndOptions options, LogSink* log = nullptr);

  // Serves `slave` at slave.info().address. False (and nothing added) when the address is not
  // 0..126 or already served. A slave that is offline (dp::DpSlave::set_offline) answers nothing;
  // one that accepts Set_Slave_Add moves to its new address.
  bool add(dp::DpSlave& slave);

  // A decoded telegram seen on the line whose last character arrived at `request_end`. Returns
  // the response for requests addressed to a served station, nullopt otherwise.
  std::optional<Reply> on_telegram(const Telegram& t, Time request_end);

  // Convenience for a PHY: raw bytes received at `now` go through the internal StreamParser;
  // returns the reply to the last request in the chunk (earlier ones are superseded — a master
  // waits for the answer before it sends again). `on_gap` signals idle ≥ TSYN (or end of input).
  std::optional<Reply> on_bytes(std::span<const std::uint8_t> bytes, Time now);
  std::optional<Reply> on_gap(Time now);
  const ParserStats& line_stats() const { return parser_.stats(); }
  // Sees every valid telegram on the line (to any station), as its raw bytes (a capture's tap).
  using ObserveFn = std::function<void(std::span<const std::uint8_t> raw, Time now)>;
  void set_observer(ObserveFn observe) { observe_ = std::move(observe); }
  StreamParser& parser() { return parser_; }

  // Inspection for the daemon's status block.
  std::vector<std::uint8_t> addresses() const;  // served stations, ascending
  const StationStats* stats(std::uint8_t address) const;
  std::uint8_t min_tsdr_bits(std::uint8_t address) const;
  // The bit-time delay as a duration at the configured baud rate (rounded up).
  Duration bit_times(std::uint32_t bits) const;
  const SlaveFrontEndOptions& options() const { return options_; }

 private:
  // FCB state of one master towards one station.
  struct Link {
    bool valid = false;  // an executed request with a known FCB exists
    bool fcb = false;
    std::optional<std::vector<std::uint8_t>> last_response;  // nullopt: it got no answer
  };
  struct Station {
    dp::DpSlave* slave = nullptr;
    std::uint8_t min_tsdr = phy::kMinTsdrBits;
    StationStats stats;
    std::array<Link, 128> links{};  // per master address
    // Per master: the diagnosis it last read with Slave_Diag (docs/decisions.md: "DH").
    std::array<std::optional<std::vector<std::uint8_t>>, 128> diag_read{};
  };

  std::optional<std::vector<std::uint8_t>> execute(Station& st, const Telegram& t, Time now);
  std::optional<std::vector<std::uint8_t>> data_exchange(Station& st, const Telegram& t, Time now);
  std::optional<std::vector<std::uint8_t>> set_slave_add(Station& st, const Telegram& t, Time now);
  std::optional<Reply> drain(Time now);

  SlaveFrontEndOptions options_;
  Logger log_;
  std::vector<std::unique_ptr<Station>> owned_;
  std::array<Station*, 128> stations_{};
  StreamParser parser_;
  ObserveFn observe_;
};

}  // namespace candp2::fdl
