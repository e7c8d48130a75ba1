#include "tools/candp2/gsd_reading.hpp"

#include "gateway/cfg_reading.hpp"
#include "gateway/user_prm.hpp"

namespace candp2::cli {

const gsd::DeviceReader& candp2_reader() {
  static const gsd::DeviceReader reader{.ident = gw::kIdentNumber,
                                        .device = "CAN-DP/2",
                                        .rules = "manual §7, docs/slots.md",
                                        .read = [](const gsd::CfgEntry& e) {
                                          const gw::EntryReading r = gw::read_cfg_entry(e.bytes);
                                          return gsd::EntryVerdict{r.text, r.problem};
                                        }};
  return reader;
}

}  // namespace candp2::cli
