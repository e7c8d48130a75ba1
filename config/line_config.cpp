// $.master.baud and $.master.bus_parameters: the in-process line in time (docs/profibus.md
// "The line in time", docs/configuration.md "master"); the bus parameters of a line, the serial
// line's ($.profibus) as well, read and checked by one rule set (docs/profibus.md "Bus
// parameters").
#include <initializer_list>
#include <string>

#include "config/parse_helpers.hpp"

namespace candp2::config::detail {

namespace {

// The bus parameters by their key in $.master.bus_parameters, and by the serial line's own key in
// $.profibus where it has one.
struct Key {
  const char* name;
  std::uint32_t fdl::BusParameters::*field;
  const char* profibus_key;
};
constexpr Key kKeys[] = {
    {"slot_time_bits", &fdl::BusParameters::slot_time_bits, "slot_time_bits"},
    {"min_tsdr_bits", &fdl::BusParameters::min_tsdr_bits, "min_tsdr_bits"},
    {"max_tsdr_bits", &fdl::BusParameters::max_tsdr_bits, nullptr},
    {"tset_bits", &fdl::BusParameters::tset_bits, nullptr},
    {"tqui_bits", &fdl::BusParameters::tqui_bits, nullptr},
    {"gap_factor", &fdl::BusParameters::gap_factor, nullptr},
    {"hsa", &fdl::BusParameters::hsa, nullptr},
    {"retry_limit", &fdl::BusParameters::retry_limit, "retries"},
    {"ttr_bits", &fdl::BusParameters::ttr_bits, nullptr},
};

// A section that gives bus parameters: $.master.bus_parameters (its keys are `name`) or
// $.profibus (its keys are `profibus_key`).
struct Section {
  const json* j = nullptr;
  std::string path;
  bool profibus = false;
  const char* key(const Key& k) const { return profibus ? k.profibus_key : k.name; }
  bool gives(const Key& k) const { return j && key(k) && j->contains(key(k)); }
};

void read_keys(const Object& o, bool profibus, fdl::BusParameters& p) {
  const Section s{nullptr, "", profibus};
  for (const auto& k : kKeys)
    if (const char* key = s.key(k))
      p.*k.field = get_uint<std::uint32_t>(o, key, p.*k.field, 0, 16776960);
}

// The one rule set and its one text (docs/profibus.md "Bus parameters"): a broken rule fails at
// the key that set its parameter, in the first of `sections` that gives it, else at `section`.
void check_rules(const fdl::BusParameters& p, std::initializer_list<Section> sections,
                 const std::string& section) {
  for (const auto& problem : fdl::check_bus_parameters(p)) {
    std::string path = section;
    for (const auto& k : kKeys) {
      if (problem.key != k.name) continue;
      for (const auto& s : sections)
        if (s.gives(k)) {
          path = member(s.path, s.key(k));
          break;
        }
    }
    fail(path,
         problem.message + " (the rules of IEC 61158-4-3; docs/profibus.md \"Bus parameters\")");
  }
}

// A parameter of role master given here and in $.profibus: one place only.
void check_twice(const Object& here, const Key& k, const DaemonConfig& c, const json* profibus) {
  if (!k.profibus_key || !here.has(k.name) || !profibus || !profibus->contains(k.profibus_key))
    return;
  fail(here.path(k.name), std::string("given twice: here and at ") + c.profibus->json_path + "." +
                              k.profibus_key + "; set it in one place");
}

const json* role_master_bus_parameters(const Object& top, const DaemonConfig& c) {
  if (!c.remote_gateways()) return nullptr;
  const json* m = top.find("master");
  return m && m->is_object() && m->contains("bus_parameters") ? &m->at("bus_parameters") : nullptr;
}

}  // namespace

fdl::BusParameters read_profibus_bus_parameters(const Object& profibus, std::uint32_t baud) {
  fdl::BusParameters p = *fdl::default_bus_parameters(baud);
  read_keys(profibus, true, p);
  return p;
}

void check_profibus_bus_parameters(const Object& top, const DaemonConfig& c) {
  const Section bp{role_master_bus_parameters(top, c), top.path("master") + ".bus_parameters"};
  const Section pb{top.find("profibus"), c.profibus->json_path, true};
  check_rules(c.profibus->bus, {bp, pb}, bp.j ? bp.path : pb.path);
}

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
  std::vector<std::string> keys;
  for (const auto& k : kKeys) keys.emplace_back(k.name);
  if (role_master) {
    // The serial line's bus parameters: these over $.profibus's, checked with them
    // (check_profibus_bus_parameters).
    const Object o(*bp, master.path("bus_parameters"), keys);
    for (const auto& k : kKeys) check_twice(o, k, c, profibus);
    read_keys(o, false, c.profibus->bus);
    return;
  }
  const std::uint64_t baud = as_uint(master.at("baud"), master.path("baud"), 0, 100000000, "bit/s");
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
    const Object o(*bp, master.path("bus_parameters"), keys);
    read_keys(o, false, line.params);
    check_rules(line.params, {Section{bp, o.path()}}, o.path());
  }
  c.line = std::move(line);
}

}  // namespace candp2::config::detail
