// FDL stream parser + slave front end: one Data_Exchange request of the docs/profibus.md
// capture (6 output bytes, §5.1.4 slots) parsed from raw bytes and answered by a real gateway,
// FCB alternating so every request executes. Also the parser alone and the encoder.
#include <benchmark/benchmark.h>

#include <array>
#include <vector>

#include "gateway/gateway.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"

using namespace candp2;

namespace {

struct NullSink : can::FrameSink {
  void send(const can::Frame&) override { ++count; }
  std::uint64_t count = 0;
};

// The docs/profibus.md capture's Data_Exchange requests (FCB=1 / FCB=0).
const std::vector<std::uint8_t> kDx1 = {0x68, 0x09, 0x09, 0x68, 0x03, 0x02, 0x7D, 0x11,
                                        0x22, 0x33, 0x44, 0x55, 0x66, 0xE7, 0x16};
const std::vector<std::uint8_t> kDx2 = {0x68, 0x09, 0x09, 0x68, 0x03, 0x02, 0x5D, 0x11,
                                        0x22, 0x33, 0x44, 0x55, 0x66, 0xC7, 0x16};

struct Line {
  NullSink sink;
  gw::Gateway gw{{.address = 3}, sink, Time{0}};
  fdl::SlaveFrontEnd fe{fdl::SlaveFrontEndOptions{}, nullptr};
  Line() {
    fe.add(gw.dp());
    const std::uint8_t prm[] = {0x88, 0x1E, 0x01, 0x00, 0x04, 0xA4, 0x00, 0x00,
                                0x02, 0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0xFF};
    const std::uint8_t cfg[] = {0x43, 0x85, 0x02, 0x89, 0xB8, 0x83, 0x85, 0x03, 0x09, 0xB8};
    fe.on_bytes(fdl::encode(fdl::Telegram::no_data(3, 2, 0x49)), Time{0});
    fe.on_bytes(fdl::encode(fdl::Telegram::with_data(3, 2, 0x6D, 61, 62, {prm, prm + 16})),
                Time{0});
    fe.on_bytes(fdl::encode(fdl::Telegram::with_data(3, 2, 0x5D, 62, 62, {cfg, cfg + 10})),
                Time{0});
    fe.on_bytes(fdl::encode(fdl::Telegram::with_data(3, 2, 0x7D, 60, 62, {})), Time{0});
    if (gw.dp().state() != dp::SlaveState::DataExch) std::abort();
  }
};

void BM_FdlDataExchangeParsedAndAnswered(benchmark::State& state) {
  Line l;
  Time now{1000};
  bool odd = false;
  std::size_t bytes = 0;
  for (auto _ : state) {
    now += microseconds(100);  // under the 300 ms watchdog
    const auto r = l.fe.on_bytes(odd ? kDx1 : kDx2, now);
    odd = !odd;
    if (!r) std::abort();
    bytes += r->bytes.size();
    benchmark::DoNotOptimize(r->bytes.data());
  }
  benchmark::DoNotOptimize(bytes);
}
BENCHMARK(BM_FdlDataExchangeParsedAndAnswered);

void BM_FdlStreamParserDataExchange(benchmark::State& state) {
  fdl::StreamParser p;
  for (auto _ : state) {
    p.feed(kDx1);
    auto ev = p.next();
    benchmark::DoNotOptimize(ev);
  }
}
BENCHMARK(BM_FdlStreamParserDataExchange);

void BM_FdlEncodeDataExchangeResponse(benchmark::State& state) {
  const auto t = fdl::Telegram::with_data(2, 3, 0x08, std::nullopt, std::nullopt,
                                          {0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F});
  std::vector<std::uint8_t> out;
  for (auto _ : state) {
    out.clear();
    fdl::encode_to(t, out);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_FdlEncodeDataExchangeResponse);

}  // namespace
