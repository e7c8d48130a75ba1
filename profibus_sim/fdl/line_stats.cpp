// What a PROFIBUS analyser counts on a line (docs/profibus.md "Line statistics").
#include "profibus_sim/fdl/line_stats.hpp"

#include <algorithm>

#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

const StationCounterField* station_counter(std::string_view name) {
  for (const auto& f : kStationCounters)
    if (f.name == name) return &f;
  return nullptr;
}

std::string_view to_string(Live l) {
  switch (l) {
    case Live::None:
      return "none";
    case Live::Ok:
      return "ok";
    case Live::Missing:
      return "missing";
    case Live::Phantom:
      return "phantom";
  }
  return "none";
}

void LineStatistics::configure(std::uint8_t address) {
  told_ = true;
  configured_.at(address % kStations) = true;
}

Live LineStatistics::live(std::uint8_t address) const {
  const std::size_t a = address % kStations;
  if (configured_[a]) return live_[a] ? Live::Ok : Live::Missing;
  return heard_[a] ? Live::Phantom : Live::None;
}

std::vector<std::uint8_t> LineStatistics::stations() const {
  std::vector<std::uint8_t> out;
  for (std::size_t a = 0; a < kStations; ++a)
    if (configured_[a] || heard_[a] || stats_[a] != StationCounters{})
      out.push_back(static_cast<std::uint8_t>(a));
  return out;
}

void LineStatistics::illegal(Time /*start*/) {
  // Where an answer was due, the telegram is that station's illegal answer (docs/profibus.md
  // "Line statistics"); anywhere else nobody can be blamed.
  if (outstanding_ && !outstanding_->answered)
    ++stats_[outstanding_->da].illegals;
  else
    ++unattributed_;
}

void LineStatistics::observe_illegal(Time start) {
  illegal(start);
}

void LineStatistics::clear_outstanding() {
  if (!outstanding_) return;
  spare_ = std::move(outstanding_->bytes);
  outstanding_.reset();
}

void LineStatistics::new_request() {
  if (outstanding_ && !outstanding_->answered) close_unanswered(*outstanding_);
  clear_outstanding();
}

void LineStatistics::drop_out(std::uint8_t da) {
  // docs/profibus.md "Line statistics": lost counts a station leaving data exchange.
  if (exchanging_[da]) {
    exchanging_[da] = false;
    ++stats_[da].lost;
  }
}

void LineStatistics::close_unanswered(const Outstanding& o) {
  // The master gave up on a request without a valid answer.
  live_[o.da] = false;
  drop_out(o.da);
}

void LineStatistics::on_request(std::span<const std::uint8_t> bytes, std::uint8_t da,
                                RequestKind k) {
  if (outstanding_ && !outstanding_->answered) {
    if (outstanding_->da == da && std::ranges::equal(outstanding_->bytes, bytes)) {
      // The same telegram again (same FCB): a repeat.
      StationCounters& s = stats_[da];
      ++s.repeats;
      if (++cycle_repeats_[da] == 1) repeated_.push_back(da);
      s.repeats_max = std::max<std::uint64_t>(s.repeats_max, cycle_repeats_[da]);
      return;
    }
    close_unanswered(*outstanding_);
  }
  clear_outstanding();
  if (!master_ && cycle_repeats_[da]) {
    // No token on this line (a lone master that passes none, candp2d in role master): a new
    // request to the station ends its run of repeats (docs/profibus.md "Line statistics in role
    // master").
    cycle_repeats_[da] = 0;
    std::erase(repeated_, da);
  }
  if (k.dp_service && !told_) configured_[da] = true;
  if (k.set_prm) {
    ++stats_[da].syncs;
    drop_out(da);  // parameterized again while in data exchange: it had dropped out
  }
  if (!k.answer_expected) return;
  // The bytes kept for the repeat check reuse the buffer of the request before (no allocation
  // a telegram on a long line).
  Outstanding o{da, std::move(spare_), k.diag, k.data_exchange};
  o.bytes.assign(bytes.begin(), bytes.end());
  outstanding_ = std::move(o);
}

void LineStatistics::on_token(std::uint8_t sa, Time start) {
  new_request();  // the token ends what was outstanding, as a new request would
  if (!master_) master_ = sa;
  if (sa != *master_) return;
  // A rotation ends: repeats_max counts per rotation.
  for (const std::uint8_t a : repeated_) cycle_repeats_[a] = 0;
  repeated_.clear();
  if (last_token_) {
    rotation_.add(start - *last_token_);
  }
  last_token_ = start;
}

void LineStatistics::observe(std::span<const std::uint8_t> bytes, Time start,
                             const Telegram* decoded) {
  DecodeResult r;
  if (!decoded) {
    r = decode(bytes);
    if (!r.telegram) return illegal(start);
    decoded = &*r.telegram;
  }
  ++telegrams_;
  const Telegram& t = *decoded;
  if (t.kind == Kind::SD4) return on_token(t.sa, start);
  if (t.kind == Kind::SC) {
    // A short acknowledgement answers the request that is due, if any.
    if (outstanding_ && !outstanding_->answered) {
      outstanding_->answered = true;
      live_[outstanding_->da] = heard_[outstanding_->da] = true;
      if (outstanding_->data_exchange) exchanging_[outstanding_->da] = true;
    } else {
      ++unattributed_;
    }
    return;
  }
  const std::uint8_t da = t.da % kStations, sa = t.sa % kStations;
  if (t.is_request()) {
    const std::uint8_t f = t.function();
    const bool sdn = f == kFcSdnLow || f == kFcSdnHigh || f == kFcTimeEvent;
    const bool answer_expected = t.da != kBroadcast && !sdn;
    // DP services: a DSAP of the DP range, or Data_Exchange (SRD to the default SAP).
    const bool dp = t.dsap ? (*t.dsap >= kSapMasterMaster && *t.dsap <= kSapChkCfg)
                           : (f == kFcSrdLow || f == kFcSrdHigh);
    const bool one = t.da != kBroadcast;  // a broadcast is nobody's request (no station 0)
    on_request(bytes, da,
               {.dp_service = dp && one,
                .set_prm = one && t.dsap == kSapSetPrm,
                .diag = one && t.dsap == kSapSlaveDiag,
                .data_exchange = !t.dsap && (f == kFcSrdLow || f == kFcSrdHigh),
                .answer_expected = answer_expected});
    return;
  }
  // A response: the answer that is due when it comes from the addressed station to the master.
  if (outstanding_ && !outstanding_->answered && sa == outstanding_->da) {
    outstanding_->answered = true;
    live_[sa] = heard_[sa] = true;
    if (outstanding_->diag) ++stats_[sa].diagnostics;
    if (outstanding_->data_exchange) exchanging_[sa] = true;
    return;
  }
  ++stats_[sa].illegals;  // an answer the master did not expect
}

}  // namespace candp2::fdl
