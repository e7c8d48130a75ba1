// The Communication Window's receive FIFO (255 frames, manual §5.3.3.2) and the paths a
// received frame and a command 3 take through the window and the gateway.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdlib>
#include <vector>

#include "gateway/comm_window.hpp"
#include "gateway/gateway.hpp"

using namespace candp2;

namespace {

can::Frame frame(std::uint32_t id, std::uint8_t b) {
  can::Frame f;
  f.id = id;
  f.dlc = 8;
  f.data.fill(b);
  return f;
}

// One push and one pop on a half-full ring (the steady state of a PLC keeping up).
void BM_CwFifoPushPop(benchmark::State& state) {
  gw::CwFifo fifo;
  for (int i = 0; i < 128; ++i) fifo.push(frame(0x181, 0));
  std::uint8_t b = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(fifo.push(frame(0x181, ++b)));
    auto f = fifo.pop();
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations() * 2);
}
BENCHMARK(BM_CwFifoPushPop);

// Fill all 255 places, then drain them.
void BM_CwFifoFillDrain255(benchmark::State& state) {
  gw::CwFifo fifo;
  const can::Frame f = frame(0x181, 0x5A);
  for (auto _ : state) {
    for (std::size_t i = 0; i < gw::kCwFifoCapacity; ++i) fifo.push(f);
    benchmark::DoNotOptimize(fifo.push(f));  // the 256th is refused
    while (auto g = fifo.pop()) benchmark::DoNotOptimize(g);
  }
  state.SetItemsProcessed(state.iterations() * 2 * gw::kCwFifoCapacity);
}
BENCHMARK(BM_CwFifoFillDrain255);

struct NullHost : gw::CwHost {
  bool tx_active() const override { return true; }
  void transmit(const can::Frame& f) override { benchmark::DoNotOptimize(f); }
  bool can_released() const override { return true; }
  bool set_sync_time(std::uint16_t, Time) override { return true; }
};

// A received frame on one of N enabled identifiers into the FIFO, and a command 3 taking it out.
void BM_CwFrameInCommand3Out(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  NullHost host;
  gw::CommWindow cw;
  gw::CwRequest r;
  r.command = gw::kCwEnable;
  for (std::uint32_t i = 0; i < n; ++i) {
    r.counter = static_cast<std::uint8_t>(r.counter + 1);
    r.set_identifier({0x100 + i, false});
    cw.on_write(gw::encode_cw_request(r), Time{0}, host);
  }
  if (cw.enabled_count() != n) std::abort();
  r.command = gw::kCwRead;
  std::array<std::uint8_t, gw::kCwLen> read{};
  std::uint32_t i = 0;
  for (auto _ : state) {
    // The frame goes into the FIFO (no read is armed: the last command 3 found a frame).
    ++i;
    cw.on_frame(frame(0x100 + i % n, static_cast<std::uint8_t>(i)));
    r.counter = static_cast<std::uint8_t>(r.counter + 1);
    cw.on_write(gw::encode_cw_request(r), Time{0}, host);
    cw.read(read);
    benchmark::DoNotOptimize(read);
  }
  if (cw.msg_lost() != 0) state.SkipWithError("frames lost");
}
BENCHMARK(BM_CwFrameInCommand3Out)->Arg(1)->Arg(6)->Arg(127);

// The gateway's receive path for a frame on a CW-enabled identifier (CW before slots).
void BM_GatewayRxEnabledIdentifier(benchmark::State& state) {
  struct NullSink : can::FrameSink {
    void send(const can::Frame&) override {}
  } sink;
  gw::Gateway g({.address = 3}, sink, Time{0});
  gw::UserPrm p;
  p.comm_window = true;
  g.dp().set_prm(1, gw::make_set_prm(p), Time{0});
  g.dp().chk_cfg(1,
                 dp::encode_chk_cfg(
                     std::vector<dp::CfgEntry>{dp::special_input(16, true, {0xFF, 0xEF, 0x00}),
                                               dp::special_output(16, true, {0xFF, 0xEF, 0x00})}),
                 Time{0});
  if (g.dp().state() != dp::SlaveState::DataExch) std::abort();
  gw::CwRequest r;
  r.command = gw::kCwEnable;
  r.counter = 1;
  r.set_identifier({0x181, false});
  if (!g.dp().data_exchange(1, gw::encode_cw_request(r), Time{0})) std::abort();
  const can::Frame f = frame(0x181, 1);
  r.command = gw::kCwRead;
  std::uint32_t i = 0;
  for (auto _ : state) {
    g.on_can_frame(f, Time{0});
    if (++i % 200 == 0) {  // keep the FIFO from overflowing: drain it through command 3
      state.PauseTiming();
      while (g.comm_window().fifo_level() > 0) {
        r.counter = static_cast<std::uint8_t>(r.counter + 1);
        g.dp().data_exchange(1, gw::encode_cw_request(r), Time{0});
      }
      state.ResumeTiming();
    }
  }
  if (g.comm_window().msg_lost() != 0) state.SkipWithError("frames lost");
}
BENCHMARK(BM_GatewayRxEnabledIdentifier);

}  // namespace
