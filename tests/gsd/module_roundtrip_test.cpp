// Every Module of the shipped GSD against the gateway core: its configuration bytes,
// placed in a configuration the gateway can accept, decode with gw::decode_slots to the slot the
// module name promises; gw::read_cfg_entry (the GSD view) reports the very same slot. The
// placeholder identifier 0x7F8 has its documented meaning (docs/gsd.md): the "no CAN assignment"
// dummy on an 11-bit output (manual §5.1.4), an ordinary identifier everywhere else.
#include <gtest/gtest.h>

#include <regex>
#include <variant>

#include "common/hex.hpp"
#include "gateway/cfg_reading.hpp"
#include "gateway/slot_config.hpp"
#include "gsd/cfg.hpp"
#include "gsd/gsd.hpp"

namespace candp2::gsd {
namespace {

const Model& shipped() {
  static const ParseResult r = parse_file(CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD");
  return r.model;
}

std::vector<std::uint8_t> config_of(const char* name) {
  const Module* m = shipped().module(name);
  if (!m) throw std::runtime_error(std::string("no module ") + name);
  return m->config;
}

std::vector<std::uint8_t> concat(std::initializer_list<std::vector<std::uint8_t>> parts) {
  std::vector<std::uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

struct Promise {
  gw::SlotKind kind;
  std::optional<can::Ident> id;
  std::size_t length;
  bool consistent;
};

// What the name says: "Rx 11-bit 3 bytes", "Tx 29-bit 1 byte", "Tx 11-bit 6 bytes ID 0x203",
// "Communication Window input", "Page-Mode segment output".
std::optional<Promise> promise_of(const std::string& name) {
  std::smatch m;
  static const std::regex rxtx(R"(^(Rx|Tx) (11|29)-bit ([1-8]) bytes?(?: ID 0x([0-9A-F]+))?$)");
  if (std::regex_match(name, m, rxtx)) {
    const bool tx = m[1] == "Tx";
    const bool extended = m[2] == "29";
    const std::uint32_t id = m[4].matched ? std::stoul(m[4].str(), nullptr, 16) : 0x7F8;
    std::optional<can::Ident> ident = can::Ident{id, extended};
    if (tx && !extended && id == gw::kDummyTxId) ident.reset();  // manual §5.1.4
    return Promise{tx ? gw::SlotKind::Tx : gw::SlotKind::Rx, ident,
                   static_cast<std::size_t>(std::stoi(m[3])), false};
  }
  if (name == "Communication Window input") return Promise{gw::SlotKind::CwIn, {}, 16, true};
  if (name == "Communication Window output") return Promise{gw::SlotKind::CwOut, {}, 16, true};
  if (name == "Page-Mode segment input") return Promise{gw::SlotKind::SegmentIn, {}, 32, true};
  if (name == "Page-Mode segment output") return Promise{gw::SlotKind::SegmentOut, {}, 32, true};
  return std::nullopt;
}

// A configuration the gateway accepts with the module at slot 0, and the parameters it needs.
std::pair<std::vector<std::uint8_t>, gw::UserPrm> context_for(gw::SlotKind kind,
                                                              const std::vector<std::uint8_t>& m) {
  gw::UserPrm prm;
  switch (kind) {
    case gw::SlotKind::Rx:  // manual §5.1.4: at least one output; the 0x07F8 dummy does
    case gw::SlotKind::Tx:
      return {concat({m, config_of("Tx 11-bit 1 byte")}), prm};
    case gw::SlotKind::CwIn:  // manual §5.3.2: both directions, the Prm flag on
      prm.comm_window = true;
      return {concat({m, config_of("Communication Window output")}), prm};
    case gw::SlotKind::CwOut:
      prm.comm_window = true;
      return {concat({m, config_of("Communication Window input")}), prm};
    case gw::SlotKind::SegmentIn:  // manual table 6.4.1: Page-Mode on, both directions
      prm.page_mode = true;
      return {concat({m, config_of("Page-Mode segment output")}), prm};
    case gw::SlotKind::SegmentOut:
      prm.page_mode = true;
      return {concat({m, config_of("Page-Mode segment input")}), prm};
  }
  return {};
}

TEST(GsdModuleRoundTrip, EveryModuleDecodesToTheSlotItsNamePromises) {
  std::size_t checked = 0;
  for (const auto& mod : shipped().modules) {
    SCOPED_TRACE(mod.name + ": " + hex_bytes(mod.config));
    const auto p = promise_of(mod.name);
    if (!p) {
      // The only module without a slot promise is the configuration tools' universal module
      // (manual §5.2): unedited it is an empty slot, which the gateway rejects (code 1).
      ASSERT_EQ(mod.name, "Universal module");
      ASSERT_TRUE(is_universal_module(mod.config));
      const auto r = gw::decode_slots(concat({mod.config, config_of("Tx 11-bit 1 byte")}), {});
      ASSERT_TRUE(std::holds_alternative<dp::CfgFault>(r));
      EXPECT_EQ(std::get<dp::CfgFault>(r), (dp::CfgFault{0, gw::kCfgWrongIoType}));
      continue;
    }
    const auto [cfg, prm] = context_for(p->kind, mod.config);
    const auto r = gw::decode_slots(cfg, prm);
    ASSERT_TRUE(std::holds_alternative<gw::SlotConfig>(r))
        << "code " << int(std::get<dp::CfgFault>(r).code);
    const gw::Slot& s = std::get<gw::SlotConfig>(r).slots.at(0);
    EXPECT_EQ(s.kind, p->kind);
    EXPECT_EQ(s.id, p->id);
    EXPECT_EQ(s.length, p->length);
    EXPECT_EQ(s.data_len, p->length);
    EXPECT_FALSE(s.counter);
    EXPECT_EQ(s.consistent, p->consistent);
    EXPECT_EQ(s.form, 0x00);     // no byte swapping (manual §7 example)
    EXPECT_EQ(s.cycle_ms, 0);    // no cycle
    EXPECT_EQ(s.cw_sync_ms, 0);  // CW: 00 00 = no SYNC time (docs/communication-window.md)

    // The GSD's own view of the module is the gateway's.
    const CfgDecode d = decode_config(mod.config);
    ASSERT_EQ(d.entries.size(), 1u);
    const gw::EntryReading g = gw::read_cfg_entry(d.entries[0].bytes);
    ASSERT_TRUE(g.slot.has_value()) << g.problem.value_or("");
    EXPECT_EQ(g.slot->kind, s.kind);
    EXPECT_EQ(g.slot->id, s.id);
    EXPECT_EQ(g.slot->length, s.length);
    EXPECT_EQ(g.slot->comment, s.comment);
    ++checked;
  }
  EXPECT_EQ(checked, shipped().modules.size() - 1);
  EXPECT_EQ(checked, 37u);
}

// docs/gsd.md: the unedited 29-bit placeholders are one identifier (29-bit 0x7F8) - Rx and Tx
// placeholders together are the "same identifier for Tx and Rx" fault of manual §2.2 (code 6),
// whereas the 11-bit Tx placeholder is the dummy and combines with every Rx placeholder.
TEST(GsdModuleRoundTrip, UneditedPlaceholdersTogether) {
  auto r = gw::decode_slots(
      concat({config_of("Rx 29-bit 4 bytes"), config_of("Tx 29-bit 4 bytes")}), {});
  ASSERT_TRUE(std::holds_alternative<dp::CfgFault>(r));
  EXPECT_EQ(std::get<dp::CfgFault>(r), (dp::CfgFault{1, gw::kCfgWrongIdentifier}));
  r = gw::decode_slots(concat({config_of("Rx 11-bit 8 bytes"), config_of("Rx 29-bit 8 bytes"),
                               config_of("Tx 11-bit 8 bytes")}),
                       {});
  EXPECT_TRUE(std::holds_alternative<gw::SlotConfig>(r));
}

}  // namespace
}  // namespace candp2::gsd
