// `candp2 replay` as a user runs it: exit status 0 / 1 / 2, --junit and --can-log files.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#ifdef CANDP2_BIN

namespace {

namespace fs = std::filesystem;

struct Output {
  int status = -1;
  std::string out;
};

// Runs the tool with a bounded time (coreutils timeout), capturing stdout.
Output run(const std::string& args) {
  const std::string cmd = "timeout 60 " + std::string(CANDP2_BIN) + " replay " + args + " 2>&1";
  Output o;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return o;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) o.out.append(buf, n);
  const int rc = ::pclose(p);
  o.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return o;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class ReplayCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("candp2-replay-cli-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  }
  fs::path dir;
};

const char* kScenario = R"({"format": "candp2-replay", "version": 1, "name": "cli",
  "gateway": {"address": 5, "bus": "vcan7", "parameters": {},
              "slots": [{"io": "output", "address": 0, "length": 1, "comment": "01,00,00"}]},
  "steps": [{"write": {"address": 0, "bytes": "2A"}},
            {"expect_frame": "100#2A", "within_ms": 100},
            {"inject": "7FF#01"}, EXTRA]})";

std::string scenario(const std::string& extra) {
  std::string s = kScenario;
  s.replace(s.find("EXTRA"), 5, extra);
  return s;
}

TEST_F(ReplayCli, PassWritesJunitAndCandumpLog) {
  const auto f = write("ok.json", scenario(R"({"expect_no_frame": "*", "for_ms": 10})"));
  const auto o = run(f.string() + " --junit " + (dir / "r.xml").string() + " --can-log " +
                     (dir / "can.log").string());
  EXPECT_EQ(o.status, 0) << o.out;
  EXPECT_NE(o.out.find("PASS: 2 expectations, 2 passed, 0 failed"), std::string::npos) << o.out;
  const auto xml = slurp(dir / "r.xml");
  EXPECT_NE(xml.find(R"(<testsuite name="cli" tests="2" failures="0")"), std::string::npos) << xml;
  // candump -l format with virtual time; the gateway's frame and the injected one.
  EXPECT_EQ(slurp(dir / "can.log"), "(0.030000) vcan7 100#2A\n(0.030000) vcan7 7FF#01\n");
}

TEST_F(ReplayCli, FailedExpectationExitsOne) {
  const auto f = write("fail.json", scenario(R"({"expect_frame": "100#2B", "within_ms": 10})"));
  const auto o = run(f.string() + " --quiet --junit " + (dir / "r.xml").string());
  EXPECT_EQ(o.status, 1) << o.out;
  EXPECT_NE(o.out.find("FAIL  #4 expect_frame 100#2B"), std::string::npos) << o.out;  // quiet
  EXPECT_NE(slurp(dir / "r.xml").find("<failure"), std::string::npos);
}

TEST_F(ReplayCli, UnusableScenarioExitsTwo) {
  const auto f = write("bad.json", scenario(R"({"expect_frame": "100#2B", "within": 10})"));
  auto o = run(f.string() + " --junit " + (dir / "r.xml").string());
  EXPECT_EQ(o.status, 2) << o.out;
  EXPECT_NE(o.out.find("bad.json: $.steps[3].within: unknown key"), std::string::npos) << o.out;
  EXPECT_NE(slurp(dir / "r.xml").find("<error message="), std::string::npos);
  o = run((dir / "missing.json").string());
  EXPECT_EQ(o.status, 2) << o.out;
  o = run("");  // no scenario: usage error
  EXPECT_EQ(o.status, 2) << o.out;
}

TEST_F(ReplayCli, PassQuietPrintsNothing) {
  const auto f = write("ok.json", scenario(R"({"note": "x"})"));
  const auto o = run("-q " + f.string());
  EXPECT_EQ(o.status, 0);
  EXPECT_EQ(o.out, "");
}

}  // namespace

#endif  // CANDP2_BIN
