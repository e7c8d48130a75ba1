// A configuration tool's module list from the user's (gsd_slave::with_presets, docs/slaves.md
// "Preset modules"): the GSD's preset modules first, in GSD order; with FixPresetModules = 1 they
// can be neither moved nor removed. And the slave built from such a list accepts the Chk_Cfg a
// tool sends.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "common/hex.hpp"
#include "gsd/gsd.hpp"
#include "gsd_slave/configuration.hpp"
#include "gsd_slave/gsd_slave.hpp"

namespace candp2::gsd_slave {
namespace {

// Two preset modules ("head" and "power", in this GSD order) among user modules.
std::string device(int fix) {
  return "#Profibus_DP\nModular_Station = 1\nMax_Module = 8\nIdent_Number = 0x0C2E\n"
         "FixPresetModules = " +
         std::to_string(fix) +
         "\n"
         "Module = \"head\" 0x90\nPreset = 1\nEndModule\n"   // 0
         "Module = \"out\" 0x20\nEndModule\n"                // 1
         "Module = \"power\" 0x00\nPreset = 1\nEndModule\n"  // 2
         "Module = \"in\" 0x10\nEndModule\n";                // 3
}

gsd::Model model(int fix) {
  auto r = gsd::parse(device(fix));
  EXPECT_TRUE(r.ok());
  return std::move(r.model);
}

using List = std::vector<std::size_t>;

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(Presets, LeftOutTheyAreAddedFirstInGsdOrder) {
  for (int fix : {0, 1}) {
    SCOPED_TRACE(fix);
    const gsd::Model m = model(fix);
    const WithPresets w = with_presets(m, List{1, 3});
    EXPECT_FALSE(w.problem);
    EXPECT_EQ(w.modules, (List{0, 2, 1, 3}));
    EXPECT_EQ(w.added, 2u);
    const WithPresets empty = with_presets(m, List{});  // a new configuration: only them
    EXPECT_EQ(empty.modules, (List{0, 2}));
  }
}

TEST(Presets, ListedFirstInGsdOrderTheListStands) {
  for (int fix : {0, 1}) {
    const WithPresets w = with_presets(model(fix), List{0, 2, 3, 1});
    EXPECT_FALSE(w.problem);
    EXPECT_EQ(w.modules, (List{0, 2, 3, 1}));
    EXPECT_EQ(w.added, 0u);
  }
}

TEST(Presets, WithoutFixPresetModulesTheyMayBeMovedOrRemoved) {
  const gsd::Model m = model(0);
  for (const List& user : {List{1, 0, 3}, List{2, 1}, List{0, 1, 0}}) {
    const WithPresets w = with_presets(m, user);
    EXPECT_FALSE(w.problem);
    EXPECT_EQ(w.modules, user);
    EXPECT_EQ(w.added, 0u);
  }
}

TEST(Presets, AFixedModuleMovedIsNamed) {
  const gsd::Model m = model(1);
  // "power" before "head": the first entry out of place is named, with its slot.
  WithPresets w = with_presets(m, List{2, 0, 1});
  ASSERT_TRUE(w.problem);
  EXPECT_EQ(w.problem->position, 0u);
  EXPECT_TRUE(has(w.problem->text,
                  "\"power\" is a fixed preset module: it belongs at slot 1 and cannot be moved "
                  "(FixPresetModules = 1): the preset modules stand first, in GSD order "
                  "(\"head\", \"power\")"))
      << w.problem->text;
  // After a user module; listed a second time.
  w = with_presets(m, List{1, 0, 2});
  ASSERT_TRUE(w.problem);
  EXPECT_EQ(w.problem->position, 1u);
  EXPECT_TRUE(has(w.problem->text, "\"head\" is a fixed preset module: it belongs at slot 0"));
  w = with_presets(m, List{0, 2, 1, 2});
  ASSERT_TRUE(w.problem);
  EXPECT_EQ(w.problem->position, 3u);
  EXPECT_TRUE(has(w.problem->text, "\"power\" is a fixed preset module"));
}

TEST(Presets, AFixedModuleRemovedIsNamed) {
  const gsd::Model m = model(1);
  WithPresets w = with_presets(m, List{0, 1});  // "power" left out after "head"
  ASSERT_TRUE(w.problem);
  EXPECT_EQ(w.problem->position, 1u);
  EXPECT_TRUE(has(w.problem->text,
                  "the fixed preset module \"power\" is missing at slot 1 and cannot be removed"))
      << w.problem->text;
  w = with_presets(m, List{0});  // the list ends before it
  ASSERT_TRUE(w.problem);
  EXPECT_EQ(w.problem->position, 1u);
  EXPECT_TRUE(has(w.problem->text, "\"power\" is missing at slot 1"));
}

TEST(Presets, AGsdWithoutPresetsChangesNothing) {
  const auto r = gsd::parse("#Profibus_DP\nModule = \"out\" 0x20\nEndModule\n");
  const WithPresets w = with_presets(r.model, List{0, 0});
  EXPECT_FALSE(w.problem);
  EXPECT_EQ(w.modules, (List{0, 0}));
  EXPECT_EQ(w.added, 0u);
}

TEST(Presets, TheSlaveAcceptsWhatAToolSends) {
  // The slave's configuration is the completed list; the Chk_Cfg of a tool (presets first) is
  // accepted, the user's modules alone are a Cfg fault naming the preset's entry.
  auto m = std::make_shared<const gsd::Model>(model(1));
  SlaveSetup s;
  s.address = 8;
  s.modules = with_presets(*m, List{1, 3}).modules;
  s.gsd = m;
  std::string error;
  auto slave = GsdSlave::create(std::move(s), &error);
  ASSERT_TRUE(slave) << error;
  EXPECT_EQ(hex_bytes(slave->configuration().bytes), "90 00 20 10");
  const std::vector<std::uint8_t> prm{0x80, 1, 1, 0, 0x0C, 0x2E, 0};
  ASSERT_TRUE(slave->dp().set_prm(1, prm, Time{0}));
  EXPECT_FALSE(slave->dp().chk_cfg(1, std::vector<std::uint8_t>{0x20, 0x10}, Time{0}));
  EXPECT_TRUE(has(slave->cfg_problem(), "Chk_Cfg entry 0: 20 (output 1 byte), the slave has 90"))
      << slave->cfg_problem();
  ASSERT_TRUE(slave->dp().set_prm(1, prm, Time{0}));
  EXPECT_TRUE(slave->dp().chk_cfg(1, std::vector<std::uint8_t>{0x90, 0x00, 0x20, 0x10}, Time{0}))
      << slave->cfg_problem();
}

}  // namespace
}  // namespace candp2::gsd_slave
