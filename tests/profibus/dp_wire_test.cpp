// DP services as FDL telegrams (profibus_sim/fdl/dp_wire.hpp): the requests and answers of the
// capture in tests/profibus/fdl_capture.hpp (a real master parameterizing slave 3) byte for byte,
// and the in-process link's wire image equal to what the FDL master and slave front end put on a
// line for the same master run.
#include "profibus_sim/fdl/dp_wire.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "fdl_capture.hpp"
#include "fixture.hpp"
#include "link_rigs.hpp"

namespace candp2::fdl::test {
namespace {

using gw::test::cfg_of;
using gw::test::in_slot;
using gw::test::out_slot;

constexpr std::uint8_t kMaster = 2;

dp::Request req(dp::Service s, std::vector<std::uint8_t> data = {}) {
  return dp::Request{s, kMaster, std::move(data)};
}

TEST(DpWire, RequestsOfTheCaptureByteForByte) {
  FcbSequence seq;
  EXPECT_EQ(H(encode(fdl_status_request(3, kMaster))), kCapFdlStatus);
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::SlaveDiag), 3, kMaster, seq))), kCapSlaveDiag1);
  seq.advance();
  const auto prm = B("88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF");
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::SetPrm, prm), 3, kMaster, seq))), kCapSetPrm);
  seq.advance();
  const auto cfg = B("43 85 02 89 B8 83 85 03 09 B8");
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::ChkCfg, cfg), 3, kMaster, seq))), kCapChkCfg);
  seq.advance();
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::SlaveDiag), 3, kMaster, seq))), kCapSlaveDiag2);
  seq.advance();
  const auto out = B("11 22 33 44 55 66");
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::DataExchange, out), 3, kMaster, seq))),
            kCapDataExch1);
  seq.advance();
  EXPECT_EQ(H(encode(dp_request(req(dp::Service::DataExchange, out), 3, kMaster, seq))),
            kCapDataExch2);
  // Global_Control: SDN_high (FC 0x46) to DSAP 58, no FCB/FCV whatever the sequence says.
  const auto gc = dp_request(req(dp::Service::GlobalControl, {0x08, 0x00}), 3, kMaster, seq);
  EXPECT_EQ(gc.fc, 0x46);
  EXPECT_EQ(gc.dsap, kSapGlobalControl);
  EXPECT_EQ(gc.ssap, kMasterSap);
}

TEST(DpWire, AnswersOfTheCapture) {
  using Status = dp::Response::Status;
  const auto diag_req = *decode(B(kCapSlaveDiag1)).telegram;
  const auto diag = B("02 05 00 FF 04 A4 05 04 00 00 00");
  EXPECT_EQ(H(encode(*dp_answer(diag_req, dp::Service::SlaveDiag, {Status::Ok, diag, false}))),
            "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16");
  const auto prm_req = *decode(B(kCapSetPrm)).telegram;
  EXPECT_EQ(H(encode(*dp_answer(prm_req, dp::Service::SetPrm, {Status::Ok, {}, false}))), "E5");
  const auto dx_req = *decode(B(kCapDataExch1)).telegram;
  const auto in = B("0A 0B 0C 0D 0E 0F");
  EXPECT_EQ(H(encode(*dp_answer(dx_req, dp::Service::DataExchange, {Status::Ok, in, false}))),
            "68 09 09 68 02 03 08 0A 0B 0C 0D 0E 0F 58 16");
  // DH: the answer in the capture of tests/sniff/make_capture.py.
  EXPECT_EQ(H(encode(*dp_answer(dx_req, dp::Service::DataExchange, {Status::Ok, in, true}))),
            "68 09 09 68 02 03 0A 0A 0B 0C 0D 0E 0F 5A 16");
  // No inputs: SC; with diagnosis pending SD1 DH; refused: SD1 RS; nothing for no response.
  EXPECT_EQ(H(encode(*dp_answer(dx_req, dp::Service::DataExchange, {Status::Ok, {}, false}))),
            "E5");
  EXPECT_EQ(H(encode(*dp_answer(dx_req, dp::Service::DataExchange, {Status::Ok, {}, true}))),
            "10 02 03 0A 0F 16");
  EXPECT_EQ(H(encode(*dp_answer(dx_req, dp::Service::DataExchange, {Status::Refused, {}, false}))),
            "10 02 03 03 08 16");
  EXPECT_FALSE(dp_answer(dx_req, dp::Service::DataExchange, {Status::NoResponse, {}, false}));
  EXPECT_FALSE(dp_answer(dx_req, dp::Service::GlobalControl, {Status::Ok, {}, false}));
}

// A recording of telegrams in order: ">" master request, "<" slave answer.
struct Trace {
  std::vector<std::string> lines;
  void add(std::span<const std::uint8_t> b, bool from_master) {
    lines.push_back(std::string(from_master ? "> " : "< ") + hex_bytes(b));
  }
};

