// `candp2 sniff --stats [--json]` (docs/sniff.md "Line statistics: --stats"): the statistics of
// fdl::LineStatistics as a table or one line of JSON. The columns and keys of the stations are
// the names of the one table fdl::kStationStats, in its order.
#pragma once

#include <string>

#include "profibus_sim/fdl/line_stats.hpp"

namespace candp2::cli {

// `times`: the telegrams carried times (a port, a pcapng capture); without them (a raw capture)
// the token rotation is unknown.
std::string stats_table(const fdl::LineStatistics& s, bool times);
// One JSON document on one line: stations [{address, live, <kStationStats names>}], live_list
// {ok, missing, phantom}, illegals_unattributed, telegrams, rotation_us {last, min, mean, max,
// count} (null without times).
std::string stats_json(const fdl::LineStatistics& s, bool times);

}  // namespace candp2::cli
