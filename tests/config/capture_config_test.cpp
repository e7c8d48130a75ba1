// The "capture" section (config/capture_config.hpp, docs/configuration.md#capture): what valid
// sections turn into, and that a bad one — above all a capture directory candp2d cannot write
// to — is rejected with the file, the JSON path and what was expected.
#include "config/capture_config.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "config/config.hpp"

namespace candp2::config {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// A minimal daemon configuration in `dir` with the given capture section.
struct CaptureFixture : ::testing::Test {
  CaptureFixture() {
    dir = fs::temp_directory_path() /
          ("candp2-capture-config-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
    file = (dir / "plant.json").string();
  }
  ~CaptureFixture() override { fs::remove_all(dir); }

  Result<DaemonConfig> parse(const json& capture) {
    json j = json::parse(R"({
      "buses": {"can0": {"type": "virtual"}},
      "gateways": [{"name": "gw3", "address": 3, "bus": "can0",
                    "slots": [{"io": "output", "address": 0, "length": 5, "comment": "02,01,00"}]}]
    })");
    j["capture"] = capture;
    return parse_daemon(j.dump(), file);
  }
  CaptureConfig ok(const json& capture) {
    auto r = parse(capture);
    if (auto* e = std::get_if<ConfigError>(&r)) {
      ADD_FAILURE() << e->to_string();
      return {};
    }
    const auto& c = std::get<DaemonConfig>(r);
    EXPECT_TRUE(c.capture);
    return c.capture.value_or(CaptureConfig{});
  }
  std::string bad(const json& capture) {
    auto r = parse(capture);
    if (!std::holds_alternative<ConfigError>(r)) {
      ADD_FAILURE() << "accepted: " << capture.dump();
      return {};
    }
    return std::get<ConfigError>(r).to_string();
  }

  fs::path dir;
  std::string file;
};

TEST_F(CaptureFixture, AbsentMeansNoCapture) {
  json j = json::parse(R"({
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{"name": "gw3", "address": 3, "bus": "can0",
                  "slots": [{"io": "output", "address": 0, "length": 5, "comment": "02,01,00"}]}]
  })");
  auto r = parse_daemon(j.dump(), file);
  ASSERT_TRUE(std::holds_alternative<DaemonConfig>(r));
  EXPECT_FALSE(std::get<DaemonConfig>(r).capture);
}

TEST_F(CaptureFixture, OneFileRelativeToTheConfiguration) {
  const auto c = ok({{"pcapng", "both.pcapng"}, {"_comment", "ignored"}});
  EXPECT_EQ(c.pcapng, (dir / "both.pcapng").string());
  EXPECT_EQ(c.max_mb, 0u);  // one file, no ring
}

TEST_F(CaptureFixture, RingAndLinktype) {
  fs::create_directories(dir / "cap");
  const auto c = ok({{"pcapng", "cap/both.pcapng"},
                     {"max_mb", 10},
                     {"files", "0x5"},
                     {"profibus_linktype", "profibus_dl"}});
  EXPECT_EQ(c.pcapng, (dir / "cap" / "both.pcapng").string());
  EXPECT_EQ(c.max_mb, 10u);
  EXPECT_EQ(c.max_bytes(), 10'000'000u);
  EXPECT_EQ(c.files, 5u);
  EXPECT_EQ(c.profibus_linktype, CaptureProfibusLinktype::ProfibusDl);
  EXPECT_EQ(c.json_path, "$.capture");
  const auto d = ok({{"pcapng", (dir / "x.pcapng").string()}});
  EXPECT_EQ(d.pcapng, (dir / "x.pcapng").string());
  EXPECT_EQ(d.max_mb, 0u);
  EXPECT_EQ(d.files, 0u);
  EXPECT_EQ(d.profibus_linktype, CaptureProfibusLinktype::WiresharkUpperPdu);
}

TEST_F(CaptureFixture, DirectoryThatDoesNotExistIsAConfigurationError) {
  EXPECT_EQ(bad({{"pcapng", "cap/both.pcapng"}}),
            file +
                ": $.capture.pcapng: expected a file in a directory candp2d can write to: the "
                "directory " +
                (dir / "cap").string() + " does not exist");
}

TEST_F(CaptureFixture, DirectoryThatIsAFileIsAConfigurationError) {
  std::ofstream(dir / "plain") << "x";
  EXPECT_EQ(bad({{"pcapng", "plain/both.pcapng"}}),
            file + ": $.capture.pcapng: expected a file in a directory candp2d can write to: " +
                (dir / "plain").string() + " is not a directory");
}

TEST_F(CaptureFixture, UnwritableDirectoryIsAConfigurationError) {
  // Not writable for anyone, root included: sysfs takes no new files. For an ordinary user a
  // directory without write permission shows the same.
  ASSERT_TRUE(fs::is_directory("/sys/kernel"));
  const std::string msg = bad({{"pcapng", "/sys/kernel/capture.pcapng"}});
  EXPECT_EQ(msg.rfind(file + ": $.capture.pcapng: expected a file in a directory candp2d can "
                             "write to: cannot create a file in /sys/kernel: ",
                      0),
            0u)
      << msg;
  if (::geteuid() != 0) {
    fs::create_directories(dir / "ro");
    fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_NE(bad({{"pcapng", "ro/c.pcapng"}}).find("Permission denied"), std::string::npos);
    fs::permissions(dir / "ro", fs::perms::owner_all);
  }
}

TEST_F(CaptureFixture, BadValues) {
  EXPECT_EQ(bad({{"max_mb", 1}}), file + ": $.capture: missing key \"pcapng\"");
  EXPECT_EQ(bad({{"pcapng", (dir / "c.pcapng").string()}, {"files", 3}}),
            file +
                ": $.capture.files: a ring of files needs \"max_mb\" (the size at which the "
                "next file starts), like dumpcap's -b files needs -b filesize");
  EXPECT_NE(
      bad({{"pcapng", (dir / "c.pcapng").string()}, {"max_mb", -1}}).find("$.capture.max_mb: "),
      std::string::npos);
  EXPECT_EQ(
      bad({{"pcapng", (dir / "c.pcapng").string()}, {"profibus_linktype", 257}}),
      file +
          ": $.capture.profibus_linktype: expected \"wireshark_upper_pdu\" or \"profibus_dl\" "
          "(a string), got the number 257");
  EXPECT_EQ(bad({{"pcapng", (dir / "c.pcapng").string()}, {"profibus_linktype", "dl"}}),
            file +
                ": $.capture.profibus_linktype: expected one of \"wireshark_upper_pdu\", "
                "\"profibus_dl\", got the string \"dl\"");
  EXPECT_NE(bad({{"pcapng", (dir / "c.pcapng").string()}, {"maxmb", 1}})
                .find("$.capture.maxmb: unknown key"),
            std::string::npos);
  EXPECT_NE(bad({{"pcapng", (dir / "").string()}}).find("got the directory"), std::string::npos);
}

}  // namespace
}  // namespace candp2::config
