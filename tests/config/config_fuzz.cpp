// libFuzzer target: arbitrary text as a daemon configuration. Nothing crashes; a rejected file
// always names its file; an accepted one yields bytes the master can send.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "config/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto r = candp2::config::parse_daemon(text, "fuzz.json");
  if (auto* e = std::get_if<candp2::config::ConfigError>(&r)) {
    if (e->file != "fuzz.json" || e->message.empty()) std::abort();
    return 0;
  }
  for (const auto& g : std::get<candp2::config::DaemonConfig>(r).gateways) {
    const auto p = candp2::config::slave_parameters(g);
    if (p.addresses.size() != g.slots.size()) std::abort();
  }
  return 0;
}
