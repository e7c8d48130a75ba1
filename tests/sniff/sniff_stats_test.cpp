// `candp2 sniff --stats --json` (docs/sniff.md "Line statistics: --stats") on captures this test
// writes: a line scenario of a class 1 master (2) and its stations, built with the codec, the DP
// wire helpers and the line faults (corrupt FCS, a collision, noise), as a pcapng capture in both
// PROFIBUS link types (with CAN frames, a note and a second PROFIBUS interface around it) and as a
// raw capture. The expected counters follow from the scenario as written down here.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "capture/pcapng.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/line_stats.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"

namespace candp2 {
namespace {

namespace pc = capture::pcapng;
using Bytes = std::vector<std::uint8_t>;
using fdl::FcbSequence;
constexpr std::uint8_t kMaster = 2;

Bytes request(dp::Service s, std::uint8_t station, const FcbSequence& seq = {}, Bytes data = {}) {
  return fdl::encode(
      fdl::dp_request(dp::Request{s, kMaster, std::move(data)}, station, kMaster, seq));
}
Bytes answer(const Bytes& req, dp::Service s, Bytes data = {}) {
  const auto t = fdl::decode(req).telegram;
  return fdl::encode(
      *fdl::dp_answer(*t, s, dp::Response{dp::Response::Status::Ok, std::move(data), false}));
}
Bytes status_request(std::uint8_t station) {
  return fdl::encode(fdl::fdl_status_request(station, kMaster));
}
Bytes status_answer(const Bytes& req) {
  return fdl::encode(fdl::short_answer(*fdl::decode(req).telegram, fdl::kFcOk));
}
Bytes token(std::uint8_t from = kMaster) {
  return fdl::encode(fdl::Telegram::token(from, from));
}
const Bytes kSc = {fdl::kSC};
const Bytes kDiag = {0x02, 0x05, 0x00, 0xFF, 0x04, 0xA4};
const Bytes kPrm = {0x88, 0x01, 0x01, 0x0B, 0x04, 0xA4, 0x00};

struct Timed {
  std::int64_t us;
  Bytes bytes;
};

// The scenario: stations 3 (parameterized, answers through noise, then lost), 4 (answers), 5
// (never answers), 7 (answers FDL_Status only: a phantom).
std::vector<Timed> scenario() {
  FcbSequence s3;
  const Bytes fs3 = status_request(3);
  const Bytes diag3 = request(dp::Service::SlaveDiag, 3, s3);
  s3.advance();
  const Bytes prm3 = request(dp::Service::SetPrm, 3, s3, kPrm);
  s3.advance();
  const Bytes diag5 = request(dp::Service::SlaveDiag, 5);
  const Bytes chk3 = request(dp::Service::ChkCfg, 3, s3, {0x21});
  s3.advance();
  const Bytes diag3b = request(dp::Service::SlaveDiag, 3, s3);
  const Bytes ans3b = answer(diag3b, dp::Service::SlaveDiag, kDiag);
  s3.advance();
  const Bytes fs7 = status_request(7);
  const Bytes dx3 = request(dp::Service::DataExchange, 3, s3, {0x11});
  s3.advance();
  const Bytes dx3b = request(dp::Service::DataExchange, 3, s3, {0x12});
  const Bytes diag4 = request(dp::Service::SlaveDiag, 4);
  return {
      {0, token()},  // rotation 1 starts
      {100, fs3},
      {200, status_answer(fs3)},
      {300, diag3},
      {400, answer(diag3, dp::Service::SlaveDiag, kDiag)},  // diagnostics 3: 1
      {500, prm3},                                          // syncs 3: 1
      {600, fdl::corrupt_fcs(kSc)},                         // illegals 3: 1
      {700, prm3},                                          // repeats 3: 1
      {800, kSc},
      {900, diag5},
      {1000, diag5},    // repeats 5: 1; 5 never answers
      {1100, token()},  // rotation 2 (1100 µs); 5 missing, not lost
      {1200, chk3},
      {1300, kSc},
      {1400, diag3b},
      {1500, fdl::superpose(ans3b, ans3b, 5).bytes},  // illegals 3: 2
      {1600, diag3b},                                 // repeats 3: 2
      {1700, fdl::garble(ans3b, 3)},                  // illegals 3: 3
      {1800, diag3b},                                 // repeats 3: 3 (2 in this rotation)
      {1900, ans3b},                                  // diagnostics 3: 2
      {2000, ans3b},                                  // unexpected: illegals 3: 4
      {2100, fs7},
      {2200, status_answer(fs7)},       // 7: a phantom
      {2300, fdl::garble(token(), 9)},  // no answer due: unattributed 1
      {2400, token()},                  // rotation 3 (1300 µs)
      {2500, dx3},
      {2550, kSc},  // 3 in data exchange
      {2600, dx3b},
      {2700, dx3b},     // repeats 3: 4
      {2800, token()},  // rotation 4 (400 µs): 3 dropped out of data exchange: lost
      {2900, diag4},
      {2950, answer(diag4, dp::Service::SlaveDiag, kDiag)},  // diagnostics 4: 1
      {3000, token()},                                       // rotation 5 (200 µs)
  };
}
constexpr std::uint64_t kValidTelegrams = 33 - 4;  // all but the 4 damaged

nlohmann::json station(int address, const char* live, fdl::StationCounters s) {
  nlohmann::json j = {{"address", address}, {"live", live}};
  for (const auto& f : fdl::kStationCounters) j[std::string(f.name)] = s.*f.member;
  return j;
}

nlohmann::json expected_stations() {
  return nlohmann::json::array({
      station(
          3, "missing",
          {.lost = 1, .syncs = 1, .repeats = 4, .repeats_max = 2, .illegals = 4, .diagnostics = 2}),
      station(4, "ok", {.diagnostics = 1}),
      station(5, "missing", {.repeats = 1, .repeats_max = 1}),
      station(7, "phantom", {}),
  });
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::path(testing::TempDir()) / name).string();
}

void write_file(const std::string& path, const Bytes& b) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

struct Result {
  int rc = -1;
  std::string out, err;
};
Result sniff(const std::string& args) {
  // One file a test process: ctest runs the tests of this program side by side, and a shared
  // name mixed one test's stderr into another's.
  const std::string err = temp_path("sniff-" + std::to_string(::getpid()) + ".stderr");
  Result r;
  FILE* p = ::popen((std::string(CANDP2_BIN) + " sniff " + args + " 2>" + err).c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  r.rc = WEXITSTATUS(::pclose(p));
  std::ifstream e(err);
  r.err.assign(std::istreambuf_iterator<char>(e), std::istreambuf_iterator<char>());
  return r;
}

// A candp2d capture of the scenario: the PROFIBUS side with `linktype`, a CAN bus and the notes
// interleaved, and (`second`) another PROFIBUS interface whose telegrams the statistics leave out.
Bytes pcapng_of(const std::vector<Timed>& line, std::uint16_t linktype, bool second) {
  constexpr std::uint64_t kEpochNs = 1'700'000'000'000'000'000ull;
  Bytes f = pc::section_header("sniff_stats_test");
  for (const Bytes& idb :
       {pc::interface_description(pc::kLinktypeCanSocketcan, "vcan0"),
        pc::interface_description(linktype, "pty:/tmp/pb", "", 1'500'000),
        pc::interface_description(pc::kLinktypeWiresharkUpperPdu, "candp2 notes"),
        pc::interface_description(linktype, "in-process")})
    f.insert(f.end(), idb.begin(), idb.end());
  const std::uint8_t can_data[] = {1, 2};
  const auto can = pc::socketcan(can::Frame::std_data(0x181, can_data));
  for (const Timed& t : line) {
    const std::uint64_t ns = kEpochNs + static_cast<std::uint64_t>(t.us) * 1000;
    Bytes data;
    if (linktype == pc::kLinktypeWiresharkUpperPdu)
      pc::exported_pdu(data, "fdl", t.bytes);
    else
      data = t.bytes;
    pc::enhanced_packet(f, 1, ns, data, pc::Direction::Inbound);
    pc::enhanced_packet(f, 0, ns + 10'000, can, pc::Direction::Outbound);
    if (second) pc::enhanced_packet(f, 3, ns + 20'000, token(9), pc::Direction::Outbound);
  }
  Bytes note;
  pc::exported_pdu(note, "candp2", kSc, "candp2");  // a note's text that looks like an SC
  pc::enhanced_packet(f, 2, kEpochNs + 5000, note, pc::Direction::Unknown, "note");
  return f;
}

void expect_scenario(const nlohmann::json& j) {
  EXPECT_EQ(j["stations"], expected_stations());
  EXPECT_EQ(j["live_list"],
            nlohmann::json::parse(R"({"ok": [4], "missing": [3, 5], "phantom": [7]})"));
  EXPECT_EQ(j["illegals_unattributed"], 1);
  EXPECT_EQ(j["telegrams"], kValidTelegrams);
  // Tokens at 0, 1100, 2400, 2800, 3000 µs.
  EXPECT_EQ(j["rotation_us"], nlohmann::json::parse(
                                  R"({"last": 200, "min": 200, "mean": 750, "max": 1300,
                                      "count": 4})"));
}

TEST(SniffStats, APcapngCaptureWithExportedPdus) {
  const std::string path = temp_path("line-252.pcapng");
  write_file(path, pcapng_of(scenario(), pc::kLinktypeWiresharkUpperPdu, false));
  const Result r = sniff("--stats --json " + path);
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.err, "");
  ASSERT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one document on one line";
  expect_scenario(nlohmann::json::parse(r.out));
}

TEST(SniffStats, APcapngCaptureWithProfibusDlAndASecondLine) {
  const std::string path = temp_path("line-257.pcapng");
  write_file(path, pcapng_of(scenario(), pc::kLinktypeProfibusDl, true));
  const Result r = sniff("--stats --json " + path);
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("33 packets of other PROFIBUS interfaces left out (only pty:/tmp/pb"),
            std::string::npos)
      << r.err;
  expect_scenario(nlohmann::json::parse(r.out));
}

TEST(SniffStats, TheKeysAreThoseOfTheStatusDocument) {
  // The `stations` entries of GET /api/v1/status "line" (the lead's design): the same keys in the
  // same order, so that the two can be compared.
  const std::string path = temp_path("keys.pcapng");
  write_file(path, pcapng_of(scenario(), pc::kLinktypeProfibusDl, false));
  const auto j = nlohmann::ordered_json::parse(sniff("--stats --json " + path).out);
  std::vector<std::string> keys;
  for (const auto& [k, v] : j["stations"][0].items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"address", "live", "lost", "syncs", "repeats",
                                            "repeats_max", "illegals", "diagnostics"}));
}

