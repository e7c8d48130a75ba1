// The capture file writer (capture/capture_writer.hpp): dumpcap's ring file names, rotation at
// the configured size with the newest K files kept, a full disk (injected, and the kernel's
// /dev/full) stopping the capture with one message while the producer goes on, and a writer
// that falls behind costing counted drops, never a blocked producer.
#include "capture/capture_writer.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <ctime>
#include <filesystem>

#include "capture/pcapng.hpp"
#include "pcapng_reader.hpp"

namespace candp2::capture::test {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  TempDir() {
    path = fs::temp_directory_path() /
           ("candp2-capture-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::vector<std::string> files() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path)) out.push_back(e.path().filename());
    std::sort(out.begin(), out.end());
    return out;
  }
  fs::path path;
};

constexpr std::uint64_t kSecond = 1'000'000'000;
constexpr std::uint64_t kT0 = 1'700'000'000 * kSecond;  // 2023-11-14 22:13:20 UTC

std::vector<std::uint8_t> idb() {
  return pcapng::interface_description(pcapng::kLinktypeCanSocketcan, "can0");
}
std::vector<std::uint8_t> epb(std::uint64_t ns, std::uint8_t fill = 0x11) {
  std::vector<std::uint8_t> b;
  const std::vector<std::uint8_t> data(16, fill);
  pcapng::enhanced_packet(b, 0, ns, data, pcapng::Direction::Outbound);
  return b;
}

struct UtcZone {
  UtcZone() {
    setenv("TZ", "UTC0", 1);
    tzset();
  }
};

TEST(CaptureWriter, RingNamesAsDumpcapNamesThem) {
  UtcZone utc;
  EXPECT_EQ(CaptureWriter::ring_name("/var/lib/candp2/cap.pcapng", 1, kT0),
            "/var/lib/candp2/cap_00001_20231114221320.pcapng");
  EXPECT_EQ(CaptureWriter::ring_name("cap", 42, kT0 + 61 * kSecond), "cap_00042_20231114221421");
  EXPECT_EQ(CaptureWriter::ring_name("/tmp/a.b/cap", 7, kT0), "/tmp/a.b/cap_00007_20231114221320");
  EXPECT_EQ(CaptureWriter::ring_name("x.tar.pcapng", 123456, kT0),
            "x.tar_123456_20231114221320.pcapng");
}

TEST(CaptureWriter, OneFileWithoutARing) {
  TempDir dir;
  const std::string path = (dir.path / "one.pcapng").string();
  {
    CaptureWriter w({.path = path});
    EXPECT_TRUE(w.add_header(idb(), kT0));
    for (int i = 0; i < 100; ++i) EXPECT_TRUE(w.add_packet(epb(kT0 + i), kT0 + i));
  }
  EXPECT_EQ(dir.files(), std::vector<std::string>{"one.pcapng"});
  const auto c = read_capture(slurp(path));
  ASSERT_TRUE(c.ok);
  EXPECT_EQ(c.sections, 1u);
  ASSERT_EQ(c.interfaces.size(), 1u);
  EXPECT_EQ(c.interfaces[0].name, "can0");
  ASSERT_EQ(c.packets.size(), 100u);
  EXPECT_EQ(c.packets[99].time, kT0 + 99);
}

TEST(CaptureWriter, RingRotatesAtItsSizeAndKeepsTheNewestFiles) {
  UtcZone utc;
  TempDir dir;
  const std::string path = (dir.path / "ring.pcapng").string();
  constexpr std::uint64_t kMax = 2000;
  constexpr int kPackets = 500;
  const std::size_t block = epb(0).size();
  std::uint32_t opened = 0;
  {
    CaptureWriter w({.path = path, .max_bytes = kMax, .files = 3});
    ASSERT_TRUE(w.add_header(idb(), kT0));
    // One packet a second: the names show the time of each file's first packet.
    for (int i = 0; i < kPackets; ++i)
      ASSERT_TRUE(
          w.add_packet(epb(kT0 + i * kSecond, static_cast<std::uint8_t>(i)), kT0 + i * kSecond));
    w.sync();
    opened = w.files_opened();
  }
  const auto names = dir.files();
  ASSERT_EQ(names.size(), 3u);
  // What fits in one file: the headers, then whole packets up to kMax.
  const std::size_t header = pcapng::section_header("candp2").size() + idb().size();
  const std::size_t per_file = (kMax - header) / block;
  const std::uint32_t expected_files = (kPackets + per_file - 1) / per_file;
  EXPECT_EQ(opened, expected_files);
  std::size_t first_packet = 0;  // index of the first packet of the newest-but-two file
  for (std::size_t k = 0; k < 3; ++k) {
    const std::uint32_t number = expected_files - 2 + static_cast<std::uint32_t>(k);
    const std::size_t first = (number - 1) * per_file;
    if (k == 0) first_packet = first;
    EXPECT_EQ(names[k], fs::path(CaptureWriter::ring_name(path, number, kT0 + first * kSecond))
                            .filename()
                            .string());
    const auto bytes = slurp((dir.path / names[k]).string());
    EXPECT_LE(bytes.size(), kMax);
    const auto c = read_capture(bytes);
    ASSERT_TRUE(c.ok) << names[k];
    ASSERT_EQ(c.interfaces.size(), 1u) << "every file repeats the interface";
    const std::size_t count = std::min<std::size_t>(per_file, kPackets - first);
    ASSERT_EQ(c.packets.size(), count) << names[k];
    if (k < 2) {
      EXPECT_GT(bytes.size() + block, kMax) << "rotated only when the next packet did not fit";
    }
    EXPECT_EQ(c.packets.front().data[0], static_cast<std::uint8_t>(first));
    EXPECT_EQ(c.packets.back().time, kT0 + (first + count - 1) * kSecond);
  }
  EXPECT_GT(first_packet, 0u);
}

// A disk that takes `room` bytes, then answers ENOSPC.
class FullDisk final : public FileSystem {
 public:
  explicit FullDisk(std::size_t room) : room_(room) {}
  int create(const std::string&) override { return 7; }
  ssize_t write(int, const std::uint8_t*, std::size_t n) override {
    if (room_ == 0) {
      errno = ENOSPC;
      ++failed_writes;
      return -1;
    }
    const std::size_t w = std::min(n, room_);
    room_ -= w;
    return static_cast<ssize_t>(w);
  }
  void close(int) override {}
  void remove(const std::string&) override {}
  std::atomic<int> failed_writes{0};

