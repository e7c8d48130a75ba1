// libFuzzer target: any bytes as a GSD file through parser, checker, encoder and summary.
// Run: build-asan/fuzz/gsd_fuzz -max_len=8192 tests/gsd/data gsd/
// The unit tests link this file too (fuzz_smoke_test.cpp) and call the entry point directly.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "gateway/cfg_reading.hpp"
#include "gsd/cfg.hpp"
#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd/summary.hpp"
#include "tools/candp2/gsd_reading.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace gsd = candp2::gsd;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const gsd::ParseResult r = gsd::parse(text);
  for (const auto& d : r.diagnostics) (void)gsd::format(d, "fuzz");
  (void)gsd::check(r.model, &candp2::cli::candp2_reader());
  (void)gsd::summary(r.model, &candp2::cli::candp2_reader());

  // Overrides by every parameter name, with the data's first bytes as values and as text.
  std::vector<gsd::PrmOverride> ov;
  for (const auto& d : r.model.ext_user_prm_data) {
    ov.push_back({d.name, static_cast<std::int64_t>(size ? data[0] : 0) - 3});
    ov.push_back({d.name, std::string(text.substr(0, 12))});
    if (ov.size() > 16) break;
  }
  (void)gsd::encode_user_prm(r.model, ov);
  for (const auto& m : r.model.modules) (void)gsd::encode_module_prm(r.model, m, ov);
  if (auto o = gsd::parse_override(text)) (void)gsd::encode_user_prm(r.model, {&*o, 1});

  // The raw bytes as module configuration bytes.
  // gw::read_cfg_entry runs gw::decode_slots a few times per entry; the first 64 entries suffice
  // (a GSD module has at most a handful).
  const gsd::CfgDecode dec = gsd::decode_config({data, size});
  for (std::size_t i = 0; i < dec.entries.size() && i < 64; ++i) {
    (void)gsd::describe(dec.entries[i]);
    (void)candp2::gw::read_cfg_entry(dec.entries[i].bytes);
  }
  return 0;
}