TEST(SniffStats, ARawCaptureHasNoTimes) {
  // Through the stream parser: garbage between telegrams is no telegram; a corrupt SD1 answer is
  // one abandoned candidate (none of its other bytes is a start delimiter).
  FcbSequence s3;
  const Bytes fs3 = status_request(3);
  const Bytes diag3 = request(dp::Service::SlaveDiag, 3, s3);
  s3.advance();
  const Bytes prm3 = request(dp::Service::SetPrm, 3, s3, kPrm);
  const Bytes diag5 = request(dp::Service::SlaveDiag, 5);
  const Bytes corrupt = fdl::corrupt_fcs(status_answer(fs3));
  for (std::size_t i = 1; i < corrupt.size(); ++i)
    ASSERT_TRUE(corrupt[i] != fdl::kSD1 && corrupt[i] != fdl::kSD2 && corrupt[i] != fdl::kSD3 &&
                corrupt[i] != fdl::kSD4 && corrupt[i] != fdl::kSC);
  Bytes raw;
  for (const Bytes& b :
       {token(), fs3, corrupt, fs3, status_answer(fs3), Bytes{0x00, 0xFF, 0x55}, diag3,
        answer(diag3, dp::Service::SlaveDiag, kDiag), prm3, kSc, token(), diag5, diag5, token()})
    raw.insert(raw.end(), b.begin(), b.end());
  const std::string path = temp_path("line.bin");
  write_file(path, raw);
  Result r = sniff("--stats --json " + path);
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(
      j["stations"],
      nlohmann::json::array({
          station(3, "ok",
                  {.syncs = 1, .repeats = 1, .repeats_max = 1, .illegals = 1, .diagnostics = 1}),
          station(5, "missing", {.repeats = 1, .repeats_max = 1}),
      }));
  EXPECT_EQ(j["live_list"], nlohmann::json::parse(R"({"ok": [3], "missing": [5], "phantom": []})"));
  EXPECT_EQ(j["illegals_unattributed"], 0);
  EXPECT_EQ(j["telegrams"], 12);
  EXPECT_TRUE(j["rotation_us"].is_null()) << "a raw capture has no times";

  // The table: a header of the table's names, a row per station, the line.
  r = sniff("--stats " + path);
  ASSERT_EQ(r.rc, 0) << r.err;
  std::istringstream lines(r.out);
  std::string first, row3, row5, line;
  std::getline(lines, first);
  std::getline(lines, row3);
  std::getline(lines, row5);
  std::getline(lines, line);
  std::istringstream words(first);
  std::vector<std::string> got, want = {"station", "live"};
  for (std::string w; words >> w;) got.push_back(w);
  for (const auto& f : fdl::kStationCounters) want.emplace_back(f.name);
  EXPECT_EQ(got, want);
  std::istringstream r3(row3);
  got.clear();
  for (std::string w; r3 >> w;) got.push_back(w);
  EXPECT_EQ(got, (std::vector<std::string>{"3", "ok", "0", "1", "1", "1", "1", "1"}));
  EXPECT_EQ(line,
            "line: 12 telegrams, 0 illegals unattributed, token rotation unknown (no times in a "
            "raw capture)");
}

TEST(SniffStats, JsonNeedsStatsAndWithoutStatsAPcapngShowsItsTelegrams) {
  const std::string path = temp_path("plain.pcapng");
  write_file(path, pcapng_of(scenario(), pc::kLinktypeWiresharkUpperPdu, false));
  EXPECT_NE(sniff("--json " + path).rc, 0);
  const Result r = sniff("--generic -n 3 " + path);
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.out,
            "(0.000000) SD4 2->2 token\n"
            "(0.000100) SD1 2->3 FDL_Status.req\n"
            "(0.000200) SD1 3->2 OK FDL_Status.res\n");
}

}  // namespace
}  // namespace candp2
