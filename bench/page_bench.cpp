// One Page-Mode page processed by the gateway (manual §6, docs/page-mode.md), and one PLC
// cycle of the page driver + DP master + gateway. Pages of 105 bytes (manual §6.4.2 example 1:
// segments 32 + 32 + 32 + 9) with 12 Tx / 12 Rx entries of 6 data bytes each, as in the 127-motor
// configuration; force 1, so every entry is sent on every page.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <vector>

#include "gateway/gateway.hpp"
#include "gateway/page_mode.hpp"
#include "plc/page_driver.hpp"
#include "profibus_sim/master/dp_master.hpp"

using namespace candp2;
namespace page = gw::page;

namespace {

struct CountingPort : gw::TxPort {
  bool tx_active() const override { return true; }
  void transmit(const can::Frame& f) override {
    benchmark::DoNotOptimize(f);
    ++count;
  }
  std::uint64_t count = 0;
};

struct NullSink : can::FrameSink {
  void send(const can::Frame&) override { ++count; }
  std::uint64_t count = 0;
};

const std::vector<std::size_t> kSegments = {32, 32, 32, 9};

std::vector<page::IdEntry> motors(std::uint32_t base) {
  std::vector<page::IdEntry> v;
  for (std::uint32_t m = 1; m <= 127; ++m) v.push_back({{base + m, false}, 0xB8, 6});
  return v;
}

gw::SlotConfig segments() {
  gw::SlotConfig cfg;
  for (auto n : kSegments) {
    gw::Slot s;
    s.kind = gw::SlotKind::SegmentOut;
    s.length = n;
    cfg.slots.push_back(s);
  }
  for (auto n : kSegments) {
    gw::Slot s;
    s.kind = gw::SlotKind::SegmentIn;
    s.length = n;
    cfg.slots.push_back(s);
  }
  return cfg;
}

// A PageMode engine configured with 127 Tx and 127 Rx identifiers (11 data pages).
struct Engine {
  gw::PageMode pm;
  CountingPort port;
  page::Layout out{kSegments};
  std::vector<std::uint8_t> p = std::vector<std::uint8_t>(105, 0);
  std::vector<std::uint8_t> in = std::vector<std::uint8_t>(105, 0);
  std::uint8_t seq = 0;
  std::vector<page::IdEntry> tx = motors(0x200), rx = motors(0x280);