 private:
  std::size_t room_;
};

TEST(CaptureWriter, FullDiskStopsTheCaptureWithOneMessage) {
  auto disk = std::make_unique<FullDisk>(1000);
  FullDisk& d = *disk;
  CaptureWriter w({.path = "/captures/c.pcapng"}, std::move(disk));
  ASSERT_TRUE(w.add_header(idb(), kT0));
  for (int i = 0; i < 200; ++i) w.add_packet(epb(kT0 + i), kT0 + i);
  w.sync();
  EXPECT_TRUE(w.stopped());
  const auto failure = w.take_failure();
  ASSERT_TRUE(failure);
  EXPECT_EQ(*failure, "cannot write /captures/c.pcapng: No space left on device");
  EXPECT_FALSE(w.take_failure()) << "the failure is reported once";
  // The producer goes on: packets are refused at once, without counting as drops.
  const auto dropped = w.dropped();
  for (int i = 0; i < 100000; ++i) EXPECT_FALSE(w.add_packet(epb(kT0 + i), kT0 + i));
  EXPECT_EQ(w.dropped(), dropped);
  EXPECT_EQ(d.failed_writes.load(), 1) << "nothing is written after the failure";
  EXPECT_LE(w.bytes_written(), 1000u);
}

TEST(CaptureWriter, DevFullIsAFullDisk) {
  // The kernel's own full disk: every write to /dev/full fails with ENOSPC.
  ASSERT_TRUE(fs::exists("/dev/full"));
  CaptureWriter w({.path = "/dev/full"});
  ASSERT_TRUE(w.add_header(idb(), kT0));
  w.add_packet(epb(kT0), kT0);
  w.sync();
  ASSERT_TRUE(w.stopped());
  EXPECT_EQ(w.take_failure().value_or(""), "cannot write /dev/full: No space left on device");
}

TEST(CaptureWriter, UncreatableFileStopsTheCapture) {
  TempDir dir;
  CaptureWriter w({.path = (dir.path / "gone" / "c.pcapng").string()});
  ASSERT_TRUE(w.add_header(idb(), kT0));
  w.sync();
  EXPECT_TRUE(w.stopped());
  EXPECT_EQ(
      w.take_failure().value_or(""),
      "cannot create " + (dir.path / "gone" / "c.pcapng").string() + ": No such file or directory");
}

// A disk whose first write waits until the test opens the gate: the writer thread is stuck.
class StuckDisk final : public FileSystem {
 public:
  int create(const std::string&) override { return 7; }
  ssize_t write(int, const std::uint8_t*, std::size_t n) override {
    entered.store(true);
    entered.notify_all();
    gate.wait(false);
    written += n;
    return static_cast<ssize_t>(n);
  }
  void close(int) override {}
  void remove(const std::string&) override {}
  std::atomic<bool> entered{false};
  std::atomic<bool> gate{false};
  std::atomic<std::size_t> written{0};
};

TEST(CaptureWriter, SlowDiskCostsCountedDropsNotABlockedProducer) {
  auto disk = std::make_unique<StuckDisk>();
  StuckDisk& d = *disk;
  CaptureWriter w({.path = "c.pcapng", .buffer_bytes = 4096}, std::move(disk));
  ASSERT_TRUE(w.add_header(idb(), kT0));
  ASSERT_TRUE(w.add_packet(epb(kT0), kT0));
  d.entered.wait(false);  // the writer thread now hangs in write()
  // The producer pushes on while nothing is written: the queue fills, the rest is dropped.
  constexpr int kMore = 1000;
  for (int i = 1; i <= kMore; ++i) w.add_packet(epb(kT0 + i), kT0 + i);
  EXPECT_GT(w.dropped(), 0u);
  EXPECT_LT(w.dropped(), static_cast<std::uint64_t>(kMore));
  EXPECT_EQ(w.packets() + w.dropped(), 1u + kMore);
  d.gate.store(true);
  d.gate.notify_all();
  w.sync();
  EXPECT_FALSE(w.stopped());
  // Everything accepted was written: the section, the interface and w.packets() packets.
  const std::size_t expected =
      pcapng::section_header("candp2").size() + idb().size() + w.packets() * epb(0).size();
  EXPECT_EQ(d.written.load(), expected);
}

}  // namespace
}  // namespace candp2::capture::test
