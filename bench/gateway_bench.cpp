// Targets on this 2-core machine: Data_Exchange with 48 slots (244 output bytes) <= 1 us,
// Rx frame dispatch <= 100 ns.
#include <benchmark/benchmark.h>

#include <vector>

#include "gateway/gateway.hpp"

using namespace candp2;

namespace {

struct NullSink : can::FrameSink {
  void send(const can::Frame&) override { ++count; }
  std::uint64_t count = 0;
};

// 31 Tx slots (30 x 8 + 1 x 4 = 244 output bytes) and 17 one-byte Rx slots: 48 slots, 261 bytes.
std::vector<std::uint8_t> full_cfg() {
  std::vector<dp::CfgEntry> e;
  for (std::uint8_t i = 0; i < 30; ++i) e.push_back(dp::special_output(8, true, {0x02, i, 0xFE}));
  e.push_back(dp::special_output(4, true, {0x02, 0x40, 0x00}));
  for (std::uint8_t i = 0; i < 17; ++i) e.push_back(dp::special_input(1, true, {0x03, i, 0x00}));
  return dp::encode_chk_cfg(e);
}

struct Bench {
  NullSink sink;
  gw::Gateway gw{{.address = 3}, sink, Time{0}};
  std::vector<std::uint8_t> out = std::vector<std::uint8_t>(244, 0);
  Bench() {
    const auto prm = gw::make_set_prm(gw::UserPrm{});
    gw.dp().set_prm(1, prm, Time{0});
    gw.dp().chk_cfg(1, full_cfg(), Time{0});
    if (gw.dp().state() != dp::SlaveState::DataExch) std::abort();
  }
};

void BM_DataExchange48SlotsUnchanged(benchmark::State& state) {
  Bench b;
  Time now{0};
  for (auto _ : state) {
    now += microseconds(1);
    auto in = b.gw.dp().data_exchange(1, b.out, now);
    benchmark::DoNotOptimize(in);
  }
}
BENCHMARK(BM_DataExchange48SlotsUnchanged);

void BM_DataExchange48SlotsAllChanged(benchmark::State& state) {
  Bench b;
  Time now{0};
  std::uint8_t v = 0;
  for (auto _ : state) {
    now += microseconds(1);
    std::fill(b.out.begin(), b.out.end(), ++v);  // every Tx slot sends a swapped frame
    auto in = b.gw.dp().data_exchange(1, b.out, now);
    benchmark::DoNotOptimize(in);
  }
  state.counters["frames"] = benchmark::Counter(static_cast<double>(b.sink.count));
}
BENCHMARK(BM_DataExchange48SlotsAllChanged);

void BM_RxDispatch(benchmark::State& state) {
  Bench b;
  can::Frame f;
  f.id = 0x300;
  f.dlc = 1;
  Time now{0};
  std::uint32_t i = 0;
  for (auto _ : state) {
    f.id = 0x300 + (i++ % 17);
    f.data[0] = static_cast<std::uint8_t>(i);
    b.gw.on_can_frame(f, now);
  }
}
BENCHMARK(BM_RxDispatch);

void BM_RxDispatchUnknownId(benchmark::State& state) {
  Bench b;
  can::Frame f;
  f.id = 0x555;
  f.dlc = 8;
  for (auto _ : state) b.gw.on_can_frame(f, Time{0});
}
BENCHMARK(BM_RxDispatchUnknownId);

}  // namespace