  void push(std::uint16_t number) {
    page::put_page_number(out, p, number);
    p[page::kSeqByte] = ++seq;
    pm.on_output_page(p, Time{0}, port);
  }
  void configure(std::uint16_t first, std::span<const page::IdEntry> ids) {
    std::uint16_t n = first;
    do {
      const auto k = page::encode_config_page(out, ids, p);
      push(n++);
      ids = ids.subspan(k);
    } while (!ids.empty());
  }
  Engine() {
    pm.configure(segments());
    push(0);
    configure(page::kTxConfigFirst, tx);
    configure(page::kRxConfigFirst, rx);
    if (pm.state() != gw::PageMode::State::Data || pm.data_pages() != 11) std::abort();
    // Data page 251: force 1 for its 12 Tx entries.
    std::fill(p.begin(), p.end(), 0);
    for (const auto& place : page::pack_data(out, tx))
      if (place.page == 0) p[place.offset] = page::kForceAlways;
  }
};

// One data page: 12 Tx entries decoded, form-swapped and sent; the input page with 12 Rx entries.
void BM_DataPage12TxFramesSent(benchmark::State& state) {
  Engine e;
  for (auto _ : state) {
    e.push(page::kDataFirst);
    e.pm.write_input_page(e.in);
    benchmark::DoNotOptimize(e.in.data());
  }
  state.counters["frames/page"] = benchmark::Counter(static_cast<double>(e.port.count) /
                                                     static_cast<double>(state.iterations()));
}
BENCHMARK(BM_DataPage12TxFramesSent);

// The same page with force 0: decoding and the answer only.
void BM_DataPageNothingSent(benchmark::State& state) {
  Engine e;
  for (const auto& place : page::pack_data(e.out, e.tx))
    if (place.page == 0) e.p[place.offset] = page::kForceNever;
  for (auto _ : state) {
    e.push(page::kDataFirst);
    e.pm.write_input_page(e.in);
    benchmark::DoNotOptimize(e.in.data());
  }
}
BENCHMARK(BM_DataPageNothingSent);

// A Tx configuration page with 11 identifiers (manual §6.4.2 example 2), decoded and validated.
void BM_ConfigPageDecode(benchmark::State& state) {
  const page::Layout l({32, 32, 18});
  std::vector<page::IdEntry> ids;
  for (std::uint32_t i = 0; i < 11; ++i) ids.push_back({{0x100 + i, false}, 0, 8});
  std::vector<std::uint8_t> p(82, 0);
  page::encode_config_page(l, ids, p);
  for (auto _ : state) {
    auto d = page::decode_config_page(l, p, nullptr);
    benchmark::DoNotOptimize(d);
  }
}
BENCHMARK(BM_ConfigPageDecode);

// A received frame on one of 127 Rx identifiers (count_in, form swap).
void BM_RxFrame127Identifiers(benchmark::State& state) {
  Engine e;
  can::Frame f;
  f.dlc = 6;
  std::uint32_t i = 0;
  for (auto _ : state) {
    f.id = 0x281 + (i++ % 127);
    benchmark::DoNotOptimize(e.pm.on_frame(f, Time{0}));
  }
}
BENCHMARK(BM_RxFrame127Identifiers);

// One PLC cycle: the page driver scans (DB96 -> page or page -> DB97), the master runs the
// Data_Exchange, the gateway processes the page. Two cycles per page, 22 per rotation.
void BM_PlcCycleDriverMasterGateway127(benchmark::State& state) {
  NullSink sink;
  gw::Gateway gateway({.address = 3}, sink, Time{0});
  std::vector<dp::CfgEntry> entries;
  dp::SlaveParameters params;
  std::uint16_t a = 128;
  for (auto n : kSegments) {
    entries.push_back(dp::special_output(static_cast<std::uint8_t>(n), true, {}));
    params.addresses.push_back({std::nullopt, a});
    a = static_cast<std::uint16_t>(a + n);
  }
  a = 128;
  for (auto n : kSegments) {
    entries.push_back(dp::special_input(static_cast<std::uint8_t>(n), true, {}));
    params.addresses.push_back({a, std::nullopt});
    a = static_cast<std::uint16_t>(a + n);
  }
  gw::UserPrm prm;
  prm.page_mode = true;
  const auto set_prm = gw::make_set_prm(prm);
  params.prm = {set_prm.begin(), set_prm.end()};
  params.cfg = dp::encode_chk_cfg(entries);
  dp::DpMaster master({.address = 1});
  master.add_slave(gateway.dp(), params);
  plc::PageDriver driver({.write_address = 128, .read_address = 128, .output_page_len = 105});
  const auto tx = motors(0x200), rx = motors(0x280);
  driver.write_config_db() = plc::make_config_chain(tx, 10);
  driver.read_config_db() = plc::make_config_chain(rx, 10);
  driver.write_db() = plc::make_data_chain(tx, 10);
  driver.read_db() = plc::make_data_chain(rx, 10);
  const auto pos = *plc::locate_data_entries(driver.write_db(), tx, nullptr);
  for (const auto& p : pos) driver.write_db()[p.db][p.offset + 1] = page::kForceAlways;
  driver.set_freigabe(true);
  master.set_program(&driver);
  Time now{0};
  for (int i = 0; i < 100 && driver.ret_value() != plc::RetValue::Data; ++i) {
    master.cycle(now);
    now += milliseconds(1);
  }
  if (driver.ret_value() != plc::RetValue::Data) std::abort();
  for (auto _ : state) {
    master.cycle(now);
    now += milliseconds(1);
  }
  state.counters["rotations"] = benchmark::Counter(static_cast<double>(driver.rotations()));
  state.counters["frames/cycle"] =
      benchmark::Counter(static_cast<double>(sink.count) / static_cast<double>(state.iterations()));
}
BENCHMARK(BM_PlcCycleDriverMasterGateway127);

}  // namespace
