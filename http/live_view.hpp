// What the front panel's Server-Sent Events carry (docs/daemon.md "Server-Sent Events"): the live
// view, kept as small pieces, each the JSON text of one thing with the round it last changed in.
//
//   header           time, cycle figures (missed cycles, lateness), Modbus and HTTP counters
//   tile per gateway the overview: address, name, LEDs, DP state, fault, frames/s
//   tile per slave   the overview's generic DP slaves: address, name, model, DP state, fault
//   panel pieces     for gateways whose panel a stream has open: the gateway (state, diagnosis,
//                    parameters, counters, ...), one piece per slot row, its bus (load) with the
//                    trace's frames, the drives on that bus; for a generic slave's panel: the
//                    slave (state, diagnosis, modules, field bytes, faults) in one piece
//
// A round refreshes the pieces in small steps (step(): one piece, or a few slot rows), each built
// between two loop callbacks; the server runs steps while its budget for a loop turn lasts, so no
// turn does more than a bounded amount of work however large the plant is. A piece whose text did
// not change keeps its round number; the round's changes become visible together when its last
// step publishes them.
//
// A stream holds a Cursor: the round it last received and the panel it has open. compose() writes
// one event for it from the newest published round: every piece of its view that changed since
// its round (everything when it has received nothing yet: the full state). It runs only when the
// stream's connection can take more data, so a stream that cannot keep up is composed for less
// often and never holds more than one event: it costs nothing while it lags.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/time.hpp"
#include "http/http_status.hpp"

namespace candp2::http {

class LiveView {
 public:
  explicit LiveView(StatusModel& model);

  struct Cursor {
    std::optional<std::size_t> gateway;  // the open panel (index into the model's gateways)
    std::optional<std::size_t> slave;    // or a generic slave's (index into the model's slaves)
    std::uint64_t round = 0;             // the round last received; 0 = nothing yet
    std::uint64_t trace_seq = 0;         // the last trace frame received
  };

  // Starts a round refreshing every tile and the panels of `open` (gateway indices) and
  // `open_slaves` (slave indices).
  void start_round(Time now, std::vector<std::size_t> open,
                   std::vector<std::size_t> open_slaves = {});
  bool round_active() const { return round_.has_value(); }
  // One step of the active round; true when it completed and was published.
  bool step(Time now);
  std::uint64_t published() const { return published_; }
  Time published_at() const { return published_at_; }
  // The first round whose publication can serve a stream opening now with this panel.
  std::uint64_t first_round_for(std::optional<std::size_t> gateway,
                                std::optional<std::size_t> slave = std::nullopt) const;

  // The event for `c` from the published round (JSON text, one line), and the cursor advanced.
  std::string compose(Cursor& c) const;

 private:
  struct Piece {
    std::string json;
    std::uint64_t round = 0;  // the round it last changed in
  };
  struct Traced {
    std::uint64_t seq;
    std::string json;
  };
  enum class Phase { Header, Tiles, SlaveTiles, Panel, Rows, SlavePanels, Bus, Drives, Done };
  struct Round {
    std::uint64_t number = 0;
    Time started{0};
    std::vector<std::size_t> open;
    std::vector<std::size_t> open_slaves;
    Phase phase = Phase::Header;
    std::size_t index = 0;  // tile, open panel or bus being refreshed
    std::size_t row = 0;    // next slot row of open[index]
    std::vector<std::size_t> buses;
    std::string header;
    std::vector<std::pair<Piece*, std::string>> changed;
    std::vector<std::pair<std::size_t, std::vector<Traced>>> traces;  // by bus
    std::vector<std::pair<std::size_t, std::size_t>> row_counts;      // by gateway
  };

  void stage(Piece& p, std::string json);
  void publish(Time now);
  bool in_round(std::size_t gateway) const;
  bool slave_in_round(std::size_t slave) const;

  StatusModel& model_;
  std::string header_;
  std::vector<Piece> tiles_;
  std::vector<Piece> panels_;
  std::vector<std::vector<Piece>> rows_;
  std::vector<Piece> buses_;
  std::vector<std::vector<Traced>> traces_;
  std::vector<Piece> drives_;
  std::vector<std::uint64_t> panel_round_;  // per gateway: the last round that refreshed it
  std::vector<Piece> slave_tiles_;
  std::vector<Piece> slave_panels_;
  std::vector<std::uint64_t> slave_round_;  // per slave: the last round that refreshed its panel
  std::optional<Round> round_;
  std::uint64_t next_round_ = 1;
  std::uint64_t published_ = 0;
  Time published_at_{0};
};

}  // namespace candp2::http
