// GSD preset modules: the module keyword Preset and the global FixPresetModules (docs/gsd.md
// "Preset modules"), parsed into the model, checked, and shown in the summary; the project's own
// test device tests/gsd_slave/data/preset_modular.gsd.
#include <gtest/gtest.h>

#include <string>

#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/summary.hpp"

namespace candp2::gsd {
namespace {

const std::string kPresetGsd = CANDP2_SOURCE_DIR "/tests/gsd_slave/data/preset_modular.gsd";

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The first diagnostic, for a failure message.
std::string first(const std::vector<Diagnostic>& d) {
  return d.empty() ? "" : format(d[0], "gsd");
}

TEST(GsdPreset, PresetAndFixPresetModulesAreParsed) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "Modular_Station = 1\n"
      "FixPresetModules = 1\n"
      "Module = \"head\" 0x00\n"
      "Preset = 1\n"
      "EndModule\n"
      "Module = \"out\" 0x20\n"
      "EndModule\n"
      "Module = \"power\" 0x10\n"
      "preset = 1\n"  // keywords are case-insensitive
      "EndModule\n"
      "Module = \"not preset\" 0x11\n"
      "Preset = 0\n"
      "EndModule\n");
  EXPECT_TRUE(r.ok()) << first(r.diagnostics);
  const Model& m = r.model;
  ASSERT_EQ(m.modules.size(), 4u);
  EXPECT_TRUE(m.modules[0].preset);
  EXPECT_FALSE(m.modules[1].preset);
  EXPECT_TRUE(m.modules[2].preset);
  EXPECT_FALSE(m.modules[3].preset);
  EXPECT_EQ(m.preset_modules(), (std::vector<std::size_t>{0, 2}));  // GSD order
  EXPECT_TRUE(m.fix_preset_modules());
}

TEST(GsdPreset, WithoutTheKeywordsNothingIsPreset) {
  const ParseResult r =
      parse("#Profibus_DP\nFixPresetModules = 0\nModule = \"out\" 0x20\nEndModule\n");
  EXPECT_TRUE(r.ok()) << first(r.diagnostics);
  EXPECT_FALSE(r.model.fix_preset_modules());
  EXPECT_TRUE(r.model.preset_modules().empty());
  EXPECT_FALSE(parse("#Profibus_DP\n").model.fix_preset_modules());  // absent: 0
}

TEST(GsdPreset, BadValuesAreLineNumberedErrors) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "FixPresetModules = yes\n"
      "Module = \"head\" 0x00\n"
      "Preset = 2\n"
      "EndModule\n");
  ASSERT_EQ(r.diagnostics.size(), 2u) << first(r.diagnostics);
  EXPECT_EQ(r.diagnostics[0].line, 2);
  EXPECT_TRUE(has(r.diagnostics[0].message, "FixPresetModules expects an unsigned number"));
  EXPECT_EQ(r.diagnostics[1].line, 4);
  EXPECT_TRUE(has(r.diagnostics[1].message, "Module 'head': Preset expects 0 or 1, found '2'"))
      << r.diagnostics[1].message;
  EXPECT_FALSE(r.model.modules[0].preset);
}

TEST(GsdPreset, CheckFindings) {
  // FixPresetModules = 1 with nothing to fix: a warning at its line.
  auto findings = check(parse("#Profibus_DP\nFixPresetModules = 1\nModule = \"out\" 0x20\n"
                              "EndModule\n")
                            .model);
  auto find = [&](const std::string& part) -> const Diagnostic* {
    for (const auto& d : findings)
      if (has(d.message, part)) return &d;
    return nullptr;
  };
  const Diagnostic* d = find("FixPresetModules = 1, but no module has Preset = 1");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->severity, Severity::Warning);
  EXPECT_EQ(d->line, 2);
  // More preset modules than Max_Module: an error at the first one too many; a value other
  // than 0 or 1.
  findings = check(parse("#Profibus_DP\nMax_Module = 1\nFixPresetModules = 2\n"
                         "Module = \"a\" 0x20\nPreset = 1\nEndModule\n"
                         "Module = \"b\" 0x10\nPreset = 1\nEndModule\n")
                       .model);
  d = find("2 modules have Preset = 1, more than Max_Module 1");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->severity, Severity::Error);
  EXPECT_EQ(d->line, 7);
  d = find("FixPresetModules expects 0 or 1, found 2");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->line, 3);
}

TEST(GsdPreset, TheProjectsTestDevice) {
  const ParseResult r = parse_file(kPresetGsd);
  EXPECT_TRUE(r.diagnostics.empty()) << first(r.diagnostics);
  const auto findings = check(r.model);
  EXPECT_TRUE(findings.empty()) << first(findings);
  const Model& m = r.model;
  EXPECT_TRUE(m.limits().modular_station);
  EXPECT_TRUE(m.fix_preset_modules());
  ASSERT_EQ(m.preset_modules().size(), 1u);
  EXPECT_EQ(display_name(m.modules[m.preset_modules()[0]].name), "Head module");
  // The summary marks it and says the rule.
  const std::string s = summary(m);
  EXPECT_TRUE(has(s,
                  "1 with Preset = 1, put first into every configuration and fixed there "
                  "(FixPresetModules = 1)"))
      << s;
  EXPECT_TRUE(has(s, "(preset)"));
}

}  // namespace
}  // namespace candp2::gsd
