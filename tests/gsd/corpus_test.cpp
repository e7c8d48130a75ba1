// Every real GSD file in ../shared/gsd-corpus parses without an error diagnostic. A failure
// lists each offending file with line and reason. The counts below were taken with grep from
// the files themselves, so blocks the parser silently dropped would show up too.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "common/hex.hpp"
#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd/summary.hpp"
#include "validate/gsd_reading.hpp"

namespace candp2::gsd {
namespace {

namespace fs = std::filesystem;
const fs::path kCorpus = fs::path(CANDP2_SHARED_DIR) / "gsd-corpus";

std::vector<fs::path> corpus_files() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(kCorpus))
    if (e.is_regular_file() && e.path().filename() != "README.md") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(GsdCorpus, EveryFileParsesWithoutErrors) {
  const auto files = corpus_files();
  ASSERT_GE(files.size(), 11u) << kCorpus;
  std::string failures;
  for (const auto& f : files) {
    const ParseResult r = parse_file(f.string());
    for (const auto& d : r.diagnostics)
      if (d.severity == Severity::Error) failures += format(d, f.filename().string()) + "\n";
    if (!r.model.has_header) failures += f.filename().string() + ": no #Profibus_DP header\n";
  }
  EXPECT_TRUE(failures.empty()) << "files that fail to parse:\n" << failures;
}

TEST(GsdCorpus, NothingIsDropped) {
  struct Counts {
    std::size_t modules, ext_user_prm_data, prm_texts, refs, consts, unit_diag_bits;
  };
  // grep -ci of '^Module *=', '^ExtUserPrmData', '^PrmText', '^Ext_User_Prm_Data_Ref',
  // '^Ext_User_Prm_Data_Const', '^Unit_Diag_(Not_)?Bit(' per file.
  const std::map<std::string, Counts> expected = {
      {"SI1180fd.gse", {2, 0, 0, 0, 1, 82}},
      {"SIEM0738.GSD", {195, 0, 0, 0, 0, 0}},
      {"SIEM8031.GSE", {6, 199, 16, 199, 1, 51}},
      {"SIEM8042.GSG", {193, 15, 11, 15, 1, 0}},
      {"SIEM8070.GSD", {20, 1, 1, 1, 1, 32}},
      {"Siem80de.gsf", {22, 88, 16, 1430, 23, 0}},
      {"profirust-mock.gsd", {2, 3, 2, 4, 2, 32}},
      {"pyprofibus-dummy_compact.gsd", {3, 2, 1, 2, 1, 0}},
      {"pyprofibus-dummy_modular.gsd", {3, 2, 1, 2, 1, 0}},
      {"si01814E.GSD", {6, 72, 7, 126, 3, 65}},
      {"siem0024.gsg", {11, 29, 6, 91, 11, 2}},
  };
  for (const auto& [name, c] : expected) {
    SCOPED_TRACE(name);
    const ParseResult r = parse_file((kCorpus / name).string());
    const Model& m = r.model;
    std::size_t refs = m.user_prm.refs.size(), consts = m.user_prm.consts.size();
    for (const auto& mod : m.modules) {
      refs += mod.prm.refs.size();
      consts += mod.prm.consts.size();
    }
    EXPECT_EQ(m.modules.size(), c.modules);
    EXPECT_EQ(m.ext_user_prm_data.size(), c.ext_user_prm_data);
    EXPECT_EQ(m.prm_texts.size(), c.prm_texts);
    EXPECT_EQ(refs, c.refs);
    EXPECT_EQ(consts, c.consts);
    EXPECT_EQ(m.unit_diag_bits.size(), c.unit_diag_bits);
  }
}

TEST(GsdCorpus, SyntaxCornerCasesOfRealFiles) {
  // SI1180fd.gse: a quoted Info_Text continued with '\' onto the next line.
  const ParseResult si = parse_file((kCorpus / "SI1180fd.gse").string());
  EXPECT_EQ(si.model.string("Info_Text"),
            "SIRIUS Motormanagement and Control Device SIMOCODE pro V, PROFIBUS-DP, "
            "0,30A...820A, expandable with expansion modules");
  ASSERT_EQ(si.model.modules.size(), 2u);
  EXPECT_EQ(hex_bytes(si.model.modules[0].config), "C0 83 89");  // config on the next line
  EXPECT_EQ(si.model.modules[0].reference, 1);
  // Siem80de.gsf: 92 constant bytes over 12 lines, each ending in '\' and a comment.
  const ParseResult fr = parse_file((kCorpus / "Siem80de.gsf").string());
  ASSERT_FALSE(fr.model.modules.empty());
  const Module& m = fr.model.modules[0];
  EXPECT_EQ(m.ext_module_prm_data_len, 92);
  ASSERT_EQ(m.prm.consts.size(), 1u);
  EXPECT_EQ(m.prm.consts[0].bytes.size(), 92u);
  const EncodeResult e = encode_module_prm(fr.model, m);
  EXPECT_TRUE(e.ok());
  EXPECT_EQ(e.bytes.size(), 92u);
  // SIEM8031.GSE: the misspelt 'Unit_Diag_!Bit(3)' is kept as an unknown keyword, with a
  // warning, not an error.
  const ParseResult s31 = parse_file((kCorpus / "SIEM8031.GSE").string());
  const Setting* odd = s31.model.find("Unit_Diag_!Bit", 3);
  ASSERT_NE(odd, nullptr);
  EXPECT_EQ(odd->line, 1113);
  // pyprofibus (CRLF): legacy and Ext parameter bytes agree.
  const ParseResult py = parse_file((kCorpus / "pyprofibus-dummy_modular.gsd").string());
  EXPECT_EQ(hex_bytes(encode_user_prm(py.model).bytes), "00 00 00 42");
  // profirust mock: 12 constant bytes, bit parameters at offset 5 at their default 0.
  const ParseResult pr = parse_file((kCorpus / "profirust-mock.gsd").string());
  EXPECT_EQ(hex_bytes(encode_user_prm(pr.model).bytes), "00 00 00 00 00 00 00 00 00 00 00 FF");
  const PrmOverride ov[] = {{"Peripheral Setting", 1}, {"Peripheral Setting 2", 3}};
  EXPECT_EQ(hex_bytes(encode_user_prm(pr.model, ov).bytes), "00 00 00 00 00 07 00 00 00 00 00 FF");
  ASSERT_EQ(pr.model.slots.size(), 1u);
  EXPECT_EQ(pr.model.slots[0].name, "Data Interface");
}

TEST(GsdCorpus, CheckEncodeAndSummaryRunOnEveryFile) {
  for (const auto& f : corpus_files()) {
    SCOPED_TRACE(f.filename().string());
    const ParseResult r = parse_file(f.string());
    (void)check(r.model, &validate::candp2_reader());
    EXPECT_TRUE(encode_user_prm(r.model).ok());
    for (const auto& m : r.model.modules) EXPECT_TRUE(encode_module_prm(r.model, m).ok()) << m.name;
    const std::string s = summary(r.model, &validate::candp2_reader());
    EXPECT_NE(s.find("Modules: " + std::to_string(r.model.modules.size())), std::string::npos);
  }
}

}  // namespace
}  // namespace candp2::gsd
