// A Data_Exchange round trip over FDL in memory (docs/profibus.md): dp::DpMaster → fdl::FdlMaster
// → bytes → fdl::SlaveFrontEnd → dp::DpSlave (a real gw::Gateway, manual §5.1.4 slots) → bytes
// back → FdlMaster → DpMaster. The line is a direct call (no PHY): this measures the protocol code
// only, ns per round trip.
#include <benchmark/benchmark.h>

#include <vector>

#include "gateway/gateway.hpp"
#include "profibus_sim/fdl/fdl_master.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace {

using namespace candp2;

struct NullSink : can::FrameSink {
  void send(const can::Frame&) override {}
};

void BM_FdlDataExchangeRoundTrip(benchmark::State& state) {
  Time now{0};
  NullSink sink;
  fdl::SlaveFrontEnd front(
      {.baud = 1500000, .master_address = std::nullopt, .default_min_tsdr_bits = 11});
  std::vector<std::uint8_t> reply;
  fdl::FdlMaster line({.address = 2, .baud = 1500000},
                      [&](std::span<const std::uint8_t> b, Time t) {
                        if (auto r = front.on_bytes(b, t)) reply = std::move(r->bytes);
                      });
  gw::Gateway g({.address = 3}, sink, now);
  front.add(g.dp());
  dp::DpMaster master({.address = 2});
  const auto prm = gw::make_set_prm(gw::UserPrm{}, 0);
  // manual §5.1.4: 6 input bytes on 0x289, 6 output bytes on 0x309 (form B8).
  std::vector<dp::CfgEntry> slots = {dp::special_input(6, true, {0x02, 0x89, 0xB8}),
                                     dp::special_output(6, true, {0x03, 0x09, 0xB8})};
  master.add_slave(line.station(3),
                   {{prm.begin(), prm.end()}, dp::encode_chk_cfg(slots), {{0, {}}, {{}, 0}}, "gw"});
  auto step = [&] {
    now += milliseconds(1);  // past TSYN
    line.advance(now);
    master.cycle(now);
    line.advance(now);
    while (!reply.empty()) {
      auto bytes = std::move(reply);
      reply.clear();
      line.on_bytes(bytes, now);
      now += microseconds(100);
      line.advance(now);
    }
  };
  for (int i = 0; i < 20; ++i) step();
  if (master.slave(3)->state != dp::MasterSlaveState::DataExch) {
    state.SkipWithError("slave not in Data_Exch");
    return;
  }
  const auto before = master.slave(3)->data_exchanges;
  for (auto _ : state) {
    master.image().outputs[0] = static_cast<std::uint8_t>(before);
    step();
  }
  state.counters["exchanges"] = static_cast<double>(master.slave(3)->data_exchanges - before);
}
BENCHMARK(BM_FdlDataExchangeRoundTrip);

}  // namespace
