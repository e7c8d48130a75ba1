// $.master.baud and $.master.bus_parameters: the in-process line in time (docs/profibus.md
// "The line in time", docs/configuration.md "master").
#include <algorithm>
#include <string>

#include "config/parse_helpers.hpp"

namespace candp2::config::detail {

namespace {

struct Key {
  const char* name;
  std::uint32_t fdl::BusParameters::*field;
  const char* profibus_key;  // the serial line's own key for the same parameter (role master)
};
constexpr Key kKeys[] = {
    {"slot_time_bits", &fdl::BusParameters::slot_time_bits, "slot_time_bits"},
    {"min_tsdr_bits", &fdl::BusParameters::min_tsdr_bits, nullptr},
    {"max_tsdr_bits", &fdl::BusParameters::max_tsdr_bits, nullptr},
    {"tset_bits", &fdl::BusParameters::tset_bits, nullptr},
    {"tqui_bits", &fdl::BusParameters::tqui_bits, nullptr},
    {"gap_factor", &fdl::BusParameters::gap_factor, nullptr},
    {"hsa", &fdl::BusParameters::hsa, nullptr},
    {"retry_limit", &fdl::BusParameters::retry_limit, "retries"},
    {"ttr_bits", &fdl::BusParameters::ttr_bits, nullptr},
};

// A parameter of role master given here and in $.profibus: one place only.
void check_twice(const Object& here, const char* key, const DaemonConfig& c,
                 const char* profibus_key, const json* profibus) {
  if (!profibus_key || !here.has(key) || !profibus || !profibus->contains(profibus_key)) return;
  fail(here.path(key), std::string("given twice: here and at ") + c.profibus->json_path + "." +
                           profibus_key + "; set it in one place");
}

}  // namespace

void parse_line(const Object& master, const json* profibus, DaemonConfig& c) {
  const json* bp = master.find("bus_parameters");
  if (!master.has("baud") && !bp) return;
  const bool role_master = c.remote_gateways();
  if (role_master && master.has("baud"))
    fail(master.path("baud"), "given twice: here and at " + c.profibus->json_path +
                                  ".baud (the line of role master); set it in one place");
  if (!role_master && !master.has("baud"))
    fail(master.path("bus_parameters"), "bus parameters need a line with a baud rate: set " +
                                            master.path("baud") + " (" + phy::line_rates_text() +
                                            ")");
  const std::uint64_t baud =
      role_master ? c.profibus->baud
                  : as_uint(master.at("baud"), master.path("baud"), 0, 100000000, "bit/s");
  const auto defaults = fdl::default_bus_parameters(static_cast<std::uint32_t>(baud));
  if (!defaults)
    fail(master.path("baud"), "baud " + std::to_string(baud) +
                                  " is not a PROFIBUS DP rate; expected one of " +
                                  phy::line_rates_text());
  LineConfig line;
  line.baud = static_cast<std::uint32_t>(baud);
  line.params = *defaults;
  line.json_path = master.path("baud");
  if (bp) {
    std::vector<std::string> keys;
    for (const auto& k : kKeys) keys.emplace_back(k.name);
    const Object o(*bp, master.path("bus_parameters"), keys);
    for (const auto& k : kKeys) {
      if (role_master) check_twice(o, k.name, c, k.profibus_key, profibus);
      line.params.*k.field = get_uint<std::uint32_t>(o, k.name, line.params.*k.field, 0, 16776960);
    }
    for (const auto& p : fdl::check_bus_parameters(line.params))
      fail(o.has(p.key) ? o.path(p.key) : o.path(),
           p.message + " (the rules of IEC 61158-4-3; docs/profibus.md \"The line in time\")");
    if (role_master) {
      // The serial line's master station takes the slot time and the retry limit from here.
      if (o.has("slot_time_bits")) c.profibus->slot_time_bits = line.params.slot_time_bits;
      if (o.has("retry_limit"))
        c.profibus->retries = static_cast<std::uint8_t>(std::min(line.params.retry_limit, 15u));
      return;
    }
  }
  c.line = std::move(line);
}

}  // namespace candp2::config::detail
