// The pcapng capture's cost to the event loop (docs/capture.md): one CAN frame or one DP telegram
// handed to capture::PcapngTap — block encoding and the push into the writer's queue; the writer
// thread writes to a file system that discards. Drops are counted: a bench that outruns the
// writer shows them in the "dropped" counter.
#include <benchmark/benchmark.h>

#include <vector>

#include "capture/pcapng_tap.hpp"

using namespace candp2;

namespace {

class Discard final : public capture::FileSystem {
 public:
  int create(const std::string&) override { return 3; }
  ssize_t write(int, const std::uint8_t*, std::size_t n) override {
    return static_cast<ssize_t>(n);
  }
  void close(int) override {}
  void remove(const std::string&) override {}
};

capture::PcapngTapOptions options() {
  capture::PcapngTapOptions o;
  o.writer.path = "bench.pcapng";
  o.writer.buffer_bytes = std::size_t{64} << 20;
  o.wall_offset = seconds(1'700'000'000);
  return o;
}

void BM_TapCanFrame(benchmark::State& state) {
  capture::PcapngTap tap(options(), nullptr, std::make_unique<Discard>());
  const auto f = can::Frame::std_data(0x201, std::vector<std::uint8_t>{0x51, 0, 0, 0, 0});
  Time now{0};
  for (auto _ : state) {
    now += microseconds(10);
    tap.on_can({.time = now,
                .bus = 0,
                .bus_name = "can0",
                .interface = "can0",
                .frame = f,
                .sender = "gw:gw3",
                .from_emulation = true});
  }
  tap.sync();
  state.counters["dropped"] = static_cast<double>(tap.stats().dropped);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TapCanFrame);

void BM_TapDataExchangeTelegram(benchmark::State& state) {
  capture::PcapngTap tap(options(), nullptr, std::make_unique<Discard>());
  // SD2 Data_Exchange with 10 output bytes (the demo's two 5-byte slots).
  const std::vector<std::uint8_t> t = {0x68, 0x0D, 0x0D, 0x68, 0x03, 0x01, 0x7D, 0x51, 0x00, 0x00,
                                       0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xD2, 0x16};
  Time now{0};
  for (auto _ : state) {
    now += microseconds(10);
    tap.on_dp(
        {.time = now, .line = 0, .line_name = "in-process", .telegram = t, .from_emulation = true});
  }
  tap.sync();
  state.counters["dropped"] = static_cast<double>(tap.stats().dropped);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TapDataExchangeTelegram);

}  // namespace
