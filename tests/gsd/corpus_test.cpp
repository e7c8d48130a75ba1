// Every GSD file of a folder parses without an error diagnostic, and nothing of it is dropped: the
// project's own files (tests/gsd/data, written for these tests) always, the vendor GSD corpus when
// CANDP2_GSD_CORPUS names it (docs/development.md "Vendor files"). A failure lists each offending
// file with line and reason. The counts below were taken with grep from the files themselves, so
// blocks the parser silently dropped would show up too.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "common/hex.hpp"
#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd/summary.hpp"
#include "gsd/text.hpp"
#include "tests/vendor_files.hpp"
#include "tools/candp2/gsd_reading.hpp"

namespace candp2::gsd {
namespace {

namespace fs = std::filesystem;
using candp2::test::kGsdCorpusVar;

const fs::path kData = candp2::test::project_gsd_dir();

std::vector<fs::path> gsd_files(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename() != "README.md") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// Each error diagnostic and each file without a #Profibus_DP header, one line each.
std::string parse_failures(const std::vector<fs::path>& files) {
  std::string failures;
  for (const auto& f : files) {
    const ParseResult r = parse_file(f.string());
    for (const auto& d : r.diagnostics)
      if (d.severity == Severity::Error) failures += format(d, f.filename().string()) + "\n";
    if (!r.model.has_header) failures += f.filename().string() + ": no #Profibus_DP header\n";
  }
  return failures;
}

struct Counts {
  std::size_t modules, ext_user_prm_data, prm_texts, refs, consts, unit_diag_bits;
};

// grep -ci of '^Module *=', '^ExtUserPrmData', '^PrmText', '^Ext_User_Prm_Data_Ref',
// '^Ext_User_Prm_Data_Const', '^Unit_Diag_(Not_)?Bit(' per file.
void expect_counts(const fs::path& dir, const std::map<std::string, Counts>& expected) {
  for (const auto& [name, c] : expected) {
    SCOPED_TRACE(name);
    const ParseResult r = parse_file((dir / name).string());
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

void check_encode_and_summary(const std::vector<fs::path>& files) {
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const ParseResult r = parse_file(f.string());
    (void)check(r.model, &cli::candp2_reader());
    EXPECT_TRUE(encode_user_prm(r.model).ok());
    for (const auto& m : r.model.modules) EXPECT_TRUE(encode_module_prm(r.model, m).ok()) << m.name;
    const std::string s = summary(r.model, &cli::candp2_reader());
    EXPECT_NE(s.find("Modules: " + std::to_string(r.model.modules.size())), std::string::npos);
  }
}

// ------------------------------------------------------------- the project's own GSD files

TEST(ProjectGsd, EveryFileParsesWithoutErrors) {
  const auto files = gsd_files(kData);
  ASSERT_GE(files.size(), 6u) << kData;
  const std::string failures = parse_failures(files);
  EXPECT_TRUE(failures.empty()) << "files that fail to parse:\n" << failures;
}

TEST(ProjectGsd, NothingIsDropped) {
  expect_counts(kData, {
                           {"CP2CIO8.GSD", {2, 2, 2, 2, 1, 0}},
                           {"CP2COUPL.GSD", {8, 1, 1, 1, 1, 6}},
                           {"CP2DPV1.GSD", {2, 0, 0, 0, 1, 6}},
                           {"CP2MIO32.GSD", {5, 3, 2, 4, 3, 0}},
                           {"CP2MOTOR.GSD", {3, 10, 4, 10, 1, 8}},
                           {"CP2REV0.GSD", {1, 0, 0, 0, 0, 0}},
                       });
}

TEST(ProjectGsd, SyntaxCornerCases) {
  // CP2DPV1.GSD: a quoted Info_Text continued with '\' onto the next line, a module's identifier
  // bytes on the line after its name.
  const ParseResult v1 = parse_file((kData / "CP2DPV1.GSD").string());
  EXPECT_EQ(v1.model.string("Info_Text"),
            "Motor manager for the candp2 tests, DP-V1, with Set_Slave_Add and a 1 ms watchdog "
            "base");
  ASSERT_EQ(v1.model.modules.size(), 2u);
  EXPECT_EQ(hex_bytes(v1.model.modules[0].config), "C0 83 89");
  EXPECT_EQ(v1.model.modules[0].reference, 1);
  // CP2MIO32.GSD: 8 module constants over 4 lines, each ending in '\' and a comment; a module
  // reference default overrides its constant's bits; Preset and FixPresetModules are kept.
  const ParseResult io = parse_file((kData / "CP2MIO32.GSD").string());
  const Module* ai = io.model.module("4 AI");
  ASSERT_NE(ai, nullptr);
  EXPECT_EQ(ai->ext_module_prm_data_len, 8);
  ASSERT_EQ(ai->prm.consts.size(), 1u);
  EXPECT_EQ(hex_bytes(encode_module_prm(io.model, *ai).bytes), "01 01 02 02 00 00 FF FF");
  const Module* out = io.model.module("16 DO");
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(hex_bytes(encode_module_prm(io.model, *out).bytes), "00 00");  // 0x10, bits 4-5 = 0
  EXPECT_EQ(hex_bytes(encode_user_prm(io.model).bytes), "01 03 00");
  const PrmOverride ov[] = {{"Output Behaviour", 2}};
  EXPECT_EQ(hex_bytes(encode_user_prm(io.model, ov).bytes), "21 03 00");
  EXPECT_EQ(io.model.number("FixPresetModules"), 1);
  const Module* head = io.model.module("Head MIO");
  ASSERT_NE(head, nullptr);
  ASSERT_EQ(head->settings.size(), 1u);
  EXPECT_EQ(head->settings[0].key, "Preset");
  EXPECT_EQ(head->settings[0].raw, "1");
  ASSERT_EQ(io.model.slots.size(), 2u);
  EXPECT_EQ(io.model.slots[0].name, "Head");
  // CP2CIO8.GSD (CRLF, ISO-8859-1): legacy and Ext parameter bytes agree; texts become UTF-8.
  const ParseResult cio = parse_file((kData / "CP2CIO8.GSD").string());
  EXPECT_EQ(hex_bytes(encode_user_prm(cio.model).bytes), "00 00 00 42");
  EXPECT_EQ(to_utf8(cio.model.string("Info_Text").value_or("")),
            "Kompakte E/A-Station f\u00fcr Pr\u00fcfungen: 8 Eing\u00e4nge, 8 Ausg\u00e4nge, "
            "Gr\u00f6\u00dfe 1");
  // CP2REV0.GSD: no GSD_Revision (revision 0), user parameters as User_Prm_Data only.
  const ParseResult r0 = parse_file((kData / "CP2REV0.GSD").string());
  EXPECT_FALSE(r0.model.gsd_revision());
  EXPECT_EQ(hex_bytes(encode_user_prm(r0.model).bytes), "00 05");
  EXPECT_NE(summary(r0.model).find("revision 0"), std::string::npos);
}

TEST(ProjectGsd, CheckEncodeAndSummaryRunOnEveryFile) {
  check_encode_and_summary(gsd_files(kData));
}

// ------------------------------------------------ the vendor GSD corpus (CANDP2_GSD_CORPUS)

TEST(VendorGsdCorpus, EveryFileParsesWithoutErrors) {
  CANDP2_VENDOR_DIR(corpus, kGsdCorpusVar);
  const auto files = gsd_files(corpus);
  ASSERT_GE(files.size(), 11u) << corpus;
  const std::string failures = parse_failures(files);
  EXPECT_TRUE(failures.empty()) << "files that fail to parse:\n" << failures;
}

TEST(VendorGsdCorpus, NothingIsDropped) {
  CANDP2_VENDOR_DIR(corpus, kGsdCorpusVar);
  expect_counts(corpus, {
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
                        });
}

TEST(VendorGsdCorpus, SyntaxCornerCasesOfRealFiles) {
  CANDP2_VENDOR_DIR(corpus, kGsdCorpusVar);
  // SI1180fd.gse: a quoted Info_Text continued with '\' onto the next line.
  const ParseResult si = parse_file((corpus / "SI1180fd.gse").string());
  EXPECT_EQ(si.model.string("Info_Text"),
            "SIRIUS Motormanagement and Control Device SIMOCODE pro V, PROFIBUS-DP, "
            "0,30A...820A, expandable with expansion modules");
  ASSERT_EQ(si.model.modules.size(), 2u);
  EXPECT_EQ(hex_bytes(si.model.modules[0].config), "C0 83 89");  // config on the next line
  EXPECT_EQ(si.model.modules[0].reference, 1);
  // Siem80de.gsf: 92 constant bytes over 12 lines, each ending in '\' and a comment.
  const ParseResult fr = parse_file((corpus / "Siem80de.gsf").string());
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
  const ParseResult s31 = parse_file((corpus / "SIEM8031.GSE").string());
  const Setting* odd = s31.model.find("Unit_Diag_!Bit", 3);
  ASSERT_NE(odd, nullptr);
  EXPECT_EQ(odd->line, 1113);
  // pyprofibus (CRLF): legacy and Ext parameter bytes agree.
  const ParseResult py = parse_file((corpus / "pyprofibus-dummy_modular.gsd").string());
  EXPECT_EQ(hex_bytes(encode_user_prm(py.model).bytes), "00 00 00 42");
  // profirust mock: 12 constant bytes, bit parameters at offset 5 at their default 0.
  const ParseResult pr = parse_file((corpus / "profirust-mock.gsd").string());
  EXPECT_EQ(hex_bytes(encode_user_prm(pr.model).bytes), "00 00 00 00 00 00 00 00 00 00 00 FF");
  const PrmOverride ov[] = {{"Peripheral Setting", 1}, {"Peripheral Setting 2", 3}};
  EXPECT_EQ(hex_bytes(encode_user_prm(pr.model, ov).bytes), "00 00 00 00 00 07 00 00 00 00 00 FF");
  ASSERT_EQ(pr.model.slots.size(), 1u);
  EXPECT_EQ(pr.model.slots[0].name, "Data Interface");
}

TEST(VendorGsdCorpus, CheckEncodeAndSummaryRunOnEveryFile) {
  CANDP2_VENDOR_DIR(corpus, kGsdCorpusVar);
  check_encode_and_summary(gsd_files(corpus));
}

}  // namespace
}  // namespace candp2::gsd
