// Helpers for the generic-slave tests: the project's own GSD files (tests/gsd/data/README.md),
// slaves built from them, and the master's telegrams built the way a configuration tool builds
// them (gsd_slave::encode_user_prm / encode_set_prm). A file that cannot be read or a slave that
// cannot be built stops the test with an exception naming the file (gtest reports it), never
// with an empty model a test would go on with.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/hex.hpp"
#include "gsd/gsd.hpp"
#include "gsd_slave/gsd_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "tests/vendor_files.hpp"

namespace candp2::gsd_slave::test {

inline constexpr std::uint8_t kMaster = 2;

// A GSD file of tests/gsd/data, parsed; throws with the path and the first error otherwise.
inline std::shared_ptr<const gsd::Model> load(const std::string& file) {
  const std::string path = candp2::test::project_gsd(file).string();
  auto r = gsd::parse_file(path);
  if (!r.ok()) {
    std::string why;
    for (const auto& d : r.diagnostics)
      if (d.severity == gsd::Severity::Error && why.empty()) why = gsd::format(d, path);
    throw std::runtime_error("cannot use the GSD file " + path + ": " + why);
  }
  return std::make_shared<const gsd::Model>(std::move(r.model));
}

inline std::vector<std::size_t> module_indices(const gsd::Model& m,
                                               const std::vector<std::string>& names) {
  std::vector<std::size_t> out;
  for (const auto& n : names) {
    const gsd::Module* mod = m.module(n);
    EXPECT_TRUE(mod) << "no module \"" << n << "\"";
    if (mod) out.push_back(static_cast<std::size_t>(mod - m.modules.data()));
  }
  return out;
}

inline std::vector<const gsd::Module*> modules(const gsd::Model& m,
                                               const std::vector<std::string>& names) {
  std::vector<const gsd::Module*> out;
  for (auto i : module_indices(m, names)) out.push_back(&m.modules[i]);
  return out;
}

inline std::unique_ptr<GsdSlave> make_slave(std::shared_ptr<const gsd::Model> model,
                                            std::uint8_t address,
                                            const std::vector<std::string>& names,
                                            LogSink* log = nullptr,
                                            SafeState safe = SafeState::Zero) {
  SlaveSetup s;
  s.address = address;
  s.modules = module_indices(*model, names);
  s.gsd = std::move(model);
  s.safe_state = safe;
  s.name = "slave" + std::to_string(address);
  s.log = log;
  std::string error;
  auto slave = GsdSlave::create(std::move(s), &error);
  if (!slave)
    throw std::runtime_error("cannot build the slave at " + std::to_string(address) + ": " + error);
  return slave;
}

// The Set_Prm a configuration tool sends: standard bytes, then the GSD's user parameters with
// `overrides`.
inline std::vector<std::uint8_t> set_prm(const gsd::Model& m, const std::vector<std::string>& names,
                                         StdPrmRequest request = {},
                                         std::vector<gsd::PrmOverride> overrides = {}) {
  const auto mods = modules(m, names);
  const auto user = encode_user_prm(m, mods, overrides);
  EXPECT_TRUE(user.ok()) << (user.errors.empty() ? "" : user.errors.front());
  return encode_set_prm(static_cast<std::uint16_t>(*m.ident_number()), request, user.bytes);
}

inline std::vector<std::uint8_t> chk_cfg(const gsd::Model& m,
                                         const std::vector<std::string>& names) {
  return configuration_of(modules(m, names)).bytes;
}

// The master's parameters, inputs mapped from PLC I `in`, outputs to PLC Q `out`, entry by entry.
inline dp::SlaveParameters params(const gsd::Model& m, const std::vector<std::string>& names,
                                  std::uint16_t in, std::uint16_t out, StdPrmRequest request = {}) {
  dp::SlaveParameters p;
  p.prm = set_prm(m, names, request);
  p.cfg = chk_cfg(m, names);
  p.name = m.model_name();
  for (const auto& e : dp::decode_chk_cfg(p.cfg).entries) {
    dp::EntryAddress a;
    if (e.in_bytes()) {
      a.input = in;
      in = static_cast<std::uint16_t>(in + e.in_bytes());
    }
    if (e.out_bytes()) {
      a.output = out;
      out = static_cast<std::uint16_t>(out + e.out_bytes());
    }
    p.addresses.push_back(a);
  }
  return p;
}

inline std::string hex(std::span<const std::uint8_t> b) {
  return hex_bytes(b);
}

}  // namespace candp2::gsd_slave::test