// The same DP master run (virtual time, 10 ms cycle) over an in-process link with its wire
// image, and over FDL on a byte pipe (tests/profibus/link_rigs.hpp).
template <typename Rig>
void run_master(Rig& rig, const std::function<void(dp::DpMaster&, dp::DpSlave&)>& add) {
  Time now{0};
  gw::test::Recorder rec;
  rec.now = &now;
  gw::Gateway gateway(gw::GatewayOptions{.address = 3}, rec, now);
  dp::DpMaster master({.address = kMaster, .retry_delay = milliseconds(100)});
  add(master, gateway.dp());
  Time next_cycle{0};
  for (int cycles = 0; cycles < 12;) {
    Time t = next_cycle;
    if (auto d = gateway.next_deadline()) t = std::min(t, *d);
    if (auto d = rig.next_deadline()) t = std::min(t, *d);
    now = std::max(now, t);
    gateway.advance(now);
    rig.advance(now);
    if (now >= next_cycle) {
      // Outputs change in cycle 8: Data_Exchange carries them.
      if (cycles == 8) master.image().outputs[0] = 0x51;
      master.cycle(now);
      next_cycle += milliseconds(10);
      ++cycles;
    }
  }
}

TEST(DpWire, InProcessWireImageEqualsTheFdlLine) {
  const auto prm = gw::make_set_prm(gw::UserPrm{}, 100);
  const dp::SlaveParameters params{
      {prm.begin(), prm.end()},
      cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})}),
      {{0, {}}, {{}, 0}},
      "gw3"};

  // FDL: every telegram on the line, both directions, in order.
  dp::test::FdlRig fdl_rig;
  Trace line;
  fdl_rig.observe = [&](std::span<const std::uint8_t> b, bool m) { line.add(b, m); };
  run_master(fdl_rig, [&](dp::DpMaster& m, dp::DpSlave& s) { fdl_rig.add(m, s, params); });

  // In-process with the wire image.
  dp::test::InProcessRig none;
  Trace image;
  std::unique_ptr<dp::InProcessLink> inner;
  std::unique_ptr<WireImageLink> traced;
  run_master(none, [&](dp::DpMaster& m, dp::DpSlave& s) {
    inner = std::make_unique<dp::InProcessLink>(s);
    traced = std::make_unique<WireImageLink>(
        *inner, [&](std::span<const std::uint8_t> b, bool from_master, Time) {
          image.add(b, from_master);
        });
    m.add_slave(*traced, params);
  });

  ASSERT_GT(line.lines.size(), 20u);
  // Both runs take one step per cycle; the FDL line may be a telegram behind at the end.
  const std::size_t n = std::min(line.lines.size(), image.lines.size());
  ASSERT_GT(n, 20u);
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(image.lines[i], line.lines[i]) << "telegram " << i;
  EXPECT_EQ(image.lines[0], std::string("> ") + kCapFdlStatus);
  EXPECT_EQ(image.lines[1], "< 10 02 03 00 05 16");
  // Cycle 8's new output byte travels in a Data_Exchange of both.
  const auto with_51 = [](const Trace& t) {
    return std::count_if(t.lines.begin(), t.lines.end(), [](const std::string& l) {
      return l.find("03 02 ") != std::string::npos && l.find(" 51 00 ") != std::string::npos;
    });
  };
  EXPECT_GT(with_51(image), 0);
}

TEST(DpWire, LostStationIsAskedForItsFdlStatusAgain) {
  Time now{0};
  gw::test::Recorder rec;
  rec.now = &now;
  gw::Gateway gateway(gw::GatewayOptions{.address = 3}, rec, now);
  dp::test::CableLink cable(gateway.dp());
  Trace t;
  WireImageLink link(cable, [&](std::span<const std::uint8_t> b, bool m, Time) { t.add(b, m); });
  int done = 0;
  auto count = [&](const dp::Response&, Time) { ++done; };
  link.request(req(dp::Service::SlaveDiag), now, count);
  link.request(req(dp::Service::SlaveDiag), now, count);
  EXPECT_EQ(t.lines.size(), 6u);  // FDL_Status, answer, two Slave_Diag with answers
  EXPECT_EQ(t.lines[4], "> 68 05 05 68 83 82 5D 3C 3E DC 16");  // FCB=0 FCV=1
  cable.pulled = true;  // no answer: nothing is reported for it, the FCB stays
  link.request(req(dp::Service::SlaveDiag), now, count);
  EXPECT_EQ(t.lines.size(), 7u);
  EXPECT_EQ(t.lines[6], "> 68 05 05 68 83 82 7D 3C 3E FC 16");  // FCB=1 FCV=1
  cable.pulled = false;
  link.request(req(dp::Service::SlaveDiag), now, count);
  ASSERT_EQ(t.lines.size(), 11u);
  EXPECT_EQ(t.lines[7], std::string("> ") + kCapFdlStatus);   // the station was lost
  EXPECT_EQ(t.lines[9], std::string("> ") + kCapSlaveDiag1);  // FCB=1 FCV=0 again
  EXPECT_EQ(done, 4);
  link.reset();  // a restarted station: FDL_Status first
  link.request(req(dp::Service::SlaveDiag), now, count);
  EXPECT_EQ(t.lines[11], std::string("> ") + kCapFdlStatus);
}

}  // namespace
}  // namespace candp2::fdl::test
